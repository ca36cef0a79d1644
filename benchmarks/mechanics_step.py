"""Benchmark: explicit mechanics step rate and memory bandwidth vs STREAM.

Builds the default slab (100 x 100 mm, 10 mm borehole, grains 3-8 mm, 2 mm
zones, Strathbogie granite) and larger slabs with the same grain and zone
sizes (``--sizes 1 4``: area factors, so 4 is 200 x 200 mm), loads them with
the paper's case-2 far-field stresses (bonds held elastic), and times
``MechanicsSolver.cycle(N)`` after a warm-up call that compiles or loads the
numba kernels.

It prints steps/s, element updates/s and sub-contact updates/s, and an
estimate of the bytes one step moves, counted array by array from what each
kernel reads and writes (see :func:`bytes_per_step`). Gathers and scatters
are counted at 8 bytes per value touched, not per cache line, so the figure is
the traffic a perfectly cached gather would need. The default slab's whole
working set (~1.3 MB; ~5 MB at 200 x 200 mm) fits in L2/L3 cache, so the
"achieved bandwidth" is a cache bandwidth; it is compared with a STREAM
triad (``a[i] = b[i] + s c[i]``, 24 bytes per element, arrays far larger than
cache, one thread like the kernels) measured in the same process.

With ``--compare-src DIR`` (a ``src`` folder of another checkout, e.g. the
commit before a change) the same measurement also runs on that code, in
subprocesses interleaved with runs of this checkout's code, and the two step
rates are printed side by side with their round-by-round ratio (mean and 95 %
interval).

With ``--dim 3`` it times the 3D step instead: synthetic tetrahedral blocks
cut into bonded slab grains (``grainfrac.physics.cuda.synthetic.grain_block``,
quartz and Q-Q contact properties of paper Table 2), pulled at a constant speed,
at ``6 n^3`` tetrahedra for each ``--cubes n``, on 1 and on all numba threads. It
prints tet-steps/s, the bytes one step moves against the STREAM triad on 1 and on
all threads, and the exponent of the step time against the model size.

Usage::

    python benchmarks/mechanics_step.py --steps 2000 --sizes 1 4
    python benchmarks/mechanics_step.py --dim 3 --cubes 12 26 40 56
    python benchmarks/mechanics_step.py --compare-src /path/to/old/src
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
from numba import njit, prange

from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.loading.boundary import Loads, far_field_stress_forces
from grainfrac.loading.insitu import STRESS_CASES
from grainfrac.physics.model import MechanicalModel, build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver

MPA = 1e6
F8, I8, B1 = 8, 8, 1  # bytes of float64, int64, bool
TARGET = 0.5  # fraction of STREAM


@njit(cache=True)
def _triad(a, b, c, s):
    for i in range(a.shape[0]):
        a[i] = b[i] + s * c[i]


@njit(cache=True, parallel=True)
def _triad_parallel(a, b, c, s):
    for i in prange(a.shape[0]):
        a[i] = b[i] + s * c[i]


def stream_triad(n: int, repeats: int, triad=_triad) -> float:
    """Best triad bandwidth (GB/s) over ``repeats`` runs, 24 B per element; one thread
    with the default ``triad``, all numba threads with ``_triad_parallel``."""
    b = np.random.default_rng(0).random(n)
    c = np.random.default_rng(1).random(n)
    a = np.empty(n)
    triad(a[:10], b[:10], c[:10], 3.0)  # compile / load
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        triad(a, b, c, 3.0)
        best = min(best, time.perf_counter() - start)
    return 24.0 * n / best / 1e9


def bytes_per_step(model: MechanicalModel) -> dict[str, int]:
    """Bytes read + written by one step, per kernel (no platens).

    element_forces, per element: cells 3 int64, grad 3 x 2, measure,
    lam, mu (read); u gathered at 3 nodes x 2; force scattered (read + write)
    at 3 nodes x 2; stress 4 (write).
    contact_forces, per sub-contact: contact_nodes 2 int64, frame 4 (normal, tangent),
    contact_area, kn, ks, tan_phi, cohesion, tensile_strength, pressure (read),
    bonded (bool, read), tau (read + write), sigma_n (write); u and v gathered at
    2 nodes x 2; force scattered (read + write) at 2 nodes x 2. status and
    released are only touched when a bond breaks.
    update_nodes, per node: u, v (read + write, 2 each), force, external,
    prescribed_velocity (read, 2 each), mass (read), fixed (2 bools, read);
    plus zeroing force at the start of the step (write, 2).
    """
    m = model.n_elements
    c = model.n_contacts
    n = model.n_nodes
    element = m * (3 * I8 + 6 * F8 + 3 * F8 + 6 * F8 + 2 * 6 * F8 + 4 * F8)
    contact = c * (2 * I8 + 4 * F8 + 7 * F8 + B1 + 2 * F8 + F8 + 4 * F8 + 4 * F8 + 2 * 4 * F8)
    node = n * (2 * 2 * F8 + 2 * 2 * F8 + 3 * 2 * F8 + F8 + 2 * B1) + n * 2 * F8
    return {"element": element, "contact": contact, "node": node,
            "total": element + contact + node}


def working_set(model: MechanicalModel) -> int:
    """Distinct bytes the step touches: every array once (nodes, elements, contacts)."""
    m, c, n = len(model.element_nodes), model.n_contacts, model.n_nodes
    # cells; grad; measure, lam, mu; stress
    per_element = 3 * I8 + 3 * F8 + 3 * F8 + 3 * F8 + 4 * F8
    per_contact = 2 * I8 + 13 * F8 + B1
    per_node = 5 * 2 * F8 + F8 + 2 * B1  # u, v, force, external, prescribed; mass; fixed
    return m * per_element + c * per_contact + n * per_node


def build_slab(area_factor: float, seed: int):
    side = 100.0 * math.sqrt(area_factor)
    cfg = validate(SpecimenConfig, {"seed": seed,
                                    "specimen": {"shape": "slab", "width_mm": side,
                                                 "height_mm": side}})
    return side, build_assembly(cfg, cfg.recipe())


def time_steps(model: MechanicalModel, loads: Loads, steps: int, repeats: int) -> float:
    """Best wall time (s) of ``cycle(steps)`` over ``repeats`` runs, after a warm-up."""
    solver = MechanicsSolver(model, loads)
    solver.allow_failure = False  # the in-situ stage holds bonds elastic
    solver.cycle(10)  # compile or load the cached kernels
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        solver.cycle(steps)
        best = min(best, time.perf_counter() - start)
    if not np.all(np.isfinite(solver.u)):
        raise RuntimeError("non-finite displacements")
    return best


def tet_bytes_per_step(model: MechanicalModel) -> int:
    """Bytes one 3D serial step reads and writes, counted as in :func:`bytes_per_step`.

    Per tetrahedron: cells 4 int64, grad 12, measure, lam, mu (read); u gathered at
    4 nodes x 3; force scattered (read + write) at 4 x 3; stress 6 (write). Per
    sub-contact: nodes 2 int64, frame 9, area, kn, ks, tan_phi, cohesion, strength,
    two softening lengths, pressure, offset (read), bonded, tau 2 (read + write),
    sigma_n, damage, plastic opening (write); u and v at 2 nodes x 3; force 2 x 3
    (read + write). Per node: u, v (read + write), force, external, prescribed
    velocity (read), mass, fixed; zeroing the force.
    """
    m, c, n = model.n_elements, model.n_contacts, model.n_nodes
    element = m * (4 * I8 + 12 * F8 + 3 * F8 + 12 * F8 + 2 * 12 * F8 + 6 * F8)
    contact = c * (2 * I8 + 9 * F8 + 10 * F8 + B1 + 2 * 2 * F8 + 3 * F8 + 12 * F8
                   + 2 * 6 * F8)
    node = n * (2 * 2 * 3 * F8 + 3 * 3 * F8 + F8 + 3 * B1 + 3 * F8)
    return element + contact + node


def main_3d(args) -> int:
    """The 3D benchmark (``--dim 3``)."""
    from grainfrac.physics.cuda.synthetic import grain_block, pull_loads

    threads_all = numba.config.NUMBA_NUM_THREADS
    stream_1 = stream_triad(args.stream_n, repeats=5)
    stream_all = stream_triad(args.stream_n, repeats=5, triad=_triad_parallel)
    print(f"STREAM triad: 1 thread {stream_1:.2f} GB/s, {threads_all} threads "
          f"{stream_all:.2f} GB/s (n = {args.stream_n:.1e})")
    print(f"{'tets':>10}{'contacts':>10}{'threads':>8}{'tet-steps/s':>13}{'ms/step':>9}"
          f"{'GB/s':>7}{'/STREAM':>9}")
    times: dict[int, list[tuple[int, float]]] = {1: [], threads_all: []}
    for n in args.cubes:
        block = grain_block(n, size=n * 1e-3, cuts=max(2, n // 4), softening=True)
        model = block.model
        traffic = tet_bytes_per_step(model)
        for threads in sorted({1, threads_all}):
            solver = MechanicsSolver(model, pull_loads(block, (1e-3, 0.0, 0.0)),
                                     threads=threads)
            solver.cycle(2)  # compile or load the cache
            steps = max(20, int(2e7 / model.n_elements))
            best = math.inf
            for _ in range(args.repeats):
                start = time.perf_counter()
                solver.cycle(steps)
                best = min(best, (time.perf_counter() - start) / steps)
            stream = stream_1 if threads == 1 else stream_all
            bandwidth = traffic / best / 1e9
            times[threads].append((model.n_elements, best))
            print(f"{model.n_elements:>10}{model.n_contacts:>10}{threads:>8}"
                  f"{model.n_elements / best:>13.3e}{best * 1e3:>9.3f}{bandwidth:>7.1f}"
                  f"{bandwidth / stream:>8.0%}")
    for threads, rows in times.items():
        if len(rows) >= 2:
            size, seconds = np.log([r[0] for r in rows]), np.log([r[1] for r in rows])
            exponent = np.polyfit(size, seconds, 1)[0]
            print(f"step time ~ size^{exponent:.2f} on {threads} thread(s)")
    if threads_all > 1:
        speedup = [t1 / ta for (_, t1), (_, ta) in zip(times[1], times[threads_all],
                                                       strict=True)]
        print("speed-up of all threads over 1: "
              + ", ".join(f"{m:.1e} tets {x:.2f} x" for (m, _), x in zip(times[1], speedup,
                                                                           strict=True)))
    return 0


def step_rates(sizes: list[float], steps: int, repeats: int, seed: int) -> list[float]:
    """Steps per second of the default-slab benchmark at each size (case-2 loads)."""
    sx, sy, _ = STRESS_CASES["case2"]
    rates = []
    for factor in sizes:
        _, assembly = build_slab(factor, seed)
        model = build_mechanical_model(assembly)
        loads = Loads.free(model.n_nodes)
        loads.external += far_field_stress_forces(assembly.mesh, sx * MPA, sy * MPA)
        rates.append(steps / time_steps(model, loads, steps, repeats))
    return rates


def compare(src: Path, sizes: list[float], steps: int, repeats: int, seed: int,
            rounds: int = 3) -> None:
    """Step rates of this code and of the code under ``src``, interleaved subprocesses.

    Prints the best rate of each and the ratio of the bests, and the ratio round by
    round (each round runs both codes back to back, so a slow spell of the machine
    hits both): its mean and 95 % t-interval say whether a difference exceeds the
    machine's own spread. Running it with ``src`` = this checkout's ``src`` measures that
    spread.
    """
    from scipy import stats

    here = Path(__file__).resolve()
    this_src = here.parents[1] / "src"
    runs: dict[str, list[list[float]]] = {"this": [], "other": []}
    for _ in range(rounds):
        for label, path in (("this", this_src), ("other", src)):
            env = {**os.environ, "PYTHONPATH": str(path)}
            out = subprocess.run(
                [sys.executable, str(here), "--rates-only", "--steps", str(steps),
                 "--repeats", str(repeats), "--seed", str(seed), "--sizes",
                 *map(str, sizes)], env=env, check=True, capture_output=True, text=True)
            runs[label].append(json.loads(out.stdout.strip().splitlines()[-1]))
    this, other = np.array(runs["this"]), np.array(runs["other"])
    paired = this / other  # (rounds, sizes)
    print(f"\nstep rate, this code ({this_src}) vs {src}; {rounds} interleaved rounds of "
          f"subprocesses x best of {repeats} calls of {steps} steps")
    print(f"{'slab':>8}{'this steps/s':>14}{'other steps/s':>15}{'ratio':>8}"
          f"{'paired ratio, mean [95 % CI]':>32}  per round")
    for k, factor in enumerate(sizes):
        a, b, r = this[:, k].max(), other[:, k].max(), paired[:, k]
        if rounds > 1:
            half = stats.t.ppf(0.975, rounds - 1) * r.std(ddof=1) / math.sqrt(rounds)
            interval = f"{r.mean():.3f} [{r.mean() - half:.3f}, {r.mean() + half:.3f}]"
        else:
            interval = f"{r.mean():.3f}"
        print(f"{f'x{factor:g}':>8}{a:>14.0f}{b:>15.0f}{a / b:>8.3f}{interval:>32}  "
              + " ".join(f"{x:.3f}" for x in r))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="steps per timed call")
    parser.add_argument("--sizes", type=float, nargs="+", default=[1.0, 4.0],
                        help="slab area factors (1 = default 100 x 100 mm)")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per size (best)")
    parser.add_argument("--stream-n", type=int, default=20_000_000,
                        help="STREAM triad array length (float64)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--compare-src", type=Path, default=None,
                        help="also time the code under this src folder (e.g. an old checkout)")
    parser.add_argument("--rounds", type=int, default=5,
                        help="interleaved subprocess pairs of --compare-src")
    parser.add_argument("--rates-only", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=2,
                        help="2: the default slab's step; 3: synthetic tetrahedral blocks")
    parser.add_argument("--cubes", type=int, nargs="+", default=[12, 26, 40, 56],
                        help="3D block sizes: 6 n^3 tetrahedra each")
    args = parser.parse_args(argv)
    if args.steps < 1 or args.repeats < 1 or any(s <= 0 for s in args.sizes):
        parser.error("--steps, --repeats and --sizes must be positive")
    if args.dim == 3:
        return main_3d(args)
    if args.rates_only:
        print(json.dumps(step_rates(args.sizes, args.steps, args.repeats, args.seed)))
        return 0
    if args.compare_src is not None and not (args.compare_src / "grainfrac").is_dir():
        parser.error(f"--compare-src {args.compare_src}: no grainfrac package there")

    stream = stream_triad(args.stream_n, repeats=5)
    print(f"STREAM triad (numba, 1 thread, n = {args.stream_n:.1e}, "
          f"{3 * 8 * args.stream_n / 1e6:.0f} MB, best of 5): {stream:.2f} GB/s")

    sx, sy, _ = STRESS_CASES["case2"]
    header = (f"{'slab':>11}{'nodes':>8}{'elements':>10}{'contacts':>10}{'WS MB':>7}{'MB/step':>9}"
              f"{'steps/s':>10}{'elem/s':>10}{'cont/s':>10}{'GB/s':>7}{'/STREAM':>9}")
    rows = []
    for factor in args.sizes:
        start = time.perf_counter()
        side, assembly = build_slab(factor, args.seed)
        model = build_mechanical_model(assembly)
        build_s = time.perf_counter() - start
        loads = Loads.free(model.n_nodes)
        loads.external += far_field_stress_forces(assembly.mesh, sx * MPA, sy * MPA)
        wall = time_steps(model, loads, args.steps, args.repeats)
        traffic = bytes_per_step(model)
        rate = args.steps / wall
        bandwidth = traffic["total"] * rate / 1e9
        rows.append((side, model, traffic, rate, bandwidth, build_s, wall))

    print(f"\n{args.steps} steps per call, best of {args.repeats}; case-2 far-field stresses "
          f"({sx:g}, {sy:g} MPa), bonds elastic")
    print(header)
    for side, model, traffic, rate, bandwidth, _, _ in rows:
        m, c = len(model.element_nodes), model.n_contacts
        print(f"{f'{side:g} mm':>11}{model.n_nodes:>8}{m:>10}{c:>10}"
              f"{working_set(model) / 1e6:>7.2f}"
              f"{traffic['total'] / 1e6:>9.3f}{rate:>10.0f}{m * rate:>10.2e}{c * rate:>10.2e}"
              f"{bandwidth:>7.1f}{bandwidth / stream:>8.0%} ")
    print("\nbytes per step by kernel (MB): "
          + "; ".join(f"{side:g} mm: element {t['element'] / 1e6:.3f}, contact "
                      f"{t['contact'] / 1e6:.3f}, node {t['node'] / 1e6:.3f}"
                      for side, _, t, *_ in rows))
    print("build + model (s): " + ", ".join(f"{side:g} mm {b:.2f}" for side, *_, b, _ in rows))
    print("timed call (s): " + ", ".join(f"{side:g} mm {w:.3f}" for side, *_, w in rows))
    print("\nnote: WS is the step's working set; a few MB fit in a server's L2/L3 cache, so "
          "the ratio then compares cache-resident kernels with DRAM STREAM (flattering "
          "the kernels); gathers/scatters are counted per value, not per cache line.")
    ok = all(bw / stream >= TARGET for *_, bw, _, _ in rows)
    print(f"target >= {TARGET:.0%} of STREAM: {'met' if ok else 'NOT met'} "
          f"({', '.join(f'{bw / stream:.0%}' for *_, bw, _, _ in rows)})")
    if args.compare_src is not None:
        compare(args.compare_src, args.sizes, args.steps, args.repeats, args.seed,
                rounds=args.rounds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
