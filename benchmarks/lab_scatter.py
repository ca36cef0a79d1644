"""How many grain realisations does a calibration need? (issue 6)

    python benchmarks/lab_scatter.py                          # Table 2, seeds 0-23
    python benchmarks/lab_scatter.py --rock calib/strathbogie-granite-2d.toml --seeds 12

Runs the UCS, BTS and NSCB tests of a recipe over seeds 0..N-1 (2-5 mm grains,
the calibration's default) and prints, per quantity, the mean, the coefficient
of variation between realisations, the Student-t 95 % interval of the mean,
the means of the first and second half of the seeds, and how many realisations
a mean known to +-5 % (95 %) would need: n = (t s / (0.05 mean))^2, with t the
Student quantile of the seeds run.

A calibration matches the mean over its own seeds; when the scatter is large
that mean says little about other grain structures (``validation_seeds`` in
the targets file measures exactly that).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from grainfrac import calibration, materials
from grainfrac.analysis import stats
from grainfrac.assembly import GrainSpec
from grainfrac.labtests.config import LAB_GRAINS

TOLERANCE = 0.05


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rock", default="strathbogie-granite",
                        help="rock preset or recipe TOML (default: Table 2)")
    parser.add_argument("--seeds", type=int, default=24, help="realisations 0..N-1")
    args = parser.parse_args()
    recipe = materials.load_recipe(args.rock)
    seeds = list(range(args.seeds))
    start = time.perf_counter()
    with calibration.LabBench(seeds, GrainSpec(**LAB_GRAINS)) as bench:
        _, runs = bench.measure(recipe, ("ucs", "bts", "nscb"))
    wall = time.perf_counter() - start
    half = args.seeds // 2
    left_out = calibration.no_peak_runs(runs)
    print(f"{recipe.name}: seeds 0-{args.seeds - 1}, grains {LAB_GRAINS['min_edge_mm']:g}-"
          f"{LAB_GRAINS['max_edge_mm']:g} mm, {wall:.0f} s; no peak (left out): "
          f"{', '.join(left_out) or 'none'}")
    print(f"{'quantity':<20} {'mean':>8} {'CV':>6} {'95 % CI of mean':>19} "
          f"{'first half':>10} {'second half':>11} {'n for 5 %':>9}")
    for key in calibration.MEASURED:
        values = np.array(calibration.measured_values(runs, key))
        mean = stats.summarise(values)
        cv = mean.std / mean.mean
        needed = math.ceil((stats.t_quantile(len(values) - 1) * cv / TOLERANCE) ** 2)
        print(f"{calibration.LABELS[key]:<20} {mean.mean:>8.4g} {cv:>6.1%} "
              f"{mean.ci_low:>9.4g} - {mean.ci_high:<7.4g} {values[:half].mean():>10.4g} "
              f"{values[half:].mean():>11.4g} {needed:>9d}")


if __name__ == "__main__":
    main()
