"""Observable runs (issue "Safe, observable runs", second half): history.csv written as
the run goes, checkpoints every N steps, interruptible equilibration, explicit times,
the crack catalogue's columns, code tables and the SCDA plug in the snapshots, one sign
convention, and the size estimate of 3D specimens.

The runs here are a 30 x 30 mm slab at 2 mm zones, a few hundred steps per stage.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainfrac.cli import app

runner = CliRunner()


# --------------------------------------------------------------------------- 3D size

SPEC_3D = """\
seed = 1
dimension = 3

[specimen]
shape = "slab"
width_mm = {w}
height_mm = {w}
thickness_mm = {t}
borehole_diameter_mm = 10.0

[grains]
min_edge_mm = 3.0
max_edge_mm = 8.0
zone_size_mm = {zone}
"""


@pytest.mark.parametrize(("w", "t", "zone", "field"), [
    (100.0, 100.0, 0.3, "grains.zone_size_mm"),  # the paper's cube at a fine zone
    (5000.0, 100.0, 2.0, "specimen.width_mm"),  # no zone the grains allow would do
])
def test_a_too_large_3d_specimen_is_refused_before_it_is_built(tmp_path, monkeypatch, w, t,
                                                              zone, field):
    from grainfrac import assembly

    def never(*args, **kwargs):
        raise AssertionError("the specimen was built")

    monkeypatch.setattr(assembly, "build_assembly", never)
    path = tmp_path / "cube.toml"
    path.write_text(SPEC_3D.format(w=w, t=t, zone=zone))
    result = runner.invoke(app, ["specimen", str(path), "--out", str(tmp_path / "out")])
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert field in lines[0] and "tetrahedra" in lines[0] and "3D" in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_the_3d_estimate_is_close_to_what_meshing_makes():
    from grainfrac.assembly import SpecimenConfig
    from grainfrac.io.config import validate
    from grainfrac.scenario import TETS_PER_ZONE_VOLUME, check_size, estimated_elements

    config = validate(SpecimenConfig, {"dimension": 3, "specimen": {
        "shape": "slab", "width_mm": 30.0, "height_mm": 30.0, "thickness_mm": 20.0,
        "borehole_diameter_mm": 10.0}, "grains": {"zone_size_mm": 2.0}})
    # 17692 tetrahedra measured for this slab (seed-independent to a few %).
    assert 17692 <= estimated_elements(config) <= 17692 * 9.0 / 8.0
    assert TETS_PER_ZONE_VOLUME == 9.0
    assert check_size(config) is config  # a small 3D slab passes


# --------------------------------------------------------------------------- runs

TINY = {
    "name": "tiny",
    "seed": 1,
    "specimen": {"shape": "slab", "width_mm": 30.0, "height_mm": 30.0,
                 "borehole_diameter_mm": 6.0},
    "stages": [{"kind": "equilibrate", "max_steps": 400}],
}
INJECT = {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 1.0, "time_step_ms": 0.01}


def _scenario(**changes):
    from grainfrac.io.config import validate
    from grainfrac.scenario import Scenario

    return validate(Scenario, {**TINY, **changes})


def _file(tmp_path, **changes):
    from grainfrac.scenario import write_resolved

    sc = _scenario(**changes)
    path = tmp_path / "tiny.toml"
    write_resolved(path, sc, sc.recipe())
    return path


def _run_cli_until(tmp_path, out, stages, signum, enough, **changes):
    """``grainfrac run`` of the tiny scenario, signalled once ``enough(lines)``; return
    (return code, stderr and stdout)."""
    from cli_interrupt import run_cli_until

    code, stderr, stdout = run_cli_until(_file(tmp_path, stages=stages, **changes), out,
                                         signum, enough)
    return code, stderr + stdout


def _csv(path):
    import csv

    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_history_is_on_disk_while_the_run_goes_and_a_resume_neither_loses_nor_repeats_rows(
        tmp_path):
    """Killed (SIGKILL: nothing runs after it) mid-injection, history.csv already holds
    the injection's rows; the resume drops the rows after its checkpoint and ends with
    the history of an uninterrupted run, row for row."""
    import signal

    from grainfrac.io.checkpoint import read_checkpoint
    from grainfrac.run import checkpoint_path
    from grainfrac.simulation import run_scenario

    stages = [{"kind": "equilibrate", "max_steps": 400}, INJECT]
    out = tmp_path / "killed"
    code, stderr = _run_cli_until(
        tmp_path, out, stages, signal.SIGKILL,
        lambda seen: len([s for s in seen if "stage 2/2 inject:" in s]) >= 5)
    assert code == -signal.SIGKILL, stderr
    rows = _csv(out / "history.csv")
    injecting = [r for r in rows if r["stage"] == "inject"]
    assert len(injecting) >= 4, rows  # flushed at each progress line, not at stage ends
    assert float(injecting[-1]["injected_volume_ml"]) > 0
    saved = read_checkpoint(checkpoint_path(out))["solver"]["time"]
    assert float(rows[-1]["time_s"]) > saved  # rows beyond the checkpoint: dropped on resume

    sc = _scenario(stages=stages)
    run_scenario(sc, sc.recipe(), out, resume=True)
    run_scenario(sc, sc.recipe(), tmp_path / "reference")
    assert (out / "history.csv").read_text() == \
        (tmp_path / "reference" / "history.csv").read_text()


def test_a_checkpoint_is_written_every_n_steps(tmp_path):
    from grainfrac.io.checkpoint import read_checkpoint
    from grainfrac.run import checkpoint_path
    from grainfrac.simulation import run_scenario

    out = tmp_path / "run"
    seen: list[int] = []

    class Stop(Exception):
        pass

    def look(p):
        # Called after each chunk, before the run decides on a checkpoint.
        if checkpoint_path(out).is_file():
            seen.append(int(read_checkpoint(checkpoint_path(out))["solver"]["step_count"]))
        if len(seen) >= 2:
            raise Stop

    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 20_000,
                            "unbalanced_ratio": 1e-12}],
                   output={"checkpoint_every_steps": 4000})
    with pytest.raises(Stop):
        run_scenario(sc, sc.recipe(), out, progress=look)
    # Equilibrate chunks are 2000 steps: the first checkpoint after the 2nd chunk, none
    # after the 3rd (the tiny slab settles after the 4th, a stage end).
    assert seen == [4000, 4000]


@pytest.mark.parametrize("value", ["0", "-5", "2.5", '"often"', "1e12"])
def test_checkpoint_every_steps_is_validated_with_its_range(tmp_path, value):
    path = _file(tmp_path)
    path.write_text(path.read_text().replace(
        "[output]\n", f"[output]\ncheckpoint_every_steps = {value}\n"))
    result = runner.invoke(app, ["run", str(path), "--out", str(tmp_path / "out")])
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "output.checkpoint_every_steps" in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_sigint_in_the_equilibrate_stage_checkpoints_and_prints_the_resume_command(tmp_path):
    import signal

    from grainfrac.io.checkpoint import read_checkpoint
    from grainfrac.run import checkpoint_path
    from grainfrac.simulation import run_scenario

    stages = [{"kind": "equilibrate", "max_steps": 40_000, "unbalanced_ratio": 1e-12},
              {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 0.03,
               "time_step_ms": 0.01}]
    out = tmp_path / "interrupted"
    # An 80 mm slab settles in some 10 chunks: the signal comes well inside the stage.
    slab = {"shape": "slab", "width_mm": 80.0, "height_mm": 80.0, "borehole_diameter_mm": 6.0}
    code, stderr = _run_cli_until(
        tmp_path, out, stages, signal.SIGINT,
        lambda seen: any("stage 1/2 equilibrate:" in s for s in seen), specimen=slab)
    assert code == 130, stderr
    assert "Traceback" not in stderr
    assert "interrupted by SIGINT in stage 1 (equilibrate)" in stderr
    assert f"grainfrac run --resume --out {out}" in stderr
    records = read_checkpoint(checkpoint_path(out))
    assert records["driver"]["stage_index"] == 0  # inside the stage, not after it
    assert 0 < records["stages/0"]["steps"] < 40_000
    assert not (out / "summary.json").exists()

    sc = _scenario(stages=stages, specimen=slab)
    resumed = run_scenario(sc, sc.recipe(), out, resume=True)
    reference = run_scenario(sc, sc.recipe(), tmp_path / "reference")
    assert {k: v for k, v in resumed.items() if k != "wall_time_s"} == \
        {k: v for k, v in reference.items() if k != "wall_time_s"}
    assert (out / "history.csv").read_text() == \
        (tmp_path / "reference" / "history.csv").read_text()


# --------------------------------------------------------------------------- times, cracks

BREAKDOWN = [{"kind": "equilibrate", "max_steps": 400},
             {"kind": "inject", "rate_ml_per_min": 150.0, "duration_ms": 3.0,
              "time_step_ms": 0.01}]


@pytest.fixture(scope="module")
def broken(tmp_path_factory):
    """A tiny slab injected to breakdown (about 20 cracks)."""
    from grainfrac.simulation import run_scenario

    out = tmp_path_factory.mktemp("broken") / "run"
    sc = _scenario(stages=BREAKDOWN)
    return out, run_scenario(sc, sc.recipe(), out)


def test_summary_times_say_which_clock_they_read(broken):
    out, summary = broken
    start = summary["stage_times_s"]["inject"][0]
    assert summary["injection_start_time_s"] == start > 0
    assert summary["breakdown_time_s"] is not None
    # breakdown_time_s keeps its meaning: from the start of injection.
    assert summary["breakdown_time_from_injection_s"] == summary["breakdown_time_s"]
    assert summary["breakdown_time_absolute_s"] == pytest.approx(
        start + summary["breakdown_time_s"], rel=1e-12)
    history = _csv(out / "history.csv")
    by_stage = {kind: t0 for kind, (t0, _) in summary["stage_times_s"].items()}
    for row in history:
        assert float(row["time_from_stage_start_s"]) == pytest.approx(
            float(row["time_s"]) - by_stage[row["stage"]], abs=1e-15)


def test_cracks_csv_names_contact_stage_orientation_length_and_grains(broken):
    import meshio
    import numpy as np

    from grainfrac.io.results import CRACK_COLUMNS

    out, summary = broken
    text = (out / "cracks.csv").read_text()
    header = text.splitlines()[0].split(",")
    assert header[:6] == ["time_s", "x_mm", "y_mm", "mode", "contact_type", "energy_J"]
    assert header == CRACK_COLUMNS
    rows = _csv(out / "cracks.csv")
    assert len(rows) == summary["n_cracks"] > 0
    contacts = meshio.read(sorted((out / "snapshots").glob("contacts_*.vtu"))[-1])
    normals = contacts.cell_data["normal"][0]
    lengths = contacts.cell_data["area_m2"][0] / 10e-3  # the slab is 10 mm thick
    inject_start = summary["stage_times_s"]["inject"][0]
    for row in rows:
        c = int(row["contact"])
        assert row["stage"] == "inject"  # equilibrate holds the bonds elastic
        assert float(row["time_from_stage_start_s"]) == pytest.approx(
            float(row["time_s"]) - inject_start, abs=1e-15)
        n = np.array([float(row["normal_x"]), float(row["normal_y"])])
        assert np.allclose(n, normals[c, :2])
        angle = float(row["normal_angle_deg"])
        assert 0 <= angle < 180
        assert np.isclose(np.tan(np.radians(angle)) * n[0], n[1], atol=1e-9) or \
            abs(n[0]) < 1e-9
        assert float(row["length_mm"]) == pytest.approx(lengths[c] * 1e3, rel=1e-9)
        assert int(row["grain_a"]) != int(row["grain_b"])
        assert float(row["energy_J"]) > 0


def test_the_stage_of_a_crack_is_the_last_stage_begun_before_it():
    import numpy as np

    from grainfrac.physics.cracks import CrackCatalogue

    cat = CrackCatalogue(contact=np.arange(4), time=np.array([0.5, 1.0, 1.0 + 1e-9, 3.0]),
                         x=np.zeros(4), y=np.zeros(4), mode=np.ones(4, dtype=int),
                         pair=np.zeros(4, dtype=int), energy=np.zeros(4))
    stage, start = cat.stage_of([("equilibrate", 0.0), ("scda", 1.0), ("inject", 2.0)])
    # A crack is timed at the end of its step: one at a stage's start time is the earlier's.
    assert stage == ["equilibrate", "equilibrate", "scda", "inject"]
    assert list(start) == [0.0, 0.0, 1.0, 2.0]


# --------------------------------------------------------------------------- snapshots


def _metadata(mesh):
    import json

    import numpy as np

    from grainfrac.io.vtk import METADATA_FIELD

    return json.loads(bytes(np.asarray(mesh.field_data[METADATA_FIELD], dtype=np.uint8)
                            ).decode("utf-8"))


@pytest.fixture(scope="module")
def charged(tmp_path_factory):
    """A tiny slab charged with SCDA for 0.3 ms, then drilled out."""
    from grainfrac.simulation import run_scenario

    out = tmp_path_factory.mktemp("charged") / "run"
    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 400},
                           {"kind": "scda", "max_duration_ms": 0.3}, {"kind": "drill_out"}],
                   output={"snapshot_every_ms": 0.1})
    return out, run_scenario(sc, sc.recipe(), out)


def test_snapshots_of_the_scda_stage_hold_the_plug_with_its_pressure(charged):
    import xml.etree.ElementTree as ET

    import meshio
    import numpy as np

    out, summary = charged
    snaps = out / "snapshots"
    pvd = ET.parse(snaps / "series.pvd").getroot()
    plug_sets = [d for d in pvd.iter("DataSet") if d.get("part") == "2"]
    assert plug_sets, "no plug in series.pvd"
    start, end = summary["stage_times_s"]["scda"]
    for d in plug_sets:
        assert d.get("file").startswith("scda_")
        assert start < float(d.get("timestep")) <= end + 1e-12
        assert (snaps / d.get("file")).is_file()
    # After the drill-out no snapshot has a plug.
    last = max(pvd.iter("DataSet"), key=lambda d: float(d.get("timestep")))
    assert not (snaps / last.get("file").replace("grains_", "scda_")).exists()
    plug = meshio.read(snaps / plug_sets[-1].get("file"))
    assert plug.cells[0].type == "triangle" and len(plug.cells[0].data) > 0
    wall = plug.cell_data["expansive_pressure_Pa"][0]
    assert np.all(wall == wall[0]) and wall[0] > 0  # compression positive
    assert summary["peak_expansive_pressure_MPa"] * 1e6 >= wall[0]
    assert np.mean(plug.cell_data["pressure_Pa"][0]) > 0  # the agent is compressed
    assert _metadata(plug)["sign_convention"] == "compression positive"


def test_every_vtu_carries_the_code_tables_of_legend_json(charged, tmp_path):
    import json

    import meshio

    from grainfrac.assembly import build_assembly
    from grainfrac.io.vtk import write_assembly
    from grainfrac.physics.codes import code_tables

    out, _ = charged
    legend = json.loads((out / "legend.json").read_text())
    files = sorted((out / "snapshots").glob("*.vtu"))
    assert any(f.name.startswith("scda_") for f in files)
    for path in files:
        meta = _metadata(meshio.read(path))
        assert meta["codes"] == legend["codes"], path.name
        assert meta["sign_conventions"] == legend["sign_conventions"]
    assert set(legend["codes"]) == {"mineral", "contact_type", "mode", "failed", "fissure"}
    # grainfrac specimen's files carry them too.
    sc = _scenario()
    assembly = build_assembly(sc.specimen_config(), sc.recipe())
    for path in write_assembly(assembly, tmp_path):
        assert _metadata(meshio.read(path))["codes"] == code_tables(assembly)


def test_one_sign_convention_in_files_summary_and_figures(tmp_path, monkeypatch):
    """A slab compressed by the in-situ stress (2.5 and 5 MPa) reads compressed, with a
    positive sign, in every output: grain stress and contact normal stress in the
    snapshots, the hoop stress in history.csv, legend.json, the snapshots' metadata,
    summary.json and the stress and pressure labels of the figures as drawn."""
    import json

    import matplotlib.figure
    import meshio
    import numpy as np

    from grainfrac.simulation import run_scenario

    labels: dict[str, list[str]] = {}
    save = matplotlib.figure.Figure.savefig

    def spy(fig, path, *args, **kwargs):
        labels[fig.axes[0].get_title() + str(len(labels))] = [
            text for ax in fig.axes for text in (ax.get_xlabel(), ax.get_ylabel()) if text]
        return save(fig, path, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    out = tmp_path / "run"
    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 4000},
                           {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 0.02,
                            "time_step_ms": 0.01}])
    summary = run_scenario(sc, sc.recipe(), out)
    convention = "compression positive"
    assert summary["sign_convention"] == convention
    assert json.loads((out / "legend.json").read_text())["sign_convention"] == convention
    grains = meshio.read(sorted((out / "snapshots").glob("grains_*.vtu"))[-1])
    contacts = meshio.read(sorted((out / "snapshots").glob("contacts_*.vtu"))[-1])
    assert "stress_Pa" not in grains.cell_data  # renamed with its sign: no silent flip
    stress = grains.cell_data["stress_compression_positive_Pa"][0]
    area = np.ones(len(stress))
    assert np.average(stress[:, 0], weights=area) > 1e6  # sigma_x 2.5 MPa
    assert np.average(stress[:, 1], weights=area) > 2e6  # sigma_y 5 MPa
    assert np.median(contacts.cell_data["normal_stress_Pa"][0]) > 0
    for mesh in (grains, contacts):
        assert _metadata(mesh)["sign_convention"] == convention
    hoop = [float(r["tangential_stress_near_well_MPa"]) for r in _csv(out / "history.csv")]
    assert hoop[-1] > 0
    stress_labels = [t for texts in labels.values() for t in texts
                     if "stress" in t or "pressure" in t]
    assert any("principal stress" in t for t in stress_labels), labels
    assert any("well pressure" in t for t in stress_labels), labels
    for text in stress_labels:
        assert "compression +" in text, text


# --------------------------------------------------------------------------- progress bar


def test_the_progress_bar_shows_the_stages_simulated_time_of_its_plan_and_an_eta(tmp_path):
    import io

    from rich.console import Console

    from grainfrac.run import Progress
    from grainfrac.runner import _fields, run_with_progress

    fields = _fields(Progress(1, "inject", 2, 0.0031, 0.25, 3, 4e6, 0.0,
                              stage_time_s=0.0005, stage_planned_s=0.002, eta_s=12.4))
    assert fields["stage_time"] == "stage 0.500/2.000 ms" and fields["eta"] == "12 s"
    assert fields["completed"] == 1.25
    fields = _fields(Progress(0, "equilibrate", 2, 0.0001, 0.4, 0, 0.0, 0.0))
    assert fields["stage_time"] == "stage  40 % of max_steps" and fields["eta"] == "-"

    sc_path = _file(tmp_path, stages=[{"kind": "equilibrate", "max_steps": 400},
                                      {"kind": "inject", "rate_ml_per_min": 90.0,
                                       "duration_ms": 0.05, "time_step_ms": 0.01}])
    buffer = io.StringIO()
    console = Console(file=buffer, force_terminal=True, width=200, color_system=None)
    run_with_progress(sc_path, tmp_path / "run", console=console)
    text = buffer.getvalue()
    assert "2/2 inject" in text and "/0.050 ms" in text and "ETA" in text, text[-2000:]
