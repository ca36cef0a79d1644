"""The paper's study matrix, the statistics and claim decisions, and the reproduction report."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats as sps
from typer.testing import CliRunner

from grainfrac.analysis import stats
from grainfrac.cli import app
from grainfrac.errors import ConfigError
from grainfrac.studies.claims import Claim, evaluate
from grainfrac.studies.paper import (
    LAB_SCENARIO,
    STUDY_NAMES,
    Study,
    plan_studies,
    select,
)
from grainfrac.studies.study import run_studies
from grainfrac.studies.sweep import (
    DaskSession,
    SweepPlan,
    SweepPoint,
    SweepResult,
    execute_run,
)

# --------------------------------------------------------------------------- statistics


def test_mean_ci_matches_student_t():
    x = [3.0, 4.5, 5.0, 7.5]
    s = stats.summarise([*x, None, float("nan")])
    lo, hi = sps.t.interval(0.95, len(x) - 1, loc=np.mean(x), scale=sps.sem(x))
    assert (s.n, s.n_missing) == (4, 2)
    assert s.std == pytest.approx(np.std(x, ddof=1))
    assert (s.ci_low, s.ci_high) == pytest.approx((lo, hi), rel=1e-12)
    one = stats.summarise([2.0, None])
    assert one.mean == 2.0 and math.isnan(one.ci_low) and math.isnan(one.std)
    assert stats.summarise([None, None]).n == 0


def test_welch_difference_and_slope_match_scipy():
    a, b = [10.1, 11.4, 12.0, 9.8], [7.0, 8.5, 6.1]
    iv = stats.difference(a, b)
    ref = sps.ttest_ind(a, b, equal_var=False).confidence_interval(0.95)
    assert (iv.low, iv.high) == pytest.approx((ref.low, ref.high), rel=1e-10)
    x = [1, 1, 2, 2, 3, 3, 4]
    y = [1.0, 1.4, 2.2, 1.9, 3.5, 2.8, 4.1]
    fit = sps.linregress(x, y)
    half = sps.t.ppf(0.975, len(x) - 2) * fit.stderr
    sl = stats.slope(x, y)
    assert (sl.estimate, sl.low, sl.high) == pytest.approx(
        (fit.slope, fit.slope - half, fit.slope + half), rel=1e-10)
    assert not stats.slope([1, 2], [1.0, 2.0]).defined


# --------------------------------------------------------------------------- claims


def _result(values: dict[str, list], quantity: str = "q", seeds: dict[str, list] | None = None
            ) -> SweepResult:
    """A sweep result with given per-run values (the decision logic only reads these)."""
    points, runs = [], []
    for point, vals in values.items():
        point_seeds = (seeds or {}).get(point, list(range(len(vals))))
        points.append(SweepPoint(point, {}, ()))
        runs += [{"point": point, "realisation": k, "seed": point_seeds[k], "status": "done",
                  quantity: v} for k, v in enumerate(vals)]
    return SweepResult(SweepPlan("t", tuple(points), ()), Path("."), runs, [], [quantity])


def test_greater_claim_paired_over_common_seeds():
    claim = Claim("c", "a > b", "q", "greater", ("a", "b"))
    # Per-seed differences 4, 5, 6: mean 5, sd 1, t(2) = 4.303 -> [2.52, 7.48].
    v = evaluate(claim, _result({"a": [9.0, 11.0, 13.0], "b": [5.0, 6.0, 7.0]}))
    assert v.verdict == "holds" and "paired" in v.estimate
    assert (v.interval.low, v.interval.high) == pytest.approx(
        (5 - 4.302652729749464 / math.sqrt(3), 5 + 4.302652729749464 / math.sqrt(3)))
    # Differences 1, 2, 3: [-0.48, 4.48] straddles 0.
    assert evaluate(claim, _result({"a": [6.0, 8.0, 10.0], "b": [5.0, 6.0, 7.0]})
                    ).verdict == "inconclusive"
    assert evaluate(claim, _result({"a": [5.0, 6.0, 7.0], "b": [9.0, 11.0, 13.0]})
                    ).verdict == "does not hold"
    welch = evaluate(claim, _result({"a": [9.0, 11.0, 13.0], "b": [5.0, 6.0, 7.0]},
                                    seeds={"a": [0, 1, 2], "b": [5, 6, 7]}))
    assert "Welch" in welch.estimate and welch.verdict == "holds"


def test_claims_without_data_are_undetermined_with_the_reason():
    claim = Claim("bd", "hybrid lower", "breakdown_pressure_MPa", "greater", ("hs", "hy"))
    v = evaluate(claim, _result({"hs": [30.0, 31.0], "hy": [None, None]},
                                "breakdown_pressure_MPa"))
    assert v.verdict == "undetermined" and "null/NaN in all 2 run(s) at hy" in v.reason
    assert "no breakdown was detected" in v.reason
    v = evaluate(claim, _result({"hs": [30.0], "hy": [20.0]}, "breakdown_pressure_MPa"))
    assert v.verdict == "undetermined" and "no 95 % CI" in v.reason
    radial = Claim("r", ">= 3", "q", "at_least", ("a", "b"), threshold=3.0)
    assert evaluate(radial, _result({"a": [4.0], "b": [5.0]})).verdict == "undetermined"


def test_threshold_trend_and_within_claims():
    radial = Claim("r", ">= 3", "q", "at_least", ("a", "b"), threshold=3.0)
    assert evaluate(radial, _result({"a": [4, 4, 4], "b": [5, 6, 5]})).verdict == "holds"
    assert evaluate(radial, _result({"a": [4, 4, 4], "b": [1, 2, 1]})).verdict == \
        "does not hold"
    assert evaluate(radial, _result({"a": [4, 4, 4], "b": [2, 6, 3]})).verdict == \
        "inconclusive"
    rising = Claim("t", "rises", "q", "trend", ("a", "b", "c"), x=(18.0, 42.0, 66.0))
    data = {"a": [10.0, 10.5], "b": [12.0, 12.4], "c": [14.1, 13.9]}
    assert evaluate(rising, _result(data)).verdict == "holds"
    falling = Claim("t", "falls", "q", "trend", ("a", "b", "c"), x=(18.0, 42.0, 66.0),
                    direction=-1)
    assert evaluate(falling, _result(data)).verdict == "does not hold"
    lab = Claim("l", "near 9.16", "q", "within", ("lab",), reference=9.16, tolerance=0.1)
    assert evaluate(lab, _result({"lab": [9.0, 9.2, 9.1]})).verdict == "holds"
    assert evaluate(lab, _result({"lab": [5.0, 5.2, 5.1]})).verdict == "does not hold"


# --------------------------------------------------------------------------- the matrix


def test_every_paper_study_plans_before_any_compute(monkeypatch):
    monkeypatch.setattr(DaskSession, "_connect", lambda self: pytest.fail("cluster started"))
    planned = dict((s.name, p) for s, p in plan_studies(select(), 2, None))
    assert tuple(planned) == STUDY_NAMES
    assert sum(len(p.points) for p in planned.values()) == 22
    for plan in planned.values():
        for point in plan.points:
            assert [r.seed for r in point.runs] == [0, 1]
            assert all(r.scenario["output"]["snapshot_every_ms"] == 10.0 for r in point.runs)
    cases = [r.scenario["stress"]["case"] for p in planned["hs-confinement"].points
             for r in p.runs[:1]]
    assert cases == ["case1", "case2", "case3", "case4"]
    grains = [(r.scenario["grains"]["max_edge_mm"], r.scenario["grains"]["zone_size_mm"],
               r.scenario["stress"]["case"]) for p in planned["grain-size"].points
              for r in p.runs[:1]]
    assert grains == [(m, 1.4, "case4") for m in (6.0, 7.0, 8.0, 9.0)]
    rate = [r.scenario["stages"][1] for p in planned["injection-rate"].points
            for r in p.runs[:1]]
    assert [(s["rate_ml_per_min"], round(s["duration_ms"], 2)) for s in rate] == [
        (18.0, 60.0), (42.0, 25.71), (66.0, 16.36)]
    hybrid = {p.id: p.runs[0].scenario for p in planned["hybrid"].points}
    assert [s["kind"] for s in hybrid["hybrid-f15"]["stages"]] == [
        "equilibrate", "scda", "drill_out", "inject"]
    assert [s["kind"] for s in hybrid["hs-only-f15"]["stages"]] == ["equilibrate", "inject"]
    assert hybrid["hs-only-f15"]["fissures"] == hybrid["hybrid-f15"]["fissures"] == {
        "fraction": 0.15, "clear_radius_mm": 10.0}
    assert hybrid["hs-only-f0"]["fissures"]["fraction"] == 0.0
    lab = planned["lab-hs"].points[0].runs[0].scenario
    assert lab["specimen"]["borehole_diameter_mm"] == 3.0 == LAB_SCENARIO["specimen"][
        "borehole_diameter_mm"]
    assert (lab["stress"]["sigma_x_MPa"], lab["stress"]["sigma_y_MPa"]) == (0.0, 0.0)
    with pytest.raises(ConfigError, match="only.0: unknown study"):
        select(["grain"])
    with pytest.raises(ConfigError, match="examples"):
        plan_studies(select(), 1, "/nonexistent")


def test_cli_study_rejects_unknown_names(tmp_path):
    result = CliRunner().invoke(app, ["study", "paper", "--out", str(tmp_path / "s"),
                                      "--only", "nope"])
    assert result.exit_code == 2 and "unknown study 'nope'" in result.output
    result = CliRunner().invoke(app, ["study", "thesis", "--out", str(tmp_path / "s")])
    assert result.exit_code == 2 and "known: paper" in result.output
    result = CliRunner().invoke(app, ["study", "paper", "--out", str(tmp_path / "s"),
                                      "--dim", "4"])
    assert result.exit_code == 2 and "dim.0: must be 2 or 3 (got 4)" in result.output


# --------------------------------------------------------------------------- the report

TINY = {
    "name": "tiny-hs", "seed": 3,
    "specimen": {"shape": "slab", "width_mm": 40.0, "height_mm": 40.0,
                 "borehole_diameter_mm": 10.0},
    "stress": {"case": "case2"},
    "stages": [{"kind": "equilibrate"},
               {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 4.0,
                "time_step_ms": 0.1}],
    "output": {"snapshot_every_ms": 100.0},
}


def test_reproduction_report_from_real_runs(tmp_path, monkeypatch):
    study = Study(
        "tiny-confinement", "Tiny HS under Case 1 and Case 3", "test", "40 mm slab, 4 ms.",
        {"name": "tiny-confinement", "base": TINY,
         "parameters": [{"path": "stress.case", "values": ["case1", "case3"],
                         "labels": ["c1", "c3"]}]},
        ("n_cracks", "breakdown_pressure_MPa", "peak_expansive_pressure_MPa"),
        (Claim("cracks", "more cracks in Case 1", "n_cracks", "greater", ("c1", "c3"),
               paper="made up for the test"),
         Claim("scda", "an SCDA peak above 1 MPa", "peak_expansive_pressure_MPa", "at_least",
               ("c1", "c3"), threshold=1.0, paper="none")))
    plan = study.plan(2, tmp_path)
    # Real runs, computed here in-process; the study then finds them done: no cluster.
    for run in plan.runs:
        assert execute_run(str(tmp_path / "out" / study.name / run.rel_dir),
                           run.scenario)["status"] == "done"
    flagged = tmp_path / "out" / study.name / plan.runs[0].rel_dir / "summary.json"
    summary = json.loads(flagged.read_text())
    flagged.write_text(json.dumps({**summary, "warnings": ["the coupling made energy"]}))
    monkeypatch.setattr(DaskSession, "_connect", lambda self: pytest.fail("cluster started"))
    done = run_studies([study], tmp_path / "out", realisations=2, examples=tmp_path)
    outcome = done.outcomes[0]
    assert done.runs_computed == 0 and outcome.result.skipped == 4
    cracks, scda = outcome.verdicts
    c1 = outcome.result.values("c1", "n_cracks")
    c3 = outcome.result.values("c3", "n_cracks")
    diffs = [a - b for a, b in zip(c1, c3, strict=True)]
    print(f"\ncracks case1 {c1}, case3 {c3}: {cracks.verdict} ({cracks.estimate})")
    assert len(c1) == len(c3) == 2 and cracks.interval.estimate == pytest.approx(
        np.mean(diffs))
    assert scda.verdict == "undetermined" and "no SCDA stage" in scda.reason
    out = tmp_path / "out"
    md = (out / "report.md").read_text()
    assert "more cracks in Case 1" in md and f"**{cracks.verdict}**" in md
    assert "figures/tiny-confinement.png" in md and "no SCDA stage" in md
    # The flagged run is listed (TINY's 0.1 ms coupling step makes energy in other runs
    # of its own, which are listed too).
    flag = f"{plan.runs[0].rel_dir}: the coupling made energy"
    assert "Runs with warnings (" in md and flag in md
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 1 and "undetermined" in page
    assert flag in page
    assert (out / "figures" / "tiny-confinement.png").stat().st_size > 10_000
    rows = list(csv.DictReader(open(out / "claims.csv")))
    assert [(r["claim"], r["verdict"]) for r in rows] == [
        ("cracks", cracks.verdict), ("scda", "undetermined")]
    assert json.loads((out / "claims.json").read_text())[0]["study"] == "tiny-confinement"
    stats_rows = list(csv.DictReader(open(out / study.name / "stats.csv")))
    c1_row = next(r for r in stats_rows if r["point"] == "c1" and r["quantity"] == "n_cracks")
    assert float(c1_row["mean"]) == pytest.approx(np.mean(c1))


@pytest.mark.slow
def test_cli_study_paper_lab_smoke(tmp_path):
    """`grainfrac study paper --only lab-hs --realisations 1`: a real run, report and verdict."""
    out = tmp_path / "study"
    result = CliRunner().invoke(app, ["study", "paper", "--out", str(out), "--only", "lab-hs",
                                      "--realisations", "1", "--workers", "1"])
    print(result.output)
    assert result.exit_code == 0, result.output
    runs = list(csv.DictReader(open(out / "lab-hs" / "runs.csv")))
    assert [(r["point"], r["status"]) for r in runs] == [("lab-5mlmin", "done")]
    claims = list(csv.DictReader(open(out / "claims.csv")))
    assert [(c["claim"], c["verdict"]) for c in claims] == [("lab-breakdown", "undetermined")]
    bd = runs[0]["breakdown_pressure_MPa"]
    assert ("no 95 % CI" in claims[0]["reason"]) if bd else ("null" in claims[0]["reason"])
    assert "lab-hs" in result.output and "undetermined" in result.output
    assert (out / "report.html").stat().st_size > 10_000


def test_the_3d_studies_plan_on_the_3d_examples(monkeypatch):
    """``--dim 3``: SCDA Cases 1-4 and the hybrid on the 50 x 50 x 10 mm slab, the lab HS
    test on the hollow cylinder; a family name selects the 3D study."""
    from grainfrac.studies.paper import STUDY_NAMES_3D

    monkeypatch.setattr(DaskSession, "_connect", lambda self: pytest.fail("cluster started"))
    planned = {s.name: p for s, p in plan_studies(select(dimensions=(3,)), 3, None)}
    assert tuple(planned) == STUDY_NAMES_3D
    for plan in planned.values():
        for point in plan.points:
            assert [r.seed for r in point.runs] == [0, 1, 2]
            assert all(r.scenario["dimension"] == 3 for r in point.runs)
    scda = [p.runs[0].scenario for p in planned["scda-confinement-3d"].points]
    assert [s["stress"]["case"] for s in scda] == ["case1", "case2", "case3", "case4"]
    for s in scda + [p.runs[0].scenario for p in planned["hybrid-3d"].points]:
        spec = s["specimen"]
        assert (spec["width_mm"], spec["height_mm"], spec["thickness_mm"]) == (50, 50, 10)
    hybrid = {p.id: [st["kind"] for st in p.runs[0].scenario["stages"]]
              for p in planned["hybrid-3d"].points}
    assert hybrid == {"hybrid-f0": ["equilibrate", "scda", "drill_out", "inject"],
                      "hs-only-f0": ["equilibrate", "inject"]}
    assert planned["lab-hs-3d"].points[0].runs[0].scenario["specimen"]["shape"] == \
        "hollow_cylinder"
    assert [s.name for s in select(["hybrid"], (2, 3))] == ["hybrid", "hybrid-3d"]
    with pytest.raises(ConfigError, match="dim.0: must be 2 or 3"):
        select(dimensions=(4,))
    with pytest.raises(ConfigError, match="only.0: unknown study 'grain-size'"):
        select(["grain-size"], (3,))


def test_the_claims_table_puts_2d_and_3d_side_by_side():
    from grainfrac.studies.claims import Verdict
    from grainfrac.studies.paper import paper_studies, paper_studies_3d
    from grainfrac.studies.report import StudyOutcome, _summary_table

    two = next(s for s in paper_studies() if s.name == "hybrid")
    three = next(s for s in paper_studies_3d() if s.name == "hybrid-3d")
    outcomes = [StudyOutcome(s, None, [Verdict(c, verdict, f"{s.dimension}D estimate", "")
                                       for c in s.claims])
                for s, verdict in ((two, "holds"), (three, "inconclusive"))]
    header, rows, verdicts = _summary_table(outcomes)
    assert header == ["study", "claim", "paper", "ours (2D)", "verdict (2D)", "ours (3D)",
                      "verdict (3D)"] and verdicts == {4, 6}
    by_id = {c.id: row for s in (two, three) for c in s.claims
             for row in rows if row[1] == c.text}
    assert by_id["hybrid-breakdown-f0"][3:] == ["2D estimate", "holds", "3D estimate",
                                                "inconclusive"]
    assert by_id["hybrid-breakdown-f15"][5:] == ["not run", "not run"]
    assert by_id["hybrid-fractures-mid-f0"][3:5] == ["not run", "not run"]
    assert all(row[0] == "hybrid" for row in rows)
    header, _, verdicts = _summary_table(outcomes[:1])
    assert header[3:] == ["ours", "verdict"] and verdicts == {4}
