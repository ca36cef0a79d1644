"""Run ``grainfrac run`` in a subprocess and signal it once its progress lines say so.

Shared by the interrupt tests (``test_safe_runs.py``, ``test_observability.py``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path


def run_cli_until(scenario: Path, out: Path, signum: int,
                  enough: Callable[[list[str]], bool]) -> tuple[int, str, str]:
    """``grainfrac run SCENARIO --out OUT`` with a progress line every chunk on stderr;
    send ``signum`` once ``enough(lines so far)``. Returns (return code, stderr, stdout)."""
    env = {**os.environ, "GRAINFRAC_LOG_EVERY_S": "0.001"}
    proc = subprocess.Popen([sys.executable, "-m", "grainfrac.cli", "run", str(scenario),
                             "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    seen: list[str] = []
    try:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line:
                break
            seen.append(line)
            if enough(seen):
                proc.send_signal(signum)
                break
        rest_out, rest_err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, "".join(seen) + rest_err, rest_out
