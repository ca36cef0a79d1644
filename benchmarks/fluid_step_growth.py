"""Benchmark: a growing fluid step (``inject.max_time_step_ms``) against the fixed one.

Runs a scenario as it is (every fluid step ``time_step_ms``) and with the injection's
fluid step allowed to grow to ``--max-step-ms`` while the injection is quiet
(``grainfrac.stages.inject.next_time_step``), for each seed, and prints the breakdown
pressure, the fluid steps of the injection (pressure solves), the explicit steps,
the cracks and the wall time of both, and the breakdown's relative difference.

Usage (from the repository root)::

    python benchmarks/fluid_step_growth.py                        # small 3D slab, 18 ml/min
    python benchmarks/fluid_step_growth.py --scenario examples/case2-hs.toml --seeds 0 1 2
"""

from __future__ import annotations

import argparse
import csv
import time
import tomllib
from pathlib import Path
from tempfile import TemporaryDirectory

from grainfrac.io.config import validate
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario

ROOT = Path(__file__).resolve().parents[1]
SMALL_3D = ROOT / "tests" / "data" / "hybrid3d-small.toml"


def scenario_with(raw: dict, seed: int, rate: float | None, duration_ms: float | None,
                  max_step_ms: float | None) -> Scenario:
    """``raw`` with the seed and, on every inject stage, the rate, duration and growth."""
    raw = {**raw, "seed": seed, "stages": [dict(s) for s in raw["stages"]]}
    for stage in raw["stages"]:
        if stage.get("kind") != "inject":
            continue
        if rate is not None:
            stage["rate_ml_per_min"] = rate
        if duration_ms is not None:
            stage["duration_ms"] = duration_ms
        if max_step_ms is not None:
            stage["max_time_step_ms"] = max_step_ms
    return validate(Scenario, raw)


def measure(scenario: Scenario, out: Path) -> dict:
    start = time.perf_counter()
    summary = run_scenario(scenario, scenario.recipe(), out, overwrite=True)
    wall = time.perf_counter() - start
    with open(out / "history.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["stage"] == "inject"]
    return {"breakdown_MPa": summary.get("breakdown_pressure_MPa"), "fluid_steps": len(rows),
            "explicit_steps": int(rows[-1]["step"]) if rows else 0,
            "cracks": summary["n_cracks"], "wall_s": wall}


def _mpa(value: float | None) -> str:
    return "no breakdown" if value is None else f"{value:.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", type=Path, default=SMALL_3D)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1])
    parser.add_argument("--rate", type=float, default=None,
                        help="injection rate [ml/min] (default: the scenario's; 18 for the "
                             "small 3D slab)")
    parser.add_argument("--duration-ms", type=float, default=None,
                        help="injection time [ms] (default: the scenario's; 12 for the small "
                             "3D slab)")
    parser.add_argument("--max-step-ms", type=float, default=0.16)
    args = parser.parse_args()
    raw = tomllib.loads(args.scenario.read_text())
    if args.scenario == SMALL_3D:
        args.rate = args.rate or 18.0
        args.duration_ms = args.duration_ms or 12.0
    print(f"{args.scenario.name}: rate {args.rate or 'as given'} ml/min, growth to "
          f"{args.max_step_ms:g} ms")
    print("seed | fixed: breakdown MPa, fluid steps, explicit steps, cracks, wall s | grown: "
          "same | breakdown difference")
    with TemporaryDirectory() as tmp:
        for seed in args.seeds:
            runs = [measure(scenario_with(raw, seed, args.rate, args.duration_ms, growth),
                            Path(tmp) / f"{seed}-{i}")
                    for i, growth in enumerate((None, args.max_step_ms))]
            cells = [f"{_mpa(r['breakdown_MPa'])}, {r['fluid_steps']}, {r['explicit_steps']}, "
                     f"{r['cracks']}, {r['wall_s']:.1f}" for r in runs]
            fixed, grown = (r["breakdown_MPa"] for r in runs)
            diff = "-" if fixed is None or grown is None else f"{100 * (grown / fixed - 1):+.2f} %"
            print(f"{seed} | {cells[0]} | {cells[1]} | {diff}", flush=True)


if __name__ == "__main__":
    main()
