"""The paper's claims (Sects. 5.1, 5.3 and 6) measured on the paper's cases (slow).

Every test runs full simulations of the example scenarios (``examples/*.toml``)
on the default slab (100 x 100 mm, borehole radius 5 mm, zones 2 mm) and
prints what it measured; run with ``pytest -m slow tests/test_paper_claims.py -q -s``.
Each simulation runs once per module (cached by scenario file, stress case and
seed); the whole module takes about 5-6 minutes on one core.

Claims checked:

1. SCDA alone (Sect. 5.1, Fig. 10): multiple radial fractures (>= 3) form in
   every stress case; their extent is shorter under Case 3 than Case 1; charging
   stops at the 45 MPa peak expansive pressure (Sect. 4.1).
2. HS alone (Sect. 5.3, Figs. 12 and 17c; 90 ml/min instead of 18 ml/min for
   speed): breakdown happens and the fracture grows along the major stress
   direction y in Case 2; the breakdown pressure is lowest in Case 1 and highest
   in Case 4 (Fig. 12e; the text adds that Case 2 and Case 3 are "slightly
   higher" than Case 1 and that Case 2 and Case 4 are "relatively similar").
3. Hybrid vs HS alone (Sect. 6, Fig. 17, Case 2, 90 ml/min, same seed hence
   same grain structure): no abrupt pressure drop after breakdown, a lower
   breakdown pressure and more radial fractures (summary ``n_radial_fractures``);
   stricter, more fractures extended by the injection itself (created or
   lengthened by more than one zone after the start of injection).
4. Robustness: claim 3 repeated with seeds 1 and 2 (reported, not asserted).

Claims that do not hold are marked ``xfail(strict=False)`` with the measured
numbers in the reason; nothing is loosened to make a test pass.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from grainfrac.analysis import (
    RadialFractures,
    breakdown,
    max_drop_rate,
    pressure_drop_after_peak,
    radial_fractures,
)
from grainfrac.scenario import Scenario, load_scenario
from grainfrac.simulation import run_scenario

pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = ("case1", "case2", "case3", "case4")
# The slab's borehole is centred on the origin (geometry.specimens.SpecimenOutline);
# the radial-fracture counts below are cross-checked against summary.json, which
# uses the specimen's own outline.
CENTER_MM = (0.0, 0.0)
# Cracks farther than this from the well centre (2 well radii) describe where the
# fracture went rather than the damage at the borehole wall.
FAR_MM = 10.0
# Window after the breakdown peak over which the pressure drop is measured
# (100 fluid steps of 0.01 ms; breakdown comes 3-4 ms after the start of injection).
DROP_WINDOW_S = 1.0e-3


# --------------------------------------------------------------------------- measurements


@dataclass
class Measured:
    """One finished run and what the claims need from it."""

    label: str
    scenario: Scenario
    summary: dict[str, Any]
    x_mm: np.ndarray
    y_mm: np.ndarray
    mode: np.ndarray
    crack_time_s: np.ndarray
    history: list[dict[str, str]]
    radial: RadialFractures

    @property
    def well_radius_mm(self) -> float:
        return self.scenario.specimen.borehole_diameter_mm / 2.0

    def stage_rows(self, kind: str) -> list[dict[str, str]]:
        return [r for r in self.history if r["stage"] == kind]

    def injection(self) -> tuple[np.ndarray, np.ndarray]:
        """Well pressure history of the injection stage: (time since its start s, Pa)."""
        rows = self.stage_rows("inject")
        t = np.array([float(r["time_s"]) for r in rows])
        p = np.array([float(r["well_pressure_MPa"]) for r in rows]) * 1e6
        return t - t[0], p

    @property
    def breakdown_MPa(self) -> float | None:
        return self.summary["breakdown_pressure_MPa"]

    @property
    def cracks_ts(self) -> str:
        s = self.summary
        return f"{s['n_cracks']} ({s['n_tensile_cracks']}/{s['n_shear_cracks']})"

    def radial_before_injection(self) -> RadialFractures:
        """Radial fractures of the cracks formed before injection started (SCDA, drill-out)."""
        start = float(self.stage_rows("inject")[0]["time_s"])
        before = self.crack_time_s < start
        well = self.well_radius_mm * 1e-3
        zone = self.scenario.grains.zone_size_mm * 1e-3
        return radial_fractures(self.x_mm[before] * 1e-3, self.y_mm[before] * 1e-3,
                                (CENTER_MM[0] * 1e-3, CENTER_MM[1] * 1e-3), well_radius=well,
                                connect_distance=1.5 * zone, radius=2.0 * well)

    def extended_by_injection(self) -> tuple[int, str]:
        """Radial fractures that injection created or lengthened by more than one zone.

        A fracture at the end matches one present before injection when their
        crossing angles are within 15 deg; it counts as extended when it has no
        match or its extent grew by more than one zone size.
        """
        before, after = self.radial_before_injection(), self.radial
        zone = self.scenario.grains.zone_size_mm * 1e-3
        n, parts = 0, []
        for angle, extent in zip(after.angles_deg, after.extents, strict=True):
            gap = np.abs((before.angles_deg - angle + 180.0) % 360.0 - 180.0)
            if gap.size and gap.min() <= 15.0:
                old = before.extents[int(np.argmin(gap))]
                grown = extent - old > zone
                parts.append(f"{angle:.0f} deg {old * 1e3:.1f} -> {extent * 1e3:.1f} mm")
            else:
                grown = True
                parts.append(f"{angle:.0f} deg new, {extent * 1e3:.1f} mm")
            n += int(grown)
        return n, "; ".join(parts)

    def radial_text(self) -> str:
        r = self.radial
        angles = ", ".join(f"{a:.0f}" for a in r.angles_deg)
        extents = ", ".join(f"{e * 1e3:.1f}" for e in r.extents)
        extent = "-" if r.fracture_extent is None else f"{r.fracture_extent * 1e3:.1f}"
        return (f"{r.count} radial fractures at [{angles}] deg, branch extents [{extents}] mm, "
                f"fracture extent {extent} mm (from the well centre)")


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _scenario(toml: str, *, seed: int, case: str | None) -> tuple[Scenario, Any]:
    scenario, recipe = load_scenario(EXAMPLES / toml)
    data = scenario.model_dump()
    data["seed"] = seed
    if case is not None and case != scenario.stress.case:
        data["stress"] = {"case": case}
        data["name"] = f"{scenario.name}-as-{case}"
    return Scenario.model_validate(data), recipe


def _measure(label: str, scenario: Scenario, recipe: Any, out: Path) -> Measured:
    summary = run_scenario(scenario, recipe, out, base_dir=EXAMPLES)
    cracks = _read_csv(out / "cracks.csv")
    x = np.array([float(r["x_mm"]) for r in cracks])
    y = np.array([float(r["y_mm"]) for r in cracks])
    mode = np.array([r["mode"] for r in cracks])
    crack_time = np.array([float(r["time_s"]) for r in cracks])
    well = scenario.specimen.borehole_diameter_mm / 2.0
    zone = scenario.grains.zone_size_mm
    radial = radial_fractures(x * 1e-3, y * 1e-3, (CENTER_MM[0] * 1e-3, CENTER_MM[1] * 1e-3),
                              well_radius=well * 1e-3, connect_distance=1.5 * zone * 1e-3,
                              radius=2.0 * well * 1e-3)
    # The count from cracks.csv must agree with the run's own summary.
    assert radial.count == summary["n_radial_fractures"], (radial.count, summary)
    return Measured(label, scenario, summary, x, y, mode, crack_time,
                    _read_csv(out / "history.csv"), radial)


@pytest.fixture(scope="module")
def run_case(tmp_path_factory) -> Callable[..., Measured]:
    """Run an example scenario (optionally under another stress case / seed) once per module."""
    cache: dict[tuple[str, str, int], Measured] = {}

    def get(toml: str, *, seed: int = 0, case: str | None = None) -> Measured:
        scenario, recipe = _scenario(toml, seed=seed, case=case)
        key = (toml, str(scenario.stress.case), seed)
        if key not in cache:
            label = f"{Path(toml).stem}[{scenario.stress.case}, seed {seed}]"
            out = tmp_path_factory.mktemp(f"{Path(toml).stem}-{scenario.stress.case}-s{seed}")
            cache[key] = _measure(label, scenario, recipe, out)
        return cache[key]

    return get


def _direction(x_mm: np.ndarray, y_mm: np.ndarray, far_mm: float = FAR_MM) -> dict[str, float]:
    """Where the cracks farther than ``far_mm`` from the well centre lie.

    ``mean_abs_sin``: mean |sin| of their polar angles (1: all on the y axis,
    0: all on the x axis, 2/pi = 0.64 for directions spread evenly).
    ``axis_deg``: direction (0-180 deg from x) of the principal axis of their
    second moment about the well centre, i.e. the line through the well that
    the far cracks follow; ``axis_off_y_deg`` its angle to the y axis.
    """
    dx, dy = x_mm - CENTER_MM[0], y_mm - CENTER_MM[1]
    r = np.hypot(dx, dy)
    far = r > far_mm
    if not np.any(far):
        return {"n_far": 0, "mean_abs_sin": math.nan, "axis_deg": math.nan,
                "axis_off_y_deg": math.nan}
    fx, fy = dx[far], dy[far]
    moment = np.array([[np.sum(fx * fx), np.sum(fx * fy)], [np.sum(fx * fy), np.sum(fy * fy)]])
    _, vectors = np.linalg.eigh(moment)
    axis = vectors[:, -1]
    axis_deg = math.degrees(math.atan2(axis[1], axis[0])) % 180.0
    return {"n_far": int(far.sum()), "mean_abs_sin": float(np.mean(np.abs(fy) / r[far])),
            "axis_deg": axis_deg, "axis_off_y_deg": abs(axis_deg - 90.0)}


def _drops(m: Measured) -> dict[str, float | None]:
    """Abruptness of the well-pressure fall after breakdown during injection."""
    t, p = m.injection()
    bd = breakdown(t, p)
    out: dict[str, float | None] = {
        "max_drop_rate_MPa_per_ms": max_drop_rate(t, p) / 1e9,
        "drop_1ms_rel": None, "drop_0.5ms_rel": None, "breakdown_time_ms": None,
        "final_MPa": float(p[-1]) / 1e6,
    }
    if bd is not None:
        out["breakdown_time_ms"] = bd.time * 1e3
        out["drop_1ms_rel"] = pressure_drop_after_peak(t, p, DROP_WINDOW_S, peak_index=bd.index,
                                                       relative=True)
        out["drop_0.5ms_rel"] = pressure_drop_after_peak(t, p, DROP_WINDOW_S / 2,
                                                         peak_index=bd.index, relative=True)
    return out


def _fmt(value: float | None, spec: str = ".2f") -> str:
    return "None" if value is None else format(value, spec)


# --------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def scda_runs(run_case) -> dict[str, Measured]:
    runs = {case: run_case(f"scda-{case}.toml") for case in CASES}
    print("\n== SCDA alone (examples/scda-case1..4.toml, seed 0)")
    for case, m in runs.items():
        s = m.summary
        rows = m.stage_rows("scda")
        last_p = float(rows[-1]["expansive_pressure_MPa"])
        duration = (float(rows[-1]["time_s"]) - float(rows[0]["time_s"])) * 1e3
        peak_target = m.scenario.stages[1].peak_pressure_MPa
        print(f"{case}: peak expansive pressure {s['peak_expansive_pressure_MPa']:.2f} MPa, "
              f"last {last_p:.2f} MPa after {duration:.2f} ms of charging (stopped at the "
              f"{peak_target:g} MPa peak: {last_p >= peak_target}); cracks (T/S) {m.cracks_ts}; "
              f"{m.radial_text()}")
    return runs


@pytest.fixture(scope="module")
def hs_cases(run_case) -> dict[str, Measured]:
    runs = {case: run_case("hs-only-case2-90mlmin.toml", case=case) for case in CASES}
    print("\n== HS alone at 90 ml/min (hs-only-case2-90mlmin.toml under each case, seed 0)")
    for case, m in runs.items():
        d = _direction(m.x_mm, m.y_mm)
        drops = _drops(m)
        print(f"{case}: breakdown {_fmt(m.breakdown_MPa)} MPa at "
              f"{_fmt(drops['breakdown_time_ms'])} ms, T/S ratio "
              f"{_fmt(m.summary['tensile_shear_ratio'])}, cracks (T/S) {m.cracks_ts}; "
              f"{m.radial_text()}; far cracks (> {FAR_MM:g} mm): {d['n_far']}, mean |sin| "
              f"{d['mean_abs_sin']:.3f}, principal axis {d['axis_deg']:.1f} deg "
              f"({d['axis_off_y_deg']:.1f} deg off y)")
    return runs


def _pair(run_case, seed: int) -> tuple[Measured, Measured]:
    return (run_case("hs-only-case2-90mlmin.toml", seed=seed),
            run_case("hybrid-case2-90mlmin.toml", seed=seed))


def _compare(hs: Measured, hy: Measured) -> dict[str, bool]:
    dh, dy = _drops(hs), _drops(hy)
    lower = (hs.breakdown_MPa is not None and hy.breakdown_MPa is not None
             and hy.breakdown_MPa < hs.breakdown_MPa)
    gentler = (dh["drop_1ms_rel"] is not None and dy["drop_1ms_rel"] is not None
               and dy["drop_1ms_rel"] < dh["drop_1ms_rel"])
    return {
        "lower breakdown": lower,
        "more radial fractures": hy.radial.count > hs.radial.count,
        "smaller drop in 1 ms after peak": gentler,
        "smaller max drop rate": dy["max_drop_rate_MPa_per_ms"] < dh["max_drop_rate_MPa_per_ms"],
        "more fractures extended by injection": (hy.extended_by_injection()[0]
                                                 > hs.extended_by_injection()[0]),
    }


def _print_pair(seed: int, hs: Measured, hy: Measured) -> None:
    print(f"-- seed {seed}, Case 2, 90 ml/min")
    for name, m in (("HS-only", hs), ("hybrid", hy)):
        d = _drops(m)
        extra = ""
        if m.summary["peak_expansive_pressure_MPa"] is not None:
            n_pre = int(m.stage_rows("inject")[0]["n_cracks"])
            extra = (f", peak expansive {m.summary['peak_expansive_pressure_MPa']:.2f} MPa, "
                     f"{n_pre} cracks before injection")
        print(f"{name:8s} breakdown {_fmt(m.breakdown_MPa)} MPa at "
              f"{_fmt(d['breakdown_time_ms'])} ms, drop in 0.5 / 1 ms after it "
              f"{_fmt(d['drop_0.5ms_rel'], '.3f')} / {_fmt(d['drop_1ms_rel'], '.3f')} of the "
              f"peak, max drop rate {d['max_drop_rate_MPa_per_ms']:.2f} MPa/ms, final "
              f"{d['final_MPa']:.2f} MPa; cracks (T/S) {m.cracks_ts}{extra}; {m.radial_text()}")
        n, detail = m.extended_by_injection()
        print(f"{'':8s} extended by injection: {n} ({detail})")
    for claim, holds in _compare(hs, hy).items():
        print(f"   {claim}: {'holds' if holds else 'DOES NOT HOLD'}")


@pytest.fixture(scope="module")
def pair_seed0(run_case) -> tuple[Measured, Measured]:
    hs, hy = _pair(run_case, 0)
    print("\n== Hybrid vs HS-only")
    _print_pair(0, hs, hy)
    return hs, hy


# --------------------------------------------------------------------------- 1. SCDA alone

@pytest.mark.parametrize("case", ["case1", "case2", "case3", "case4"])
def test_scda_forms_multiple_radial_fractures(scda_runs, case):
    """Seed 0: 4 / 3 / 3 / 4 radial fractures in Cases 1-4 with the SCDA plug of blocks and
    its smooth wall (a bonded wall gave 3 / 2 / 1 / 2). Over seeds 1 and 2 the counts are
    4 / 1 / 1 / 2 and 5 / 3 / 2 / 4: the ensemble is in ``grainfrac study paper``."""
    m = scda_runs[case]
    print(f"\n{case}: {m.radial_text()}")
    assert m.radial.count >= 3, f"{case}: {m.radial_text()}"


def test_scda_charging_stops_at_the_peak_expansive_pressure(scda_runs):
    for case, m in scda_runs.items():
        peak = m.scenario.stages[1].peak_pressure_MPa
        last = float(m.stage_rows("scda")[-1]["expansive_pressure_MPa"])
        assert m.summary["peak_expansive_pressure_MPa"] >= peak, case
        assert last >= peak, f"{case}: charging ended at {last:.2f} MPa, not at the peak"
        # ... and not far past it (one chunk of 500 steps of overshoot at most).
        assert m.summary["peak_expansive_pressure_MPa"] < 1.02 * peak, case


def test_scda_fractures_shorter_under_case3_than_case1(scda_runs):
    e1 = scda_runs["case1"].radial.fracture_extent
    e3 = scda_runs["case3"].radial.fracture_extent
    m1 = max(scda_runs["case1"].radial.extents, default=math.nan)
    m3 = max(scda_runs["case3"].radial.extents, default=math.nan)
    print(f"\nSCDA fracture extent (from the well centre): case1 {_fmt(e1 and e1 * 1e3, '.1f')} "
          f"mm, case3 {_fmt(e3 and e3 * 1e3, '.1f')} mm; longest radial branch case1 "
          f"{m1 * 1e3:.1f} mm, case3 {m3 * 1e3:.1f} mm; cracks case1 "
          f"{scda_runs['case1'].cracks_ts}, case3 {scda_runs['case3'].cracks_ts}")
    assert e1 is not None and e3 is not None
    assert e3 < e1
    assert m3 < m1


# --------------------------------------------------------------------------- 2. HS alone


def test_hs_case2_breaks_down_and_grows_along_the_major_stress_y(hs_cases):
    m = hs_cases["case2"]
    t, p = m.injection()
    bd = breakdown(t, p)
    d = _direction(m.x_mm, m.y_mm)
    assert bd is not None and m.breakdown_MPa is not None
    assert m.summary["n_cracks"] > 0
    assert p[-1] < bd.pressure  # the pressure falls after breakdown
    # The far cracks lie along y: mostly near the y axis (2/pi for no preference) ...
    assert d["mean_abs_sin"] > 0.7, d
    # ... and the line through the well that they follow is within 30 deg of y.
    assert d["axis_off_y_deg"] < 30.0, d


def test_hs_breakdown_pressure_lowest_in_case1(hs_cases):
    bd = {case: m.breakdown_MPa for case, m in hs_cases.items()}
    print("\nHS breakdown (MPa): " + ", ".join(f"{c} {_fmt(v)}" for c, v in bd.items()))
    assert all(v is not None for v in bd.values()), bd
    for case in ("case2", "case3", "case4"):
        assert bd["case1"] < bd[case], bd


@pytest.mark.xfail(strict=False, reason=(
    "paper Fig. 12e: highest breakdown in Case 4. Measured at 90 ml/min, seed 0: "
    "case1 7.51, case2 9.64, case3 11.80, case4 8.30 MPa (case 4 second lowest; case 3 "
    "highest, the order of the elastic Hubbert-Willis 3 sigma_min - sigma_max + T)"))
def test_hs_breakdown_pressure_highest_in_case4(hs_cases):
    bd = {case: m.breakdown_MPa for case, m in hs_cases.items()}
    print("\nHS breakdown (MPa): " + ", ".join(f"{c} {_fmt(v)}" for c, v in bd.items())
          + f"; case4 / case2 = {bd['case4'] / bd['case2']:.3f}")
    assert bd["case4"] >= max(bd["case1"], bd["case2"], bd["case3"]), bd


# --------------------------------------------------------------------------- 3. hybrid


def test_hybrid_pressure_falls_less_after_breakdown(pair_seed0):
    """No abrupt drop: a smaller fall of the well pressure within 1 ms after breakdown.

    Seed 0: 2.1 vs 4.6 % (the hybrid peaks four times within 3.4 ms, then falls
    gradually). Seed 2 holds as well (4.8 vs 5.5 %), seed 1 does not (4.4 vs 3.9 %); the
    mean over 10 realisations does (4.1 vs 8.2 %, README). It was an xfail while the
    pressure solve lumped each crack's uniform mode onto its nodes (seed 0: 6.3 vs 5.1 %,
    read at the second of two peaks)."""
    hs, hy = pair_seed0
    dh, dy = _drops(hs), _drops(hy)
    assert dh["drop_1ms_rel"] is not None and dy["drop_1ms_rel"] is not None
    assert dy["drop_1ms_rel"] < dh["drop_1ms_rel"], (dh, dy)


def test_hybrid_pressure_falls_less_steeply(pair_seed0):
    """No abrupt drop: a smaller steepest fall between fluid steps (0.01 ms) during injection.
    A noisy measure (one pair of samples): seed 0 gives hybrid 3.67 vs HS-only 5.13 MPa/ms;
    seeds 1 and 2 hold as well (2.59 vs 6.48, 5.03 vs 5.41). It was an xfail from 90a3eee
    (3.57 vs 3.25) until drained pores stopped holding their pressure past their fluid."""
    hs, hy = pair_seed0
    dh, dy = _drops(hs), _drops(hy)
    assert dy["max_drop_rate_MPa_per_ms"] < dh["max_drop_rate_MPa_per_ms"], (dh, dy)


def test_hybrid_breaks_down_below_hs_only(pair_seed0):
    """A small margin: 9.37 vs 9.64 MPa (seed 0) with the 5 % mass-scaling quantile
    and the step control of this version; the closed SCDA cracks barely take fluid
    before breakdown (it was 10.32 vs 10.10, an xfail, at ae72664)."""
    hs, hy = pair_seed0
    assert hs.breakdown_MPa is not None and hy.breakdown_MPa is not None
    assert hy.breakdown_MPa < hs.breakdown_MPa


def test_hybrid_extends_more_radial_fractures_than_hs_only(pair_seed0):
    hs, hy = pair_seed0
    assert hy.radial.count > hs.radial.count


@pytest.mark.xfail(strict=False, reason=(
    "marginal at seed 0: 2 vs 2 at f18a681 and after (now HS-only: new branches at 52 and "
    "267 deg; hybrid: its SCDA branches at 52 and 278 deg lengthened, at 143 and 224 "
    "deg not); it was 3 vs 2 at b3ecbe7 and 2 vs 2 at d08d122; seeds 0-2 hold for 1 of 3. "
    "The radial count over 10 realisations holds (README)"))
def test_hybrid_injection_extends_more_fractures_than_hs_only(pair_seed0):
    """Stricter than the radial count: fractures that the injection itself created or lengthened.

    Seed 2 gives 2 vs 2 as well, seed 1 3 vs 2 (reported by test_hybrid_claims_over_seeds).
    """
    hs, hy = pair_seed0
    n_hs, d_hs = hs.extended_by_injection()
    n_hy, d_hy = hy.extended_by_injection()
    print(f"\nextended by injection: HS-only {n_hs} ({d_hs}); hybrid {n_hy} ({d_hy})")
    assert n_hy > n_hs


# --------------------------------------------------------------------------- 4. robustness


def test_hybrid_claims_over_seeds(run_case, pair_seed0):
    """Claim 3 for seeds 0, 1 and 2: reported, not asserted (seed 0 is asserted above)."""
    tally: dict[str, int] = {}
    print("\n== Hybrid vs HS-only over seeds")
    pairs = {0: pair_seed0, 1: _pair(run_case, 1), 2: _pair(run_case, 2)}
    for seed, (hs, hy) in pairs.items():
        _print_pair(seed, hs, hy)
        for claim, holds in _compare(hs, hy).items():
            tally[claim] = tally.get(claim, 0) + int(holds)
    for claim, n in tally.items():
        print(f"{claim}: holds for {n} of {len(pairs)} seeds")
    for hs, hy in pairs.values():
        assert hs.summary["n_cracks"] > 0 and hy.summary["n_cracks"] > 0
