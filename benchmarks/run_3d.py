"""Benchmark: wall time of a 3D stimulation run, stage by stage.

Runs a 3D scenario file (default: the HS-only Case 2 slab of ``examples/3d``) into a
temporary directory and prints the wall time of the whole run, its mechanical steps,
tetrahedron-steps per second, and the breakdown it found. ``--threads`` is the run's
``GRAINFRAC_THREADS`` (the mechanics' worker threads).

Usage::

    python benchmarks/run_3d.py                         # the example, 1 thread
    python benchmarks/run_3d.py examples/3d/hs-only-case2-90mlmin.toml --threads 2
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import tempfile
import time
from pathlib import Path

DEFAULT = Path(__file__).resolve().parents[1] / "examples" / "3d" / "hs-only-case2-90mlmin.toml"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", type=Path, default=DEFAULT,
                        help="3D scenario file")
    parser.add_argument("--seed", type=int, default=None, help="override the file's seed")
    parser.add_argument("--threads", type=int, default=1, help="mechanics threads")
    args = parser.parse_args(argv)
    os.environ["GRAINFRAC_THREADS"] = str(args.threads)
    os.environ.setdefault("NUMBA_NUM_THREADS", str(args.threads))

    from grainfrac.scenario import load_scenario
    from grainfrac.simulation import run_scenario

    scenario, recipe = load_scenario(args.scenario)
    if scenario.dimension != 3:
        parser.error(f"{args.scenario} is not a 3D scenario (dimension = {scenario.dimension})")
    if args.seed is not None:
        scenario = scenario.with_seed(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        summary = run_scenario(scenario, recipe, Path(tmp) / "run",
                               base_dir=args.scenario.parent)
        wall = time.perf_counter() - start
        with open(Path(tmp) / "run" / "history.csv", newline="") as f:
            last_step = int(list(csv.DictReader(f))[-1]["step"])
    tet_steps = last_step * summary["n_elements"]
    print(f"{args.scenario.name}, seed {scenario.seed}, {args.threads} thread(s): "
          f"{summary['n_elements']} tetrahedra, {summary['n_contacts']} sub-contacts")
    print(f"wall time {wall:.0f} s ({wall / 60:.1f} min) for {last_step} mechanical steps: "
          f"{tet_steps / wall:.3g} tet-steps/s")
    for kind, (t0, t1) in summary["stage_times_s"].items():
        print(f"  {kind:<12} {1e3 * (t1 - t0):8.3f} ms simulated")
    bd = summary["breakdown_pressure_MPa"]
    print(f"breakdown {'-' if bd is None else f'{bd:.3f} MPa'}, "
          f"{summary['n_cracks']} cracks, radial fractures top/mid "
          f"{summary.get('n_radial_fractures_top')}/{summary.get('n_radial_fractures_mid')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
