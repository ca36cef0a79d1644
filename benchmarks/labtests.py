"""Wall time of each virtual lab test and of a calibration (issue 6).

    python benchmarks/labtests.py              # the four tests, seed 0
    python benchmarks/labtests.py --calibrate  # also the example calibration (minutes)

Prints one line per test (value, grains, steps, wall time) and, with
--calibrate, the evaluations, the target-vs-achieved table and the total time.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory

from grainfrac.labtests import lab_test_config, measure

KEYS = {"ucs": "ucs_MPa", "bts": "bts_MPa", "nscb": "kic_MPa_sqrt_m",
        "permeability": "permeability_m2"}


def main() -> None:
    measure(lab_test_config("bts", seed=0, loading={"max_strain": 1e-4}))  # compile kernels
    for test, key in KEYS.items():
        start = time.perf_counter()
        s = measure(lab_test_config(test, seed=0))["summary"]
        wall = time.perf_counter() - start
        print(f"{test:<13} {key} = {s[key]:.4g}  ({s['n_grains']} grains, "
              f"{s.get('steps', '-')} steps)  wall {wall:.2f} s", flush=True)
    if "--calibrate" in sys.argv:
        from grainfrac import calibration

        example = Path(__file__).parents[1] / "examples" / "calibration" / "strathbogie-2d.toml"
        config, recipe = calibration.load_calibration_config(example)
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
