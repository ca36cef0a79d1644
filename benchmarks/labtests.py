"""Wall time of each virtual lab test and of a calibration (issue 6).

    python benchmarks/labtests.py                      # the four tests, Table 2, seed 0
    python benchmarks/labtests.py --dim 3              # the four tests on the 3D specimens
    python benchmarks/labtests.py --rock examples/rocks/strathbogie-granite-breakable.toml
    python benchmarks/labtests.py --calibrate          # also the example calibration (minutes)
    python benchmarks/labtests.py --calibrate examples/calibration/strathbogie-2d-breakable.toml

Prints one line per test (value, grains, elements, steps kept and discarded by a
fast approach, node-steps per second,
wall time, and for the platen tests the wall time to the peak sample and to
"post-peak": the first sample at which the load has fallen ``peak_drop_fraction``
below the peak, when the test knows its peak) and, with --calibrate, the
evaluations, the target-vs-achieved table and the total time. ``--threads`` sets
``GRAINFRAC_THREADS`` (the explicit step's threads; default 1).

For scale (issue 45): YADE's JCFPM Brazilian test of 5,090 rigid spheres takes 109 s
on one thread and 20,000 spheres 446 s on two (YADE 2023, on this kind of machine).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from tempfile import TemporaryDirectory

from grainfrac.labtests import lab_test_config, measure
from grainfrac.stages.platen import LoadingCurve

KEYS = {"ucs": "ucs_MPa", "bts": "bts_MPa", "nscb": "kic_MPa_sqrt_m",
        "permeability": "permeability_m2"}
EXAMPLE = Path(__file__).parents[1] / "examples" / "calibration" / "strathbogie-2d.toml"


class SampleClock:
    """Progress callback: the wall time (s since creation) and load of every curve sample."""

    def __init__(self):
        self.start = time.perf_counter()
        self.samples: list[tuple[float, float]] = []

    def __call__(self, curve: LoadingCurve) -> None:
        # A fast approach goes back in time: keep the samples of the curve as it stands
        # (after a rewind the curve has no new sample).
        del self.samples[len(curve.load):]
        if len(self.samples) < len(curve.load):
            self.samples.append((time.perf_counter() - self.start, float(curve.load[-1])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rock", default="strathbogie-granite",
                        help="rock preset or recipe TOML for the four tests")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2,
                        help="2: plane-strain sections; 3: the specimens as solids")
    parser.add_argument("--calibrate", nargs="?", const=EXAMPLE, type=Path, default=None,
                        metavar="TARGETS", help="also time this calibration")
    parser.add_argument("--threads", type=int, default=1,
                        help="threads of the explicit step (GRAINFRAC_THREADS)")
    parser.add_argument("--tests", nargs="+", choices=tuple(KEYS), default=tuple(KEYS))
    parser.add_argument("--approach", type=float, default=None, metavar="FACTOR",
                        help="loading.approach_speed_factor of every platen test "
                             "(1: none; default: each test's own)")
    args = parser.parse_args()
    os.environ["GRAINFRAC_THREADS"] = str(args.threads)

    measure(lab_test_config("bts", seed=0, loading={"max_strain": 1e-4}))  # compile kernels
    for test in args.tests:
        key = KEYS[test]
        loading = ({} if args.approach is None or test == "permeability"
                   else {"approach_speed_factor": args.approach})
        config = lab_test_config(test, seed=args.seed, rock=args.rock, dimension=args.dim,
                                 loading=loading)
        clock = SampleClock()
        result = measure(config, progress=clock)
        wall = time.perf_counter() - clock.start
        samples = clock.samples
        s = result["summary"]
        line = (f"{test:<13} {key} = {s[key]:.4g}  ({s['n_grains']} grains, "
                f"{s['n_elements']} elements, {s.get('steps', '-')} steps")
        if "steps" in s:
            nodes = result["assembly"].mesh.n_nodes
            steps = s["steps"] + s["steps_discarded"]
            if s["steps_discarded"]:
                line += f" kept + {s['steps_discarded']} of the fast approach discarded"
            line += f", {nodes * steps / wall:.3g} node-steps/s"
            curve = result["curve"]
            if curve is not None:
                peak = s["peak_index"]
                line += (f", peak at sample {peak + 1} of {len(curve.time)}: "
                         f"{samples[peak][0]:.1f} s to the peak")
                drop = (1.0 - config.resolved_loading.peak_drop_fraction) * samples[peak][1]
                after = next((t for t, load in samples[peak:] if load < drop), None)
                line += ("" if after is None else f", {after:.1f} s to post-peak")
        print(line + f")  wall {wall:.2f} s", flush=True)
        if test == "bts":
            print("              for scale: YADE's JCFPM Brazilian test, 5,090 rigid spheres "
                  "109 s on one thread, 20,000 spheres 446 s on two (YADE 2023)")
    if args.calibrate is not None:
        from grainfrac import calibration

        config, recipe = calibration.load_calibration_config(args.calibrate)
        start = time.perf_counter()
        result = calibration.calibrate(config, recipe, log=lambda m: print("  " + m, flush=True))
        wall = time.perf_counter() - start
        with TemporaryDirectory() as tmp:
            paths = calibration.write_calibration(result, config, tmp, wall)
            print(paths["table_md"].read_text())
        print(f"calibration: {len(result['history'])} evaluations over seeds {config.seeds}, "
              f"converged {result['converged']}, wall {wall:.0f} s")


if __name__ == "__main__":
    main()
