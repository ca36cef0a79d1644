"""Sweeps on Dask: complete tables with the right statistics, a killed worker, re-runs, validation.

One small Dask cluster (2 worker processes) serves the module; every sweep is
2 points (stress Case 1 and Case 2) x 2 realisations (seeds 3 and 4) of a
40 mm slab injected for 4 ms, a real coupled run of about a second each.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import signal
import statistics
from pathlib import Path

import pytest
from typer.testing import CliRunner

from grainfrac.cli import app
from grainfrac.errors import ConfigError
from grainfrac.studies import sweep as sweep_mod
from grainfrac.studies.sweep import (
    DaskSession,
    SweepError,
    load_sweep,
    plan_sweep,
    run_sweep,
)

distributed = pytest.importorskip("distributed")

BASE = {
    "name": "tiny-hs", "seed": 3,
    "specimen": {"shape": "slab", "width_mm": 40.0, "height_mm": 40.0,
                 "borehole_diameter_mm": 10.0},
    "stress": {"case": "case2"},
    # A permeable wall breaks down within the 4 ms these tests can afford (sealed: ~6 ms).
    "fluid": {"well_wall": "wet"},
    "stages": [{"kind": "equilibrate"},
               {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 4.0,
                "time_step_ms": 0.1}],
}
SWEEP = {
    "name": "tiny",
    "base": BASE,
    "realisations": 2,
    "set": {"output.snapshot_every_ms": 100.0},
    "parameters": [{"path": "stress.case", "values": ["case1", "case2"]}],
}
SWEEP_TOML = """\
name = "tiny"
realisations = 2
set = { "output.snapshot_every_ms" = 100.0 }

[base]
name = "tiny-hs"
seed = 3
specimen = { shape = "slab", width_mm = 40.0, height_mm = 40.0, borehole_diameter_mm = 10.0 }
stress = { case = "case2" }
fluid = { well_wall = "wet" }
stages = [ { kind = "equilibrate" },
           { kind = "inject", rate_ml_per_min = 90.0, duration_ms = 4.0, time_step_ms = 0.1 } ]

