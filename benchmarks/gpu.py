"""Benchmark: the full explicit mechanical step on a GPU (numba-cuda) against the CPU.

Synthetic 3D blocks (:mod:`grainfrac.physics.cuda.synthetic`: ``6 n^3`` linear
tetrahedra of 1 mm cubes, cut by 4 planes into 5 slab grains joined by bonded
quartz-quartz sub-contacts, paper Table 2 properties) are held at one face and
pulled and sheared at the other. For each size it prints the build time, the
host-to-device copy, the first call (kernel compile, first size only), tet-steps
per second of :meth:`CudaMechanics.advance` (elements + contacts + node update +
damping + energy books + crack list, all on the device; the host reads back an
eight-byte control word at the end), the time split by stage (each
stage timed alone, with a device synchronisation after it), and the
device-to-host copy of what a cycle changes, into pageable host memory and into the
pinned memory of a GPU-backend solver, for each way of summing nodal forces
(``--sums``: ordered, the CPU's order and reproducible; atomic, float64 atomics).
Then the same step on the CPU backend
(``MechanicsSolver.cycle``, numba, one thread: the CPU kernels are serial) at a
smaller size, and the GPU/CPU ratio.

Usage (from the repository root)::

    PYTHONPATH=src python3 benchmarks/gpu.py            # ~1e5 .. 1e7 tets, < 5 min
    PYTHONPATH=src python3 benchmarks/gpu.py --quick    # 1e5 and 1e6 tets, ~1 min
    PYTHONPATH=src python3 benchmarks/gpu.py --sim-smoke  # CPU only: numba's simulator
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import importlib.metadata
import os
import platform
import sys
import time

SMOKE = "--sim-smoke" in sys.argv
if SMOKE:  # must be set before numba is imported
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

import numba  # noqa: E402
import numpy as np  # noqa: E402

from grainfrac.physics.cuda import CudaMechanics, device_name  # noqa: E402
from grainfrac.physics.cuda._numba import cuda  # noqa: E402
from grainfrac.physics.cuda.synthetic import grain_block, pull_loads  # noqa: E402
from grainfrac.physics.solver import MechanicsSolver  # noqa: E402

CELL = 1e-3  # m, edge of a sub-cube
PULL = (0.5, 0.15, 0.0)  # m/s, the moving face's velocity
TARGET = 3e9  # tet-steps/s at >= 1e6 tets (issue 44)
BUDGET = 270.0  # s: skip a size whose set-up would not fit


def say(*parts) -> None:
    print(*parts, flush=True)


def build(n: int):
    return grain_block(n, size=n * CELL, cuts=4)


def versions() -> str:
    out = []
    for dist in ("numba", "numba-cuda", "numpy", "cuda-python", "cuda-bindings"):
        with contextlib.suppress(importlib.metadata.PackageNotFoundError):
            out.append(f"{dist} {importlib.metadata.version(dist)}")
    return ", ".join(out)


def time_gpu(n: int, block, t_build: float, steps: int, first: bool, ordered: bool) -> dict:
    """Time ``block`` (built in ``t_build`` s) on the GPU from a fresh state."""
    model = block.model
    solver = MechanicsSolver(model, pull_loads(block, PULL))
    cuda.synchronize()
    t0 = time.perf_counter()
    gpu = CudaMechanics(solver, ordered=ordered)
    cuda.synchronize()
    t_push = time.perf_counter() - t0
    t0 = time.perf_counter()
    gpu.advance(2)  # compiles on the first size
    cuda.synchronize()
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    gpu.advance(steps)
    cuda.synchronize()
    t_run = time.perf_counter() - t0
    # The split: the same stages, timed one by one.
    split: dict[str, float] = {}
    split_steps = max(steps // 4, 2)
    gpu.advance(split_steps, timings=split)
    t0 = time.perf_counter()
    gpu.pull()
    t_pull = time.perf_counter() - t0
    # The same pull into a GPU-backend solver's arrays, which are pinned host memory.
    pageable, gpu.solver = solver, MechanicsSolver(model, pull_loads(block, PULL),
                                                   backend="cuda")
    t0 = time.perf_counter()
    gpu.pull()
    t_pull_pinned = time.perf_counter() - t0
    gpu.solver = pageable
    m = model.n_elements
    return {
        "n": n, "tets": m, "nodes": model.n_nodes, "contacts": model.n_contacts,
        "steps": steps, "build_s": t_build, "push_s": t_push, "first_call_s": t_first,
        "run_s": t_run, "rate": m * steps / t_run,
        "split_ms": {k: 1e3 * v / split_steps for k, v in split.items()},
        "pull_s": t_pull, "pull_pinned_s": t_pull_pinned,
        "cracks": len(solver.cracks.contact), "first": first,
        "sums": "ordered" if ordered else "atomic",
    }


def time_cpu(n: int, steps: int, threads: int) -> dict:
    """The CPU backend's step rate on ``threads`` numba threads (1: the serial kernels)."""
    block = build(n)
    solver = MechanicsSolver(block.model, pull_loads(block, PULL), threads=threads)
    t0 = time.perf_counter()
    solver.cycle(2)  # compiles (or loads the cache)
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    solver.cycle(steps)
    t_run = time.perf_counter() - t0
    m = block.model.n_elements
    return {"n": n, "tets": m, "steps": steps, "first_call_s": t_first, "run_s": t_run,
            "rate": m * steps / t_run, "threads": threads}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="1e5 and 1e6 tets (~1 min)")
    parser.add_argument("--sim-smoke", action="store_true",
                        help="tiny sizes in numba's CUDA simulator (no GPU needed)")
    parser.add_argument("--sizes", type=int, nargs="*",
                        help="cube edges n (6 n^3 tets); default 26 56 80 119")
    parser.add_argument("--cpu-n", type=int, help="cube edge of the CPU run (default 26)")
    parser.add_argument("--sums", nargs="+", choices=("ordered", "atomic"),
                        default=["ordered", "atomic"], help="how the GPU sums nodal forces")
    args = parser.parse_args()
    start = time.perf_counter()
    if args.sim_smoke:
        sizes, cpu_n, steps_for = args.sizes or [2], args.cpu_n or 2, (lambda m: 3)
    elif args.quick:
        sizes, cpu_n = args.sizes or [26, 56], args.cpu_n or 26
        steps_for = lambda m: int(np.clip(3e9 / m, 50, 2000))  # noqa: E731
    else:
        sizes, cpu_n = args.sizes or [26, 56, 80, 119], args.cpu_n or 26
        steps_for = lambda m: int(np.clip(1e10 / m, 100, 4000))  # noqa: E731
    say(f"# grainfrac GPU benchmark, {datetime.datetime.now().isoformat(timespec='seconds')}")
    say(f"device: {device_name()}")
    say(f"python {platform.python_version()}, {versions()}, host {platform.node()} "
        f"({os.cpu_count()} CPU cores)")
    results = []
    per_tet_build = None
    for i, n in enumerate(sizes):
        m = 6 * n**3
        elapsed = time.perf_counter() - start
        if per_tet_build is not None and elapsed + 1.5 * per_tet_build * m > BUDGET:
            say(f"skipping n = {n} ({m:.2e} tets): its set-up (~{per_tet_build * m:.0f} s) "
                f"would pass the {BUDGET:.0f} s budget")
            continue
        t0 = time.perf_counter()
        block = build(n)  # once for both ways of summing
        t_build = time.perf_counter() - t0
        for j, sums in enumerate(args.sums):
            r = time_gpu(n, block, t_build, steps_for(m), first=i == 0,
                         ordered=sums == "ordered")
            per_tet_build = max(per_tet_build or 0.0, r["build_s"] / r["tets"])
            results.append(r)
            split = ", ".join(f"{k} {v:.3f}" for k, v in r["split_ms"].items())
            say(f"n={n:4d} tets {r['tets']:.3e} nodes {r['nodes']:.2e} contacts "
                f"{r['contacts']:.2e}, {sums} sums | build {r['build_s']:.1f} s, host->device "
                f"{r['push_s']:.3f} s, first call {r['first_call_s']:.2f} s"
                f"{' (compile)' if r['first'] and j == 0 else ''}")
            say(f"        {r['steps']} steps in {r['run_s']:.3f} s: {r['rate']:.3e} "
                f"tet-steps/s, {1e3 * r['run_s'] / r['steps']:.4f} ms/step, "
                f"{r['cracks']} cracks so far")
            say(f"        split (ms/step, synchronised): {split}; device->host (a cycle's "
                f"changes) {r['pull_s']:.3f} s into pageable, {r['pull_pinned_s']:.3f} s "
                f"into pinned host memory")
    cpu_steps = (steps_for(6 * cpu_n**3) if args.sim_smoke else
                 int(np.clip(2e7 / (6 * cpu_n**3), 20, 400)))
    for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
        cpu = time_cpu(cpu_n, cpu_steps, threads)
        say(f"CPU backend (numba, {threads} thread{'s' if threads > 1 else ''}), n={cpu_n}, "
            f"tets {cpu['tets']:.3e}: {cpu['steps']} steps in {cpu['run_s']:.3f} s: "
            f"{cpu['rate']:.3e} tet-steps/s (first call {cpu['first_call_s']:.2f} s)")
    # The ratios below are against the last line: all the machine's threads.
    for sums in args.sums:
        mine = [r for r in results if r["sums"] == sums]
        same = [r for r in mine if r["n"] == cpu_n]
        if same:
            say(f"GPU/CPU at the same size ({same[0]['tets']:.2e} tets), {sums} sums: "
                f"{same[0]['rate'] / cpu['rate']:.1f} x")
        if mine:
            best = max(mine, key=lambda r: r["rate"])
            say(f"GPU/CPU, best GPU size ({best['tets']:.2e} tets), {sums} sums, over the CPU "
                f"rate: {best['rate'] / cpu['rate']:.1f} x")
            big = [r for r in mine if r["tets"] >= 1e6]
            if big and not args.sim_smoke:
                ok = max(r["rate"] for r in big) >= TARGET
                say(f"target >= {TARGET:.0e} tet-steps/s at >= 1e6 tets, {sums} sums: "
                    f"{'met' if ok else 'NOT met'}")
    say(f"total {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
