"""HTML report: self-contained, every figure renders in headless Chromium, comparison page."""

from __future__ import annotations

import json
import re
import shutil

import pytest
from headless_chromium import CHROMIUM, assert_renders
from typer.testing import CliRunner

from grainfrac.cli import app
from grainfrac.io.config import validate
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario
from grainfrac.viz.report import build_report


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A short HS run and a copy under another name: enough for a comparison page."""
    root = tmp_path_factory.mktemp("runs")
    sc = validate(Scenario, {
        "name": "small-hs", "seed": 1,
        "specimen": {"shape": "slab", "width_mm": 60.0, "height_mm": 60.0},
        "stages": [{"kind": "equilibrate"},
                   {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 5.0,
                    "time_step_ms": 0.1}],
    })
    first = root / "hs-a"
    run_scenario(sc, sc.recipe(), first)
    second = root / "hs-b"
    shutil.copytree(first, second)
    summary = json.loads((second / "summary.json").read_text())
    summary["scenario"] = "small-hs-copy"
    (second / "summary.json").write_text(json.dumps(summary))
    return first, second


def _report(runs, tmp_path):
    out = tmp_path / "report.html"
    build_report(list(runs), out)
    return out, out.read_text()


def test_report_is_self_contained(runs, tmp_path):
    _, page = _report(runs, tmp_path)
    images = re.findall(r"<img [^>]*src=\"([^\"]{0,40})", page)
    assert len(images) >= 8 and all(s.startswith("data:image/png;base64,") for s in images)
    assert not re.search(r"(src|href)=\"https?://", page)
    assert "Comparison" in page and "small-hs-copy" in page
    assert "breakdown pressure (MPa)" in page and "[[stages]]" in page
    print(f"\nreport: {len(images)} embedded figures, {len(page) / 1e6:.2f} MB")


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (installed by .ci/run)")
def test_report_renders_every_figure_in_headless_chromium(runs, tmp_path):
    path, _ = _report(runs, tmp_path)
    assert_renders(path, tmp_path)


def test_report_cli(runs, tmp_path):
    result = CliRunner().invoke(app, ["report", str(runs[0])])
    assert result.exit_code == 0, result.output
    assert (runs[0] / "report.html").is_file()
    result = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert result.exit_code == 2 and "no summary.json" in result.output
