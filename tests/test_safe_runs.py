"""Run directories that cannot be mixed up (issue 42): fingerprint, lock, overwrite.

Each defect of the issue is reproduced: a resume that continued another
scenario's checkpoint, ``--resume`` ignoring a scenario or seed given with it,
two processes writing one ``--out``, and leftovers of an earlier run in a
re-used directory. The refusals come before any compute, so most tests here
run nothing; the runs that do are an equilibrate stage of a few hundred steps.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

from grainfrac.cli import app
from grainfrac.errors import CheckpointError
from grainfrac.io.config import validate
from grainfrac.io.files import directory_lock
from grainfrac.run import FINGERPRINT_FILE, RunDirectoryError, checkpoint_path, fingerprint
from grainfrac.scenario import Scenario, write_resolved
from grainfrac.simulation import run_scenario

TINY = {
    "name": "tiny",
    "seed": 1,
    "specimen": {"shape": "slab", "width_mm": 30.0, "height_mm": 30.0,
                 "borehole_diameter_mm": 6.0},
    "stages": [{"kind": "equilibrate", "max_steps": 400}],
}
runner = CliRunner()


def _scenario(**changes) -> Scenario:
    return validate(Scenario, {**TINY, **changes})


def _file(tmp_path: Path, filename: str = "tiny.toml", **changes) -> Path:
    sc = _scenario(**changes)
    path = tmp_path / filename
    write_resolved(path, sc, sc.recipe())
    return path


def _one_line(result) -> str:
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code != 0 and len(lines) == 1, result.output
    assert "Traceback" not in result.output
    return lines[0]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished tiny run (run A)."""
    out = tmp_path_factory.mktemp("a") / "run"
    sc = _scenario()
    return out, run_scenario(sc, sc.recipe(), out)


def test_a_run_directory_carries_its_fingerprint(finished):
    out, summary = finished
    written = json.loads((out / FINGERPRINT_FILE).read_text())
    sc = _scenario()
    assert written == fingerprint(sc, sc.recipe())
    assert set(written) == {"scenario_sha256", "scenario", "seed", "grainfrac_version"}
    assert written["seed"] == 1 and written["scenario"] == "tiny"
    assert fingerprint(sc.with_seed(2), sc.recipe())["scenario_sha256"] != \
        written["scenario_sha256"]


def test_a_new_run_into_a_used_directory_is_refused(finished, tmp_path):
    out, _ = finished
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    result = runner.invoke(app, ["run", str(_file(tmp_path, seed=2)), "--out", str(out)])
    line = _one_line(result)
    assert "not empty" in line and "--overwrite" in line and "--resume" in line
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before


def test_overwrite_clears_what_an_earlier_run_left(finished, tmp_path):
    out = tmp_path / "reused"
    import shutil

    shutil.copytree(finished[0], out)
    # A well-pressure figure and snapshots of a run that injected; this one does not.
    (out / "figures" / "well_pressure.png").write_bytes(b"old")
    (out / "snapshots").mkdir(exist_ok=True)
    (out / "snapshots" / "grains_0042.vtu").write_text("old")
    result = runner.invoke(app, ["run", str(_file(tmp_path, seed=2)), "--out", str(out),
                                 "--overwrite"])
    assert result.exit_code == 0, result.output
    assert not (out / "figures" / "well_pressure.png").exists()
    assert not (out / "snapshots" / "grains_0042.vtu").exists()
    assert json.loads((out / "summary.json").read_text())["seed"] == 2
    assert json.loads((out / FINGERPRINT_FILE).read_text())["seed"] == 2


def test_overwrite_never_clears_a_directory_grainfrac_did_not_write(tmp_path):
    out = tmp_path / "home"
    out.mkdir()
    (out / "thesis.tex").write_text("years of work")
    result = runner.invoke(app, ["run", str(_file(tmp_path)), "--out", str(out),
                                 "--overwrite"])
    line = _one_line(result)
    assert "thesis.tex" in line and "not cleared" in line
    assert (out / "thesis.tex").read_text() == "years of work"


