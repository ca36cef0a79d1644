"""Benchmark: wall time of a 3D stimulation run, stage by stage.

Runs a 3D scenario file (default: the HS-only Case 2 slab of ``examples/3d``) into a
temporary directory and prints the wall time of the whole run, its mechanical steps,
tetrahedron-steps per second, the breakdown it found, and the wall time split into:

- set-up: building the grain assembly and the mechanical model;
- mechanics: the explicit steps (element forces, contact law, node update: one
  compiled loop, so the contacts' share is not timed apart);
- pressure solve: the fluid's implicit steps (``flow.implicit_step``);
- output: snapshots and checkpoints;
- coupling and host: the rest (the coupling's apertures and pressures on contacts,
  crack events, histories, stage logic, figures).

``--threads`` is the run's ``GRAINFRAC_THREADS`` (the mechanics' worker threads).

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

    import grainfrac.run as run_module
    from grainfrac.io.snapshots import SnapshotSeries
    from grainfrac.physics import flow
    from grainfrac.physics.solver import MechanicsSolver
    from grainfrac.scenario import load_scenario
    from grainfrac.simulation import run_scenario

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from _clock import Clock

    scenario, recipe = load_scenario(args.scenario)
    if scenario.dimension != 3:
        parser.error(f"{args.scenario} is not a 3D scenario (dimension = {scenario.dimension})")
    if args.seed is not None:
        scenario = scenario.with_seed(args.seed)
    clock = Clock()
    clock.wrap(run_module, "build_assembly", "set-up")
    clock.wrap(run_module, "build_mechanical_model", "set-up")
    clock.wrap(MechanicsSolver, "cycle", "mechanics")
    clock.wrap(flow, "implicit_step", "pressure solve")
    clock.wrap(SnapshotSeries, "write", "output")
    clock.wrap(run_module, "write_checkpoint", "output")
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        try:
            summary = run_scenario(scenario, recipe, Path(tmp) / "run",
                                   base_dir=args.scenario.parent)
        finally:
            clock.restore()
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
    books = summary.get("hydraulic_energy_J")
    if books:
        print(f"fluid energy books: residual {books['residual'] / books['pumped']:+.2%} of "
              f"the {books['pumped']:.4g} J pumped")
    split = dict(clock.seconds)
    split["coupling and host"] = wall - sum(split.values())
    print("time split:")
    for part, seconds in split.items():
        print(f"  {part:<18} {seconds:8.1f} s  {seconds / wall:6.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
