"""Benchmark: where the wall time of a coupled injection run goes.

On the default slab (100 x 100 mm, 10 mm borehole, seed 0), in-situ stress
case 2 (2.5 / 5 MPa), outer sides drained at 0 Pa, 90 ml/min into the well,
``N`` coupled steps of ``dt``. Each :meth:`HydroMechanicalSolver.advance`
does one implicit pressure solve (:func:`grainfrac.physics.flow.implicit_step`)
and one batch of explicit mechanics steps (:meth:`MechanicsSolver.cycle`);
both are wrapped with ``time.perf_counter`` and their share of the total
wall time of the advances is printed. The rest ("other") is the coupling
glue: apertures from openings, pore compliances, pressure loads, history.

A few warm-up steps run first and are not counted (numba's first call, scipy's
first factorisation).

``--dim 3`` times the same on a 3D slab of polyhedral grains (``--width-mm`` square,
``--thickness-mm`` thick, borehole along z, sigma_z of the case on its faces): the
issue's "no part other than the mechanics takes over half" is read from its shares.
The contacts are stepped inside ``mechanics.cycle`` (one kernel with the elements).

``--mechanics-steps K`` runs only ``K`` explicit steps per coupled step (the fluid step's
time still flows into the well): what is left is the host's share of a coupled step,
the work a GPU run does on the host while the device does the mechanics. With
``--in-situ-steps`` capping the equilibration (the 100 mm cube's takes hours on two
cores; ``--in-situ-method static`` reaches it by a static solve instead) and
``--profile`` printing where that host time goes, it measures the host
work per fluid step of the cube's network without a GPU.

``--first-step SCENARIO`` times instead the first injection step's pressure solve of a
scenario's specimen (the whole network conducting at the initial aperture, no
mechanics) three ways: conjugate gradients started from zero (the code's solve from
``pressure_system.ITERATIVE_MIN_UNKNOWNS`` unknowns up), the factorisation ordered for a
symmetric matrix (the code's below that), and SuperLU's default column ordering; it
prints each one's time and well pressure.

Usage::

    python benchmarks/pressure_solve.py --steps 200 --dt 1e-5
    python benchmarks/pressure_solve.py --dim 3 --width-mm 100 --thickness-mm 20 --steps 50
    python benchmarks/pressure_solve.py --first-step examples/3d/hybrid-case3-cube.toml
    python benchmarks/pressure_solve.py --dim 3 --width-mm 100 --thickness-mm 100 \
        --case case3 --in-situ-steps 300 --mechanics-steps 1 --steps 20 --profile 25
"""

from __future__ import annotations

import argparse
import cProfile
import math
import pstats
import sys
import time
from pathlib import Path

import numpy as np
from scipy.sparse.linalg import splu

from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.loading.insitu import STRESS_CASES, initialise_in_situ
from grainfrac.physics import flow, pressure_system
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.scenario import load_scenario
from grainfrac.units import ML_PER_MIN, MPA


def build_solver(seed: int, case: str, dim: int = 2, width_mm: float = 100.0,
                 thickness_mm: float = 20.0, in_situ_steps: int = 200_000,
                 in_situ_method: str = "explicit") -> HydroMechanicalSolver:
    spec = {"seed": seed}
    sides = ("left", "right", "top", "bottom")
    if dim == 3:
        spec = {"seed": seed, "dimension": 3,
                "specimen": {"shape": "slab", "width_mm": width_mm, "height_mm": width_mm,
                             "thickness_mm": thickness_mm}}
        sides = ("x-", "x+", "y-", "y+")
    config = validate(SpecimenConfig, spec)
    assembly = build_assembly(config, config.recipe())
    mechanics = MechanicsSolver(build_mechanical_model(assembly))
    sx, sy, sz = STRESS_CASES[case]
    initialise_in_situ(mechanics, assembly.mesh, sx * MPA, sy * MPA,
                       sz * MPA if dim == 3 else 0.0, max_steps=in_situ_steps,
                       method=in_situ_method)
    network = flow.build_flow_network(assembly.mesh, permeable_sides=dict.fromkeys(sides, 0.0),
                                      well=True, wall="sealed")
    return HydroMechanicalSolver(assembly, mechanics, network, flow.FluidProperties())


