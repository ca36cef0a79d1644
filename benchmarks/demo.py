"""Wall time of `grainfrac demo` (HS-only vs hybrid, default slab, Case 2, 90 ml/min).

Target (issue 5): <= 60 s on 2 cores at default resolution. Prints the wall
time of the whole demo and of each run, and the headline numbers.

    python benchmarks/demo.py [--out DIR] [--workers N]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from grainfrac.runner import run_demo

TARGET_S = 60.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="grainfrac-demo-"))
    start = time.perf_counter()
    results = run_demo(out, seed=args.seed, workers=args.workers)
    wall = time.perf_counter() - start
    for name, summary in results.items():
        pb = summary["breakdown_pressure_MPa"]
        breakdown = "none detected" if pb is None else f"{pb:.2f} MPa"
        print(f"{name:8s} run wall time {summary['wall_time_s']:6.1f} s   breakdown "
              f"{breakdown}   radial fractures {summary['n_radial_fractures']}   "
              f"cracks {summary['n_cracks']}")
    verdict = "meets" if wall <= TARGET_S else "misses"
    print(f"demo wall time {wall:.1f} s ({verdict} the {TARGET_S:.0f} s target); output in {out}")


if __name__ == "__main__":
    main()