def test_resume_refuses_another_seed_or_scenario(finished, tmp_path):
    out, _ = finished
    stamp = (out / "summary.json").stat().st_mtime_ns
    line = _one_line(runner.invoke(app, ["run", "--resume", "--out", str(out), "--seed", "5"]))
    assert "another run" in line and "seed 1, not 5" in line
    other = _file(tmp_path, filename="other.toml", stress={"case": "case3"})
    line = _one_line(runner.invoke(app, ["run", str(other), "--resume", "--out", str(out)]))
    assert "another run" in line and "stress" in line
    renamed = _file(tmp_path, filename="renamed.toml", name="b")
    line = _one_line(runner.invoke(app, ["run", str(renamed), "--resume", "--out", str(out)]))
    assert "scenario 'tiny', not 'b'" in line
    assert (out / "summary.json").stat().st_mtime_ns == stamp


def test_resume_with_the_runs_own_scenario_file_is_accepted(finished, tmp_path):
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(finished[0], out)
    result = runner.invoke(app, ["run", str(_file(tmp_path)), "--resume", "--out", str(out),
                                 "--seed", "1"])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert {k: v for k, v in summary.items() if k != "wall_time_s"} == \
        {k: v for k, v in finished[1].items() if k != "wall_time_s"}


def test_a_run_killed_before_its_first_checkpoint_never_resumes_into_another(finished,
                                                                           tmp_path):
    """The issue's case: B started into A's directory, killed before its first
    checkpoint, resumed into A's numbers under B's name."""
    import shutil

    out = tmp_path / "ab"
    shutil.copytree(finished[0], out)
    b = _scenario(name="b", seed=9)

    class Killed(Exception):
        pass

    def kill(p):
        raise Killed

    with pytest.raises(RunDirectoryError, match="not empty"):
        run_scenario(b, b.recipe(), out, progress=kill)
    with pytest.raises(Killed):
        run_scenario(b, b.recipe(), out, overwrite=True, progress=kill)
    assert not checkpoint_path(out).exists()  # A's checkpoint went with --overwrite
    with pytest.raises(Exception, match="nothing to resume"):
        run_scenario(b, b.recipe(), out, resume=True)
    # A checkpoint copied in from A is refused by its own fingerprint too.
    checkpoint_path(out).parent.mkdir()
    shutil.copy(checkpoint_path(finished[0]), checkpoint_path(out))
    with pytest.raises(CheckpointError, match="another run"):
        run_scenario(b, b.recipe(), out, resume=True)


def test_resume_without_a_fingerprint_is_refused(tmp_path):
    out = tmp_path / "old"
    out.mkdir()
    write_resolved(out / "config.toml", _scenario(), _scenario().recipe())
    line = _one_line(runner.invoke(app, ["run", "--resume", "--out", str(out)]))
    assert FINGERPRINT_FILE in line
    line = _one_line(runner.invoke(app, ["run", "--resume", "--out", str(tmp_path / "none")]))
    assert "no run to continue" in line


def test_a_second_writer_of_one_out_is_refused(tmp_path):
    out = tmp_path / "busy"
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(f"""
            import sys, time
            from grainfrac.io.files import directory_lock
            with directory_lock({str(out)!r}):
                print("locked", flush=True)
                sys.stdin.read()
            """)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        line = _one_line(runner.invoke(app, ["run", str(_file(tmp_path)), "--out", str(out)]))
        assert "in use by another process" in line
        line = _one_line(runner.invoke(app, ["run", "--resume", "--out", str(out)]))
        assert "no run to continue" in line or "in use" in line
    finally:
        holder.stdin.close()
        holder.wait(timeout=30)
    assert sorted(p.name for p in out.iterdir()) == ["run.lock"]
    # The lock went with the process: the directory is free (and counts as empty).
    with directory_lock(out):
        pass


def test_the_lock_is_held_in_process_too(tmp_path):
    out = tmp_path / "held"
    sc = _scenario()
    with directory_lock(out), pytest.raises(RunDirectoryError, match="in use"):
        run_scenario(sc, sc.recipe(), out)


@pytest.mark.parametrize("where", ["file", "under-file"])
def test_an_out_that_is_a_file_is_one_line(tmp_path, where):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    out = blocker if where == "file" else blocker / "run"
    line = _one_line(runner.invoke(app, ["run", str(_file(tmp_path)), "--out", str(out)]))
    assert "a file is in the way" in line