def timed_run(solver: HydroMechanicalSolver, steps: int, dt: float, rate: float,
              mechanics_steps: int | None = None,
              profile: cProfile.Profile | None = None) -> dict[str, float]:
    """Advance ``steps`` times; return wall seconds in the flow solve, the mechanics, in all.

    ``mechanics_steps``: at most this many explicit steps per coupled step.
    ``profile``: enabled around the timed steps."""
    times = {"flow": 0.0, "mechanics": 0.0, "total": 0.0}
    original_step = flow.implicit_step
    original_cycle = solver.mechanics.cycle

    def timed_step(*args, **kwargs):
        start = time.perf_counter()
        try:
            return original_step(*args, **kwargs)
        finally:
            times["flow"] += time.perf_counter() - start

    def timed_cycle(*args, **kwargs):
        start = time.perf_counter()
        try:
            n = args[0] if mechanics_steps is None else min(args[0], mechanics_steps)
            return original_cycle(n, *args[1:], **kwargs)
        finally:
            times["mechanics"] += time.perf_counter() - start

    flow.implicit_step = timed_step
    solver.mechanics.cycle = timed_cycle
    try:
        if profile is not None:
            profile.enable()
        start = time.perf_counter()
        for _ in range(steps):
            solver.advance(dt, rate)
        times["total"] = time.perf_counter() - start
    finally:
        if profile is not None:
            profile.disable()
        flow.implicit_step = original_step
        del solver.mechanics.cycle
    return times


