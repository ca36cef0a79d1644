"""Measured table of the paper's cases: SCDA (Fig. 10), HS at 90 ml/min (Fig. 12), hybrid (Fig. 17).

Runs, for each seed, the SCDA-only cases 1-4 (examples/scda-case1..4.toml), HS-only at
90 ml/min under cases 1-4 (examples/hs-only-case2-90mlmin.toml with the stress case
replaced; the 18 ml/min Fig. 12 files are much slower) and the hybrid Case 2 at 90 ml/min
(examples/hybrid-case2-90mlmin.toml), one after the other, and prints one row per run:
breakdown pressure (injection runs) or peak expansive pressure (SCDA), radial fractures
crossing the circle of 2 well radii (summary.json ``n_radial_fractures``), fracture extent
from the well centre, cracks (tensile / shear), the relative well-pressure drop within
1 ms after breakdown, and wall time. tests/test_paper_claims.py checks the claims on the
same runs. About 4 minutes per seed on one core.

    python benchmarks/paper_cases.py [--seeds 0 1 2] [--only scda hs hybrid] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from grainfrac.analysis import breakdown, pressure_drop_after_peak
from grainfrac.scenario import Scenario, load_scenario
from grainfrac.simulation import run_scenario

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CASES = ("case1", "case2", "case3", "case4")
GROUPS = ("scda", "hs", "hybrid")


def plan(groups: list[str]) -> list[tuple[str, str, str]]:
    """(label, scenario file, stress case) of every run, in order."""
    runs: list[tuple[str, str, str]] = []
    if "scda" in groups:
        runs += [(f"SCDA {c}", f"scda-{c}.toml", c) for c in CASES]
    if "hs" in groups:
        runs += [(f"HS 90 ml/min {c}", "hs-only-case2-90mlmin.toml", c) for c in CASES]
    if "hybrid" in groups:
        runs.append(("hybrid 90 ml/min case2", "hybrid-case2-90mlmin.toml", "case2"))
    return runs


def scenario_for(toml: str, case: str, seed: int) -> tuple[Scenario, Any]:
    scenario, recipe = load_scenario(EXAMPLES / toml)
    data = scenario.model_dump()
    data["seed"] = seed
    if case != scenario.stress.case:
        data["stress"] = {"case": case}
        data["name"] = f"{scenario.name}-as-{case}"
    return Scenario.model_validate(data), recipe


def drop_after_breakdown(run_dir: Path, window_s: float = 1e-3) -> float | None:
    """Relative fall of the well pressure within ``window_s`` after breakdown (injection only)."""
    with open(run_dir / "history.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["stage"] == "inject"]
    if not rows:
        return None
    t = np.array([float(r["time_s"]) for r in rows])
    p = np.array([float(r["well_pressure_MPa"]) for r in rows]) * 1e6
    bd = breakdown(t - t[0], p)
    if bd is None:
        return None
    return pressure_drop_after_peak(t - t[0], p, window_s, peak_index=bd.index, relative=True)


def _num(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


HEADER = (f"{'case':24s} {'seed':>4s} {'breakdown':>9s} {'peak exp.':>9s} {'radial':>6s} "
          f"{'extent':>7s} {'cracks (T/S)':>14s} {'drop 1ms':>8s} {'wall':>6s}")
UNITS = (f"{'':24s} {'':>4s} {'MPa':>9s} {'MPa':>9s} {'':>6s} {'mm':>7s} {'':>14s} "
         f"{'of peak':>8s} {'s':>6s}")


def row(label: str, seed: int, s: dict[str, Any], drop: float | None, wall: float) -> str:
    cracks = f"{s['n_cracks']} ({s['n_tensile_cracks']}/{s['n_shear_cracks']})"
    return (f"{label:24s} {seed:4d} {_num(s['breakdown_pressure_MPa'], '.2f'):>9s} "
            f"{_num(s['peak_expansive_pressure_MPa'], '.2f'):>9s} {s['n_radial_fractures']:6d} "
            f"{_num(s['fracture_extent_mm'], '.1f'):>7s} {cracks:>14s} "
            f"{_num(drop, '.3f'):>8s} {wall:6.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="seeds (default 0)")
    parser.add_argument("--only", nargs="+", choices=GROUPS, default=list(GROUPS),
                        help="which groups of cases to run (default all)")
    parser.add_argument("--out", type=Path, default=None,
                        help="directory for the run directories (default: a new temp dir)")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="grainfrac-paper-cases-"))
    lines: list[str] = []
    print(HEADER)
    print(UNITS, flush=True)
    start = time.perf_counter()
    for seed in args.seeds:
        for label, toml, case in plan(args.only):
            scenario, recipe = scenario_for(toml, case, seed)
            run_dir = out / f"{Path(toml).stem}-{case}-s{seed}"
            t0 = time.perf_counter()
            summary = run_scenario(scenario, recipe, run_dir, base_dir=EXAMPLES)
            wall = time.perf_counter() - t0
            line = row(label, seed, summary, drop_after_breakdown(run_dir), wall)
            lines.append(line)
            print(line, flush=True)
    total = time.perf_counter() - start
    if len(args.seeds) > 1:
        print("\n" + HEADER)
        print(UNITS)
        print("\n".join(sorted(lines, key=lambda s: (s[:24], s[25:29]))))
    print(f"\n{len(lines)} runs in {total:.0f} s; run directories in {out}")


if __name__ == "__main__":
    main()
