"""The grainfrac command line: specimen building and its error handling."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
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


def _radial_run_dir(path: Path) -> Path:
    """A hand-made SCDA run directory: four radial crack lines from the 5 mm well wall
    out to 12 mm (at 0, 90, 180, 270 deg) and two out to 8.5 mm (at 135, 315 deg),
    cracks 1 mm apart."""
    path.mkdir()
    (path / "config.toml").write_text(
        '[specimen]\nborehole_diameter_mm = 10.0\n[grains]\nzone_size_mm = 2.0\n')
    (path / "history.csv").write_text(
        "time_s,stage,well_pressure_MPa,expansive_pressure_MPa\n"
        "0.001,scda,0.0,20.0\n0.002,scda,0.0,45.0\n")
    rows = ["time_s,x_mm,y_mm,mode,contact_type,energy_J"]
    for angle, end in ((0, 12), (90, 12), (180, 12), (270, 12), (135, 8.5), (315, 8.5)):
        c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        for r in np.arange(5.5, end + 0.01, 1.0):
            rows.append(f"0.002,{r * c:.6f},{r * s:.6f},tensile,F-Q,1e-6")
    (path / "cracks.csv").write_text("\n".join(rows) + "\n")
    return path


def test_analyse_recounts_radial_fractures_at_other_circles(tmp_path):
    run = _radial_run_dir(tmp_path / "scda")
    result = runner.invoke(app, ["analyse", str(run), "--radius-mm", "8", "--radius-mm", "10",
                                 "--json"])
    assert result.exit_code == 0, result.output
    got = json.loads(result.output)[str(run)]
    assert got["n_radial_fractures_by_radius_mm"] == {"8": 6, "10": 4}
    assert got["n_cracks"] == 4 * 7 + 2 * 4
    assert got["peak_expansive_pressure_MPa"] == 45.0
    assert got["fracture_extent_mm"] == pytest.approx(11.5)
    table = runner.invoke(app, ["analyse", str(run)], env={"COLUMNS": "200"})
    assert table.exit_code == 0, table.output
    assert "radial" in table.output and "11.5" in table.output


def test_analyse_rejects_a_circle_inside_the_borehole(tmp_path):
    run = _radial_run_dir(tmp_path / "scda")
    result = runner.invoke(app, ["analyse", str(run), "--radius-mm", "4"])
    assert result.exit_code == 2
    assert "radius_mm" in result.output and "> 5 mm" in result.output
    missing = runner.invoke(app, ["analyse", str(tmp_path / "nope")])
    assert missing.exit_code == 2 and "not a run directory" in missing.output


def test_verify_zone_size_is_checked_before_any_compute():
    # A case without a zone size, and a size out of range: one line naming the option.
    result = runner.invoke(app, ["verify", "cubic-law", "--zone-size", "1.4"])
    assert result.exit_code == 2
    assert "--zone-size" in result.output and "cubic-law" in result.output
    result = runner.invoke(app, ["verify", "kirsch3d", "--zone-size", "0.1"])
    assert result.exit_code == 2
    assert "--zone-size" in result.output
    # Only the 3D Kirsch cases refine their wall.
    result = runner.invoke(app, ["verify", "kirsch", "--wall-zone-size", "1"])
    assert result.exit_code == 2
    assert "--wall-zone-size" in result.output and "kirsch" in result.output


def test_verify_equilibrium_is_checked_and_passed_to_the_elastic_cases(monkeypatch):
    from grainfrac import verification
    from grainfrac.verification.report import Comparison

    result = runner.invoke(app, ["verify", "kirsch", "--equilibrium", "implicit"])
    assert result.exit_code == 2
    assert "--equilibrium" in result.output and "'static' or 'explicit'" in result.output
    result = runner.invoke(app, ["verify", "cubic-law", "--equilibrium", "explicit"])
    assert result.exit_code == 2
    assert "--equilibrium" in result.output and "cubic-law" in result.output
    calls = []

    def case(seed: int = 0, equilibrium: str = "static") -> list[Comparison]:
        calls.append(equilibrium)
        return [Comparison("kirsch", "x_MPa", 1.0, 1.0, 0.1)]

    monkeypatch.setitem(verification.CASES, "kirsch", case)
    for option in ([], ["--equilibrium", "explicit"]):
        assert runner.invoke(app, ["verify", "kirsch", "--json", *option]).exit_code == 0
    assert calls == ["static", "explicit"]