def test_an_unwritable_out_is_one_line(tmp_path):
    import os

    parent = tmp_path / "ro"
    parent.mkdir()
    parent.chmod(0o500)
    try:
        if os.access(parent, os.W_OK):
            pytest.skip("running as a user who can write anywhere (root)")
        line = _one_line(runner.invoke(app, ["run", str(_file(tmp_path)), "--out",
                                             str(parent / "run")]))
        assert "cannot be written" in line
    finally:
        parent.chmod(0o700)


def test_resume_and_overwrite_together_are_refused(tmp_path):
    line = _one_line(runner.invoke(app, ["run", str(_file(tmp_path)), "--resume",
                                         "--overwrite", "--out", str(tmp_path / "x")]))
    assert "--resume" in line and "--overwrite" in line


# --------------------------------------------------------------------------- physics fixes

RATE_ML_PER_MIN = 90.0


@pytest.mark.parametrize("time_step_ms", [1e-5, 3e-4, 0.0123, 0.02])
def test_the_injected_volume_is_rate_times_simulated_time(tmp_path, time_step_ms):
    """For any fluid step, also one below the mechanical step (1.14e-4 ms here): before
    the fix a 1e-5 ms step injected rate x 1e-8 s per 1.14e-7 s step, 8.8 % of the volume."""
    duration_ms = 0.05
    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 400},
                           {"kind": "inject", "rate_ml_per_min": RATE_ML_PER_MIN,
                            "duration_ms": duration_ms, "time_step_ms": time_step_ms}])
    summary = run_scenario(sc, sc.recipe(), tmp_path / "run")
    start, end = summary["stage_times_s"]["inject"]
    rate = RATE_ML_PER_MIN / 60.0  # ml/s
    assert summary["injected_volume_ml"] == pytest.approx(rate * (end - start), rel=1e-9)
    dt_mech = 1.1405086202083206e-07  # the tiny slab's mechanical step (s)
    assert duration_ms * 1e-3 <= end - start < duration_ms * 1e-3 + dt_mech * (1 + 1e-9)


def test_a_volume_limited_injection_stops_within_a_mechanical_step_of_it(tmp_path):
    volume_ml = 1e-3
    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 400},
                           {"kind": "inject", "rate_ml_per_min": RATE_ML_PER_MIN,
                            "volume_ml": volume_ml, "time_step_ms": 0.01}])
    summary = run_scenario(sc, sc.recipe(), tmp_path / "run")
    start, end = summary["stage_times_s"]["inject"]
    rate = RATE_ML_PER_MIN / 60.0
    assert summary["injected_volume_ml"] == pytest.approx(rate * (end - start), rel=1e-9)
    assert volume_ml <= summary["injected_volume_ml"] < volume_ml + rate * 1.15e-7


def test_an_unsettled_equilibrate_stage_warns_in_the_summary_and_the_log(finished, caplog):
    out, summary = finished  # max_steps = 400 leaves the tiny slab at a ratio above 1e-5
    assert summary["in_situ_unbalanced_force_ratio"] > 1e-5
    (warning,) = [w for w in summary["warnings"] if w.startswith("equilibrate")]
    assert "max_steps = 400" in warning and "target 1e-05" in warning
    assert warning in json.loads((out / "summary.json").read_text())["warnings"]
    import logging

    from grainfrac.stages import Equilibrate
    from grainfrac.stages.equilibrate import EquilibrateState

    stage = Equilibrate(1e6, 1e6, ratio=1e-5, max_steps=400,
                        state=EquilibrateState(done=True, steps=400,
                                               unbalanced_force_ratio=0.5, converged=False))
    assert "ratio 0.5" in stage.unsettled_warning()
    stage.state.converged = True
    assert stage.unsettled_warning() is None
    with caplog.at_level(logging.WARNING, logger="grainfrac"):
        sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 50}])
        run_scenario(sc, sc.recipe(), out.parent / "fifty")
    assert any("max_steps = 50" in r.getMessage() for r in caplog.records)


# --------------------------------------------------------------------------- observability


def test_every_run_directory_has_a_log(finished):
    out, summary = finished
    text = (out / "run.log").read_text()
    assert "starting run 'tiny', seed 1" in text
    assert "stage 1/1 equilibrate done" in text and "done in" in text
    # The unsettled equilibrium is in the log as well as in summary.json.
    assert "WARNING equilibrate: the in-situ stress had not settled" in text