def first_step(path: Path, rate_ml_per_min: float, dt: float) -> int:
    """The first fluid step's pressure solve of a scenario's specimen, both orderings."""
    scenario, recipe = load_scenario(path)
    start = time.perf_counter()
    assembly = build_assembly(scenario.specimen_config(), recipe)
    fluid = scenario.fluid.properties()
    network = flow.build_flow_network(
        assembly.mesh, permeable_sides=scenario.fluid.fixed_pressures(assembly.dimension))
    aperture = flow.pore_aperture(np.zeros(assembly.mesh.n_contacts), fluid)
    print(f"{path}: {assembly.mesh.n_elements} elements, {network.n_unknowns} pressure "
          f"unknowns (built in {time.perf_counter() - start:.1f} s); one step of {dt:g} s "
          f"at {rate_ml_per_min:g} ml/min")
    ordered, threshold = pressure_system.factorised, pressure_system.ITERATIVE_MIN_UNKNOWNS
    solves = {"conjugate gradients (Jacobi), from zero": (ordered, 0),
              "symmetric (minimum degree on A + A^T)": (ordered, network.n_unknowns + 1),
              "SuperLU default (COLAMD)": (splu, network.n_unknowns + 1)}
    try:
        for label, (factorise, smallest_iterative) in solves.items():
            pressure_system.factorised = factorise
            pressure_system.ITERATIVE_MIN_UNKNOWNS = smallest_iterative
            state = flow.initial_state(network, aperture, fluid)
            start = time.perf_counter()
            flow.implicit_step(network, state, aperture, dt, fluid,
                               rate_ml_per_min * ML_PER_MIN)
            print(f"  {label:<42}{time.perf_counter() - start:8.2f} s, well pressure "
                  f"{state.pressure[network.well_unknown]:.9g} Pa")
    finally:
        pressure_system.factorised = ordered
        pressure_system.ITERATIVE_MIN_UNKNOWNS = threshold
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200, help="coupled (fluid) steps timed")
    parser.add_argument("--dt", type=float, default=1e-5, help="fluid step (s)")
    parser.add_argument("--rate", type=float, default=90.0, help="injection rate (ml/min)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the slab")
    parser.add_argument("--case", default="case2", choices=sorted(STRESS_CASES),
                        help="in-situ stress case (paper Table 6)")
    parser.add_argument("--warmup", type=int, default=5, help="untimed steps first")
    parser.add_argument("--dim", type=int, default=2, choices=(2, 3), help="2D or 3D slab")
    parser.add_argument("--width-mm", type=float, default=100.0, help="3D slab side (mm)")
    parser.add_argument("--thickness-mm", type=float, default=20.0,
                        help="3D slab thickness (mm)")
    parser.add_argument("--first-step", type=Path, default=None, metavar="SCENARIO",
                        help="time the first pressure solve of this scenario's specimen")
    parser.add_argument("--in-situ-steps", type=int, default=200_000,
                        help="at most this many steps of in-situ equilibration")
    parser.add_argument("--in-situ-method", choices=("explicit", "static"), default="explicit",
                        help="in-situ equilibrium by explicit steps alone or a static solve "
                             "first (the cube's in minutes instead of hours)")
    parser.add_argument("--mechanics-steps", type=int, default=None,
                        help="at most this many explicit steps per coupled step (host share)")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="print the N functions of most own time in the timed steps")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error("--steps must be >= 1")
    if args.mechanics_steps is not None and args.mechanics_steps < 1:
        parser.error("--mechanics-steps must be >= 1")
    if args.first_step is not None:
        return first_step(args.first_step, args.rate, args.dt)

    start = time.perf_counter()
    solver = build_solver(args.seed, args.case, args.dim, args.width_mm, args.thickness_mm,
                          args.in_situ_steps, args.in_situ_method)
    setup = time.perf_counter() - start
    rate = args.rate * ML_PER_MIN
    for _ in range(args.warmup):
        solver.advance(args.dt, rate)
    profile = cProfile.Profile() if args.profile else None
    times = timed_run(solver, args.steps, args.dt, rate, args.mechanics_steps, profile)

    m = solver.mechanics
    substeps = max(1, math.ceil(args.dt / m.model.dt))
    total = times["total"]
    other = total - times["flow"] - times["mechanics"]
    what = ("default slab" if args.dim == 2 else
            f"3D slab {args.width_mm:g} x {args.width_mm:g} x {args.thickness_mm:g} mm, "
            f"{m.model.n_elements} tetrahedra")
    print(f"{what}, seed {args.seed}, {args.case}, {args.rate:g} ml/min: "
          f"{solver.network.n_unknowns} pressure unknowns, {m.model.n_nodes} nodes, "
          f"{m.model.n_contacts} sub-contacts; setup (build + in-situ) {setup:.2f} s")
    if args.mechanics_steps is not None:
        substeps = min(substeps, args.mechanics_steps)
    print(f"{args.steps} coupled steps of {args.dt:g} s ({substeps} mechanics steps of "
          f"{m.model.dt:.3g} s each): {total:.3f} s wall, "
          f"{1e3 * total / args.steps:.2f} ms per step")
    print(f"{'part':<30}{'wall (s)':>10}{'per step (ms)':>15}{'share':>9}")
    for name, label in (("flow", "flow.implicit_step"), ("mechanics", "mechanics.cycle")):
        print(f"{label:<30}{times[name]:>10.3f}{1e3 * times[name] / args.steps:>15.3f}"
              f"{100 * times[name] / total:>8.1f}%")
    print(f"{'other (coupling glue)':<30}{other:>10.3f}{1e3 * other / args.steps:>15.3f}"
          f"{100 * other / total:>8.1f}%")
    print(f"state after: well pressure {solver.well_pressure / MPA:.3f} MPa, "
          f"{len(m.cracks.contact)} cracks")
    if profile is not None:
        pstats.Stats(profile).sort_stats("tottime").print_stats(args.profile)
    return 0


if __name__ == "__main__":
    sys.exit(main())