[[parameters]]
path = "stress.case"
values = ["case1", "case2"]
"""
T_975_DOF1 = 12.706204736174707  # Student t, two-sided 95 %, one degree of freedom


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=50)
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture(scope="module")
def reference(client, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    result = run_sweep(plan_sweep(SWEEP), out, scheduler=client)
    return out, result


def _read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _no_cluster(monkeypatch):
    def refuse(self):
        raise AssertionError("a Dask cluster was started")
    monkeypatch.setattr(DaskSession, "_connect", refuse)


def test_sweep_table_is_complete_with_correct_statistics(reference):
    out, result = reference
    runs = _read(out / "runs.csv")
    assert [(r["point"], r["realisation"], r["seed"], r["status"]) for r in runs] == [
        ("case-case1", "0", "3", "done"), ("case-case1", "1", "4", "done"),
        ("case-case2", "0", "3", "done"), ("case-case2", "1", "4", "done")]
    assert [r["stress.case"] for r in runs] == ["case1", "case1", "case2", "case2"]
    # The per-run table is the runs' own summary.json.
    for row in runs:
        summary = json.loads((out / row["run_dir"] / "summary.json").read_text())
        assert summary["seed"] == int(row["seed"])
        for key in ("n_cracks", "fracture_extent_mm", "breakdown_pressure_MPa",
                    "contact_fraction_failed"):
            value = summary[key]
            if isinstance(value, dict):
                for entry, v in value.items():
                    assert float(row[f"{key}.{entry}"]) == v
            else:
                assert row[key] == ("" if value is None else str(value)), key
    # Statistics recomputed independently from the per-run table.
    table = _read(out / "stats.csv")
    quantities = result.quantities
    assert len(table) == 2 * len(quantities) and "n_cracks" in quantities
    checked = 0
    for row in table:
        values = [float(r[row["quantity"]]) for r in runs
                  if r["point"] == row["point"] and r[row["quantity"]] != ""]
        assert int(row["n_runs"]) == 2 and int(row["n"]) == len(values)
        if len(values) == 2:
            mean, std = statistics.fmean(values), statistics.stdev(values)
            half = T_975_DOF1 * std / math.sqrt(2)
            assert float(row["mean"]) == pytest.approx(mean, rel=1e-12, abs=1e-300)
            # Two nearly equal values leave a std at round-off of the mean: compare on that scale.
            assert float(row["std"]) == pytest.approx(std, rel=1e-9, abs=1e-12 * abs(mean))
            assert float(row["ci95_low"]) == pytest.approx(mean - half, rel=1e-9, abs=1e-12)
            assert float(row["ci95_high"]) == pytest.approx(mean + half, rel=1e-9, abs=1e-12)
            checked += 1
        elif not values:
            assert row["mean"] == row["std"] == row["ci95_low"] == ""
    cracks = result.stat("case-case1", "n_cracks")
    print(f"\ncase1 cracks {cracks['mean']:.1f} +- {cracks['ci95_half_width']:.1f} "
          f"(95 % CI, n = 2); {checked} quantity rows checked against runs.csv")
    assert checked >= 20
    assert all(result.stat(p, "n_cracks")["mean"] > 0 for p in ("case-case1", "case-case2"))
    plan = json.loads((out / "sweep.json").read_text())
    assert plan["last_invocation"]["computed"] == 4 and plan["last_invocation"]["complete"]


@pytest.mark.slow  # 13 s; keeps the default suite under 10 min
def test_a_killed_worker_loses_and_duplicates_nothing(client, reference, tmp_path):
    killed: dict = {}

    def kill_once(p):
        if killed or p.computed + p.failed == 0:
            return
        busy = [w for w, keys in client.processing().items() if keys]
        if busy:
            pids = client.run(os.getpid)
            killed.update(address=busy[0], pid=pids[busy[0]],
                          keys=list(client.processing()[busy[0]]))
            os.kill(killed["pid"], signal.SIGKILL)

    result = run_sweep(plan_sweep(SWEEP), tmp_path, scheduler=client, progress=kill_once)
    print(f"\nkilled worker pid {killed.get('pid')} while it ran {killed.get('keys')}")
    assert killed and killed["keys"], "no worker was busy when the first result came"
    assert killed["pid"] not in client.run(os.getpid).values()
    rows = _read(tmp_path / "runs.csv")
    keys = [(r["point"], r["realisation"]) for r in rows]
    assert len(keys) == 4 == len(set(keys)) and all(r["status"] == "done" for r in rows)
    assert result.failures == {}
    # Same sweep and seeds, same table: the rerun task reproduced the killed run exactly.
    assert (tmp_path / "stats.csv").read_text() == (reference[0] / "stats.csv").read_text()


def test_rerun_skips_finished_runs_and_completes_missing_ones(client, reference, tmp_path,
                                                              monkeypatch):
    out = tmp_path / "again"
    shutil.copytree(reference[0], out)
    summaries = sorted(out.glob("runs/*/r*/summary.json"))
    stamps = {p: p.stat().st_mtime_ns for p in summaries}
    with monkeypatch.context() as m:
        _no_cluster(m)
        again = run_sweep(plan_sweep(SWEEP), out)
    assert (again.computed, again.skipped) == (0, 4)
    assert {p: p.stat().st_mtime_ns for p in summaries} == stamps
    # A lost result is recomputed, alone, and the table comes back identical.
    summaries[1].unlink()
    partial = run_sweep(plan_sweep(SWEEP), out, scheduler=client)
    assert (partial.computed, partial.skipped) == (1, 3)
    assert {p: p.stat().st_mtime_ns for p in summaries if p != summaries[1]} == {
        p: s for p, s in stamps.items() if p != summaries[1]}
    assert (out / "stats.csv").read_text() == (reference[0] / "stats.csv").read_text()
    # A finished run of another scenario at a planned place is never reused.
    changed = {**SWEEP, "set": {"output.snapshot_every_ms": 50.0}}
    with pytest.raises(SweepError, match="output.snapshot_every_ms"):
        run_sweep(plan_sweep(changed), out, scheduler=client)


def test_cli_sweep_reads_the_file_and_reuses_the_runs(reference, tmp_path, monkeypatch):
    (tmp_path / "tiny.toml").write_text(SWEEP_TOML)
    assert [p.id for p in load_sweep(tmp_path / "tiny.toml").points] == [
        "case-case1", "case-case2"]
    out = tmp_path / "out"
    shutil.copytree(reference[0], out)
    _no_cluster(monkeypatch)
    result = CliRunner().invoke(app, ["sweep", str(tmp_path / "tiny.toml"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "4 already done" in result.output and "case-case2" in result.output


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"parameters": [{"path": "stress.cas", "values": ["case1"]}]},
     "parameters.0.path", "stress has case, sigma_x_MPa, sigma_y_MPa"),
    ({"parameters": [{"path": "stages.0.rate_ml_per_min", "values": [18.0]}]},
     "parameters.0.path", "stages.0 (equilibrate) has kind"),
    ({"parameters": [{"path": "stages.1.rate_ml_per_min", "values": [18.0, -5.0]}]},
     "parameters.0.values.1", "stages.1.rate_ml_per_min: must be > 0"),
    ({"parameters": [{"path": "grains.max_edge_mm", "values": [8.0, 2.5]}]},
     "parameters.0.values.1", "grains.min_edge_mm: must be < max_edge_mm"),
    ({"set": {"fissures.fractoin": 0.1}}, "set.fissures.fractoin", "fissures has fraction"),
    ({"set": {"output.snapshot_every_ms": -1.0}}, "set.output.snapshot_every_ms",
     "must be > 0"),
    ({"seeds": [1, 1]}, "seeds.1", "listed twice"),
    ({"quantities": ["breakdown_MPa"]}, "quantities.0", "unknown quantity"),
    ({"paramters": []}, "paramters", "did you mean 'parameters'"),
    ({"base": "nowhere.toml"}, "base", "scenario file not found"),
])
def test_sweep_validation_names_the_field_before_any_compute(change, field, words, tmp_path,
                                                             monkeypatch):
    _no_cluster(monkeypatch)
    with pytest.raises(ConfigError) as info:
        plan_sweep({**SWEEP, **change}, base_dir=tmp_path)
    assert info.value.field == field and words in str(info.value)
    assert "\n" not in str(info.value)
    # The command line says it in one line, exit code 2, and writes nothing.
    bad = {**SWEEP, **change}
    if "paramters" not in change and not isinstance(bad["base"], str):
        import tomli_w

        (tmp_path / "bad.toml").write_text(tomli_w.dumps(bad))
        result = CliRunner().invoke(app, ["sweep", str(tmp_path / "bad.toml"), "--out",
                                          str(tmp_path / "out")])
        assert result.exit_code == 2 and field in result.output
        assert not (tmp_path / "out").exists()


def test_points_paths_and_stress_overrides():
    plan = plan_sweep({
        "name": "pts", "base": BASE, "seeds": [5, 9],
        "points": [
            {"id": "values", "set": {"stress": {"sigma_x_MPa": 3.0}}},
            {"id": "weibull", "set": {"rock.weibull.shape": 9.0, "stress.case": "case4"}},
            {"id": "fissured", "set": {"fissures": {"fraction": 0.1, "clear_radius_mm": 8.0}}},
        ]})
    stress = plan.point("values").runs[0].scenario["stress"]
    assert (stress.get("case"), stress["sigma_x_MPa"], stress["sigma_y_MPa"]) == (None, 3.0, 5.0)
    weibull = plan.point("weibull").runs[1].scenario
    assert weibull["rock"]["weibull"]["shape"] == 9.0 and weibull["stress"]["case"] == "case4"
    assert weibull["seed"] == 9 and plan.parameters == (
        "stress.sigma_x_MPa", "rock.weibull.shape", "stress.case", "fissures.fraction",
        "fissures.clear_radius_mm")
    assert plan.point("fissured").runs[0].scenario["fissures"]["clear_radius_mm"] == 8.0


def test_sigma_z_override_keeps_the_case_values_in_3d():
    plan = load_sweep(Path(__file__).resolve().parents[1] / "examples" / "sweeps"
                      / "hs-3d-sigma-z.toml")
    assert [p.runs[0].scenario["stress"] for p in plan.points] == [
        {"sigma_x_MPa": 2.5, "sigma_y_MPa": 5.0, "sigma_z_MPa": sz} for sz in (1.0, 5.0, 10.0)]
    assert sweep_mod.SweepConfig.model_validate(
        {"base": "x.toml", "realisations": 3}).n_realisations == 3


def test_a_failing_run_is_recorded_and_the_sweep_goes_on(client, tmp_path, monkeypatch):
    from grainfrac import simulation
    from grainfrac.run import RunFailed
    from grainfrac.studies.sweep import PlannedRun, SweepPlan, SweepPoint, collect, execute_run

    plan = plan_sweep({**SWEEP, "parameters": [{"path": "seed", "values": [7]}],
                       "realisations": 1})
    (run,) = plan.runs
    assert (run.point, run.seed) == ("seed-7", 7)
    # A physics failure (a GrainfracError) is data: failed.json, status "failed".
    with monkeypatch.context() as m:
        def blow_up(*args, **kwargs):
            raise RunFailed("stage 2 (inject) stopped: non-finite velocity")
        m.setattr(simulation, "run_scenario", blow_up)
        assert execute_run(str(tmp_path / run.rel_dir), run.scenario)["status"] == "failed"
    failed = collect(plan, tmp_path)
    assert failed.runs[0]["status"] == "failed" and failed.stat("seed-7", "n_cracks")["n"] == 0
    assert "non-finite" in (tmp_path / run.rel_dir / "failed.json").read_text()
    # A re-run computes it for real and clears the failure.
    assert execute_run(str(tmp_path / run.rel_dir), run.scenario)["status"] == "done"
    assert collect(plan, tmp_path).runs[0]["status"] == "done"
    assert not (tmp_path / run.rel_dir / "failed.json").exists()
    # A finished run's warnings (energy made by the coupling) reach the sweep.
    summary_path = tmp_path / run.rel_dir / "summary.json"
    summary = json.loads(summary_path.read_text())
    assert collect(plan, tmp_path).warnings == {}
    summary_path.write_text(json.dumps({**summary, "warnings": ["the coupling made energy"]}))
    assert collect(plan, tmp_path).warnings == {run.rel_dir: ["the coupling made energy"]}
    # A task that raises on every try (here: a scenario that does not validate on the
    # worker) is retried, then reported as failed while the other runs complete.
    broken = PlannedRun("broken", 0, 0, {**run.scenario, "stages": []})
    bad_plan = SweepPlan("bad", (SweepPoint("seed-7", {}, (run,)),
                                 SweepPoint("broken", {}, (broken,))), (), retries=1)
    result = run_sweep(bad_plan, tmp_path, scheduler=client)
    assert (result.skipped, result.computed) == (1, 0)
    assert list(result.failures) == ["runs/broken/r0"] and "stages" in \
        result.failures["runs/broken/r0"]
    assert [r["status"] for r in result.runs] == ["done", "failed"]


def test_example_sweeps_plan():
    examples = sorted((Path(__file__).resolve().parents[1] / "examples" / "sweeps").glob(
        "*.toml"))
    assert examples
    for path in examples:
        plan = load_sweep(path)
        assert plan.points and all(len(p.runs) >= 2 for p in plan.points), path.name
    rate = load_sweep(examples[0].parent / "hs-rate-case2.toml")
    assert [p.id for p in rate.points] == ["18mlmin", "42mlmin", "66mlmin"]
    assert [round(p.runs[0].scenario["stages"][1]["duration_ms"], 1) for p in rate.points] == [
        60.0, 25.7, 16.4]
