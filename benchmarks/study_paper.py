"""Wall time of `grainfrac study paper` (the paper's whole study matrix on Dask).

Runs every study of grainfrac.studies.paper (22 points) with N realisations per point
(default 10: 220 runs) on a local Dask cluster, one worker per core, into a fresh
directory, then prints the wall time, the number of runs, the mean run time (each
run's own wall_time_s from summary.json), the mean per study and the claim verdicts.
Runs already in --out are skipped, so pass a fresh --out to time everything.

    python benchmarks/study_paper.py [--realisations N] [--only STUDY ...] [--out DIR]
                                     [--workers N] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from grainfrac.studies.paper import STUDY_NAMES
from grainfrac.studies.study import run_paper_study


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=10)
    parser.add_argument("--only", nargs="*", choices=STUDY_NAMES, default=None)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--scheduler", default=None)
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="grainfrac-study-"))
    start = time.perf_counter()
    done = run_paper_study(out, realisations=args.realisations, only=args.only,
                           scheduler=args.scheduler, n_workers=args.workers)
    wall = time.perf_counter() - start
    all_times = []
    for o in done.outcomes:
        times = [r["wall_time_s"] for r in o.result.runs if r.get("wall_time_s") is not None]
        all_times += times
        mean = f"{statistics.fmean(times):6.1f} s" if times else "     -"
        print(f"{o.study.name:18s} {len(o.result.runs):4d} runs   mean run {mean}   "
              + ", ".join(f"{v.claim.id}: {v.verdict}" for v in o.verdicts))
    n = len(all_times)
    mean_run = statistics.fmean(all_times) if all_times else float("nan")
    print(f"study paper, {args.realisations} realisation(s) per point: {n} runs "
          f"({done.runs_computed} computed now) in {wall:.1f} s wall; mean run time "
          f"{mean_run:.1f} s (sum {sum(all_times):.0f} s of run time); failures: "
          f"{len(done.failures)}; report in {out}/report.html")


if __name__ == "__main__":
    main()
