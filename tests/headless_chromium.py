"""Render a report in headless Chromium and check every figure decoded and the page is
not blank. Shared by ``test_report.py`` (2D runs) and ``test_hydromechanics3d.py`` (a
3D run)."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--virtual-time-budget=5000"]


def assert_renders(page: Path, scratch: Path) -> None:
    """Every ``<img>`` of ``page`` decodes, no script error, and a screenshot has ink."""
    n_images = len(re.findall(r"<img ", page.read_text()))
    dom = subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={scratch / 'p1'}",
                          "--enable-logging=stderr", "--v=0", "--dump-dom", page.as_uri()],
                         capture_output=True, text=True, timeout=120)
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert "Uncaught" not in dom.stderr
    body = re.search(r"<body[^>]*>", dom.stdout).group(0)
    assert f'data-images="{n_images}"' in body
    assert f'data-images-loaded="{n_images}"' in body, body

    shot = scratch / "shot.png"
    subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={scratch / 'p2'}",
                    "--window-size=1200,2000", f"--screenshot={shot}", page.as_uri()],
                   capture_output=True, timeout=120, check=True)
    import matplotlib.image as mpimg

    pixels = mpimg.imread(shot)[..., :3]
    spread = float(pixels.std())
    print(f"\nchromium: {n_images} of {n_images} images decoded; screenshot pixel std "
          f"{spread:.3f} (blank page: 0)")
    assert spread > 0.05
    assert np.mean(pixels < 0.9) > 0.02  # some ink on the page
