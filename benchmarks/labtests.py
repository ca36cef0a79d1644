"""Wall time of each virtual lab test and of a calibration (issue 6).

    python benchmarks/labtests.py                      # the four tests, Table 2, seed 0
    python benchmarks/labtests.py --dim 3              # the four tests on the 3D specimens
    python benchmarks/labtests.py --rock examples/rocks/strathbogie-granite-breakable.toml
    python benchmarks/labtests.py --calibrate          # also the example calibration (minutes)
    python benchmarks/labtests.py --calibrate examples/calibration/strathbogie-2d-breakable.toml

Prints one line per test (value, grains, elements, steps, node-steps per second,
wall time; in 3D the time to the peak too) and, with
--calibrate, the evaluations, the target-vs-achieved table and the total time.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from tempfile import TemporaryDirectory

from grainfrac.labtests import lab_test_config, measure

KEYS = {"ucs": "ucs_MPa", "bts": "bts_MPa", "nscb": "kic_MPa_sqrt_m",
        "permeability": "permeability_m2"}
EXAMPLE = Path(__file__).parents[1] / "examples" / "calibration" / "strathbogie-2d.toml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rock", default="strathbogie-granite",
                        help="rock preset or recipe TOML for the four tests")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2,
                        help="2: plane-strain sections; 3: the specimens as solids")
    parser.add_argument("--calibrate", nargs="?", const=EXAMPLE, type=Path, default=None,
                        metavar="TARGETS", help="also time this calibration")
    args = parser.parse_args()

    measure(lab_test_config("bts", seed=0, loading={"max_strain": 1e-4}))  # compile kernels
    for test, key in KEYS.items():
        start = time.perf_counter()
        result = measure(lab_test_config(test, seed=args.seed, rock=args.rock,
                                         dimension=args.dim))
        wall = time.perf_counter() - start
        s = result["summary"]
        line = (f"{test:<13} {key} = {s[key]:.4g}  ({s['n_grains']} grains, "
                f"{s['n_elements']} elements, {s.get('steps', '-')} steps")
        if "steps" in s:
            nodes = result["assembly"].mesh.n_nodes
            line += f", {nodes * s['steps'] / wall:.3g} node-steps/s"
            curve = result["curve"]
            if curve is not None:
                line += f", peak at {s['peak_index'] + 1} of {len(curve.time)} samples"
        print(line + f")  wall {wall:.2f} s", flush=True)
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
