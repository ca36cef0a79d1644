"""The grainfrac command line: specimen building and its error handling."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from grainfrac.cli import app

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "specimens"
runner = CliRunner()


def test_specimen_command_writes_every_output(tmp_path):
    out = tmp_path / "ucs"
    result = runner.invoke(app, ["specimen", str(EXAMPLES / "ucs-rectangle.toml"), "--out",
                                 str(out)])
    assert result.exit_code == 0, result.output
    for name in ("grains.vtu", "contacts.vtu", "specimen.png", "specimen.toml", "summary.json"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_grains"] > 3 and summary["n_elements"] > 100
    assert summary["specimen"] == "rectangle"
    assert "mineral volume fractions" in result.output


def test_every_example_specimen_validates(tmp_path):
    from grainfrac.assembly import load_specimen_config

    files = sorted(EXAMPLES.glob("*.toml"))
    assert len(files) >= 4
    for path in files:
        load_specimen_config(path)


def test_bad_specimen_gives_one_line_error(tmp_path):
    spec = tmp_path / "bad.toml"
    spec.write_text('[grains]\nmin_edge_mm = 9.0\nmax_edge_mm = 8.0\n')
    result = runner.invoke(app, ["specimen", str(spec), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1, result.output
    assert "grains.min_edge_mm" in lines[0] and "< max_edge_mm" in lines[0]
    assert not (tmp_path / "o").exists()


def test_missing_file_is_a_clear_error(tmp_path):
    result = runner.invoke(app, ["specimen", str(tmp_path / "nope.toml"), "--out",
                                 str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "file not found" in result.output


def test_flat_namespace_exposes_the_verbs():
    import grainfrac

    for name in ("build_specimen", "load_scenario", "run_scenario", "analyse_run",
                 "build_report"):
        assert callable(getattr(grainfrac, name)), name
    assert grainfrac.build_specimen({"specimen": {"shape": "rectangle"}}).n_grains > 3