def test_progress_lines_name_stage_time_cracks_pressure_and_eta(tmp_path):
    sc = _scenario(stages=[{"kind": "equilibrate", "max_steps": 400},
                           {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 0.03,
                            "time_step_ms": 0.01}])
    run_scenario(sc, sc.recipe(), tmp_path / "run", log_every_s=0.0)
    lines = [ln for ln in (tmp_path / "run" / "run.log").read_text().splitlines()
             if "stage 2/2 inject:" in ln]
    assert len(lines) == 3, lines
    for word in ("t = ", "% of the stage", "cracks", "well ", "MPa", "ETA of the stage"):
        assert word in lines[0], lines[0]


def test_sigint_mid_injection_checkpoints_and_resume_gives_the_uninterrupted_result(tmp_path):
    """``grainfrac run`` off a terminal: progress lines on stderr while it runs; SIGINT
    in the injection stops it with a checkpoint and the resume command; the resumed
    run's summary and cracks are those of an uninterrupted run."""
    import signal

    from cli_interrupt import run_cli_until

    stages = [{"kind": "equilibrate", "max_steps": 400},
              {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 1.0,
               "time_step_ms": 0.01}]
    out = tmp_path / "interrupted"

    def enough(seen: list[str]) -> bool:
        line = seen[-1]
        return "stage 2/2 inject:" in line and "t = " in line and len(
            [s for s in seen if "inject:" in s]) >= 5

    code, stderr, stdout = run_cli_until(_file(tmp_path, stages=stages), out,
                                         signal.SIGINT, enough)
    assert code == 130, stderr + stdout
    assert "Traceback" not in stderr
    assert f"grainfrac run --resume --out {out}" in stderr
    assert checkpoint_path(out).is_file() and not (out / "summary.json").exists()

    sc = _scenario(stages=stages)
    resumed = run_scenario(sc, sc.recipe(), out, resume=True)
    reference = run_scenario(sc, sc.recipe(), tmp_path / "reference")
    strip = ("wall_time_s",)
    assert {k: v for k, v in resumed.items() if k not in strip} == \
        {k: v for k, v in reference.items() if k not in strip}
    assert (out / "cracks.csv").read_text() == (tmp_path / "reference" / "cracks.csv").read_text()
    log = (out / "run.log").read_text()
    assert "interrupted by SIGINT in stage 2 (inject)" in log and "resuming run" in log


# --------------------------------------------------------------------------- legend


def test_legend_names_every_code_in_the_files_and_the_sign_conventions(finished):
    import meshio
    import numpy as np

    out, _ = finished
    legend = json.loads((out / "legend.json").read_text())
    grains = meshio.read(sorted((out / "snapshots").glob("grains_*.vtu"))[-1])
    contacts = meshio.read(sorted((out / "snapshots").glob("contacts_*.vtu"))[-1])
    in_files = {"mineral": grains.cell_data.get("mineral"),
                "mode": contacts.cell_data.get("mode"),
                "failed": contacts.cell_data.get("failed")}
    for name, data in in_files.items():
        assert data is not None, name
        codes = {str(int(v)) for v in np.unique(np.concatenate(data))}
        assert codes <= set(legend["codes"][name]), (name, codes)
    assert legend["codes"]["mineral"] == {"0": "mica", "1": "feldspar", "2": "quartz"}
    assert legend["codes"]["contact_type"]["5"] == "Q-Q"
    assert legend["codes"]["mode"] == {"0": "intact", "1": "tensile", "2": "shear"}
    signs = legend["sign_conventions"]
    assert legend["sign_convention"] == "compression positive"
    assert signs["contact normal stress (normal_stress_Pa)"] == "compression positive"
    assert signs["contact opening (opening_m)"].startswith("opening positive")


@pytest.mark.parametrize("keep", [0.5, 0.02])
def test_a_truncated_checkpoint_is_one_line(finished, tmp_path, keep):
    import shutil

    out = tmp_path / "cut"
    shutil.copytree(finished[0], out)
    data = checkpoint_path(out).read_bytes()
    checkpoint_path(out).write_bytes(data[:int(len(data) * keep)])
    line = _one_line(runner.invoke(app, ["run", "--resume", "--out", str(out)]))
    assert "state.h5" in line and ("truncated" in line or "not a grainfrac checkpoint" in line)
