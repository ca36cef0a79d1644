"""Benchmark: whole 3D scenario runs on the CUDA backend, against the CPU backend.

Two measurements, each a plain ``run_scenario`` into a run directory:

``same-answers``
    A small 3D hybrid slab (``tests/data/hybrid3d-small.toml``: 26 x 26 x 6 mm, SCDA
    to 3 MPa, drill-out, injection past breakdown; about 23,000 explicit steps) on
    the CPU backend and on the CUDA backend, once for each way the GPU sums nodal
    forces (``--sums``: ordered, the CPU's order; atomic). Prints the crack catalogues
    compared as sets of (contact, mode), whether the order is the same, and the
    largest relative difference of the history's well pressures.

``cube``
    ``examples/3d/hybrid-case3-cube.toml`` (the paper's 100 mm cube, Case 3, SCDA
    then 90 ml/min injection) on the CUDA backend, with the wall time split into
    set-up (assembly and model), GPU mechanics (the explicit steps on the device),
    host-device copies, the pressure solve (``flow.implicit_step``, CPU) and the
    rest on the host (coupling, histories, snapshots, checkpoints, figures). Then the
    CPU backend's time per explicit step of the same model, on all the machine's
    cores, and the estimated CPU time of the whole run: its steps at that rate plus
    the host parts measured on the GPU run (which the CPU run does too). With
    ``--limit-s`` the run is stopped (SIGTERM: a checkpoint, as a user's Ctrl-C) and
    the split covers the part it ran.

The host's parallel work, the 3D mesher's pieces above all, runs on every core
(``--threads``, default all; the mesh and the results are the same on any number).

Usage (from the repository root, on a machine with an NVIDIA GPU)::

    PYTHONPATH=src python3 benchmarks/gpu_runs.py same-answers cube --out /tmp/gpu-runs
    PYTHONPATH=src python3 benchmarks/gpu_runs.py cube --backend cpu --limit-s 60  # no GPU
"""

from __future__ import annotations

import argparse
import cProfile
import csv
import datetime
import json
import os
import pstats
import signal
import sys
import threading
import time
import tomllib
from contextlib import contextmanager
from pathlib import Path

import numba
import numpy as np

import grainfrac.run as run_module
from grainfrac.io.config import validate
from grainfrac.physics import flow
from grainfrac.physics.cuda.mechanics import SUMS_VARIABLE
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import BACKEND_VARIABLE, MechanicsSolver
from grainfrac.run import RunInterrupted
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario
from grainfrac.threads import THREADS_VARIABLE, default_threads

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _clock import Clock  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CUBE = ROOT / "examples" / "3d" / "hybrid-case3-cube.toml"
SMALL_HYBRID = ROOT / "tests" / "data" / "hybrid3d-small.toml"


def say(*parts) -> None:
    print(*parts, flush=True)


@contextmanager
def backend(name: str):
    os.environ[BACKEND_VARIABLE] = name
    try:
        yield
    finally:
        os.environ.pop(BACKEND_VARIABLE, None)


def history(out: Path) -> list[dict[str, str]]:
    with open(out / "history.csv", newline="") as f:
        return list(csv.DictReader(f))


def cracks(out: Path) -> list[tuple[int, str]]:
    with open(out / "cracks.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return [(int(r["contact"]), r["mode"]) for r in rows]


def _run_small_hybrid(out: Path, name: str, label: str) -> dict:
    """The small hybrid scenario on backend ``name`` into ``out / label``."""
    scenario = validate(Scenario, tomllib.loads(SMALL_HYBRID.read_text()))
    start = time.perf_counter()
    with backend(name):
        summary = run_scenario(scenario, scenario.recipe(), out / label, overwrite=True)
    run = {"wall_s": time.perf_counter() - start, "summary": summary,
           "cracks": cracks(out / label), "history": history(out / label)}
    say(f"same-answers: {label} run {run['wall_s']:.1f} s, {summary['n_cracks']} cracks, "
        f"breakdown {summary['breakdown_pressure_MPa']} MPa")
    return run


def same_answers(out: Path, sums: list[str]) -> dict:
    """The CPU run once, then the CUDA run with each way of summing, compared with it."""
    cpu = _run_small_hybrid(out, "cpu", "cpu")
    reports = {}
    for way in sums:
        os.environ[SUMS_VARIABLE] = way
        gpu = _run_small_hybrid(out, "cuda", f"cuda-{way}")
        p_cpu = np.array([float(r["well_pressure_MPa"]) for r in cpu["history"]])
        p_gpu = np.array([float(r["well_pressure_MPa"]) for r in gpu["history"]])
        n = min(len(p_cpu), len(p_gpu))
        scale = max(float(np.max(np.abs(p_cpu))), 1e-300)
        reports[way] = {
            "steps": int(cpu["history"][-1]["step"]),
            "cracks_cpu": len(cpu["cracks"]), "cracks_cuda": len(gpu["cracks"]),
            "same_crack_set": sorted(cpu["cracks"]) == sorted(gpu["cracks"]),
            "same_crack_order": cpu["cracks"] == gpu["cracks"],
            "cracks_only_cpu": len(set(cpu["cracks"]) - set(gpu["cracks"])),
            "cracks_only_cuda": len(set(gpu["cracks"]) - set(cpu["cracks"])),
            "history_rows": [len(p_cpu), len(p_gpu)],
            "well_pressure_max_rel": float(np.max(np.abs(p_cpu[:n] - p_gpu[:n])) / scale),
            "breakdown_MPa": [cpu["summary"]["breakdown_pressure_MPa"],
                              gpu["summary"]["breakdown_pressure_MPa"]],
            "wall_s": [cpu["wall_s"], gpu["wall_s"]],
        }
        say(f"same-answers, {way} sums: " + json.dumps(reports[way]))
    os.environ.pop(SUMS_VARIABLE, None)  # later runs take the default
    return reports


def cpu_step_time(assembly, scenario: Scenario, steps: int) -> tuple[float, int]:
    """Seconds per explicit step of the CPU backend on all numba threads, and the threads."""
    model = build_mechanical_model(assembly, mass_scaling=scenario.numerics.mass_scaling)
    solver = MechanicsSolver(model, threads=numba.config.NUMBA_NUM_THREADS)
    solver.cycle(2)  # compiles
    start = time.perf_counter()
    solver.cycle(steps)
    return (time.perf_counter() - start) / steps, solver.threads


def cube(out: Path, name: str, limit_s: float | None, cpu_steps: int,
         profile: bool = False) -> dict:
    scenario = validate(Scenario, tomllib.loads(CUBE.read_text()))
    start = time.perf_counter()
    assembly = run_module.build_assembly(scenario.specimen_config(), scenario.recipe())
    built_s = time.perf_counter() - start
    say(f"cube: assembly {assembly.mesh.n_elements:.3e} tets, "
        f"{assembly.mesh.n_contacts} contacts, built in {built_s:.1f} s")
    clock = Clock()
    build_assembly = run_module.build_assembly
    run_module.build_assembly = lambda *args, **kwargs: assembly  # built above
    clock.wrap(run_module, "build_mechanical_model", "set-up")
    clock.wrap(flow, "implicit_step", "pressure solve")
    if name == "cuda":
        from grainfrac.physics.cuda.mechanics import CudaMechanics

        clock.wrap(CudaMechanics, "advance", "GPU mechanics")
        for method in ("push", "push_inputs", "pull"):
            clock.wrap(CudaMechanics, method, "host-device copies")
    else:
        clock.wrap(MechanicsSolver, "cycle", "CPU mechanics")
    timer = None
    if limit_s:
        timer = threading.Timer(limit_s, lambda: os.kill(os.getpid(), signal.SIGTERM))
        timer.start()
    start = time.perf_counter()
    stopped = None
    profiler = cProfile.Profile() if profile else None
    try:
        with backend(name):
            if profiler is not None:
                profiler.enable()
            summary = run_scenario(scenario, scenario.recipe(), out / f"cube-{name}",
                                   overwrite=True, log_every_s=30.0)
    except RunInterrupted as exc:
        summary, stopped = None, str(exc)
    finally:
        if profiler is not None:
            profiler.disable()
        if timer is not None:
            timer.cancel()
        clock.restore()
        run_module.build_assembly = build_assembly
    if profiler is not None:
        profiler.dump_stats(out / f"cube-{name}.prof")
        stats = pstats.Stats(profiler, stream=sys.stdout)
        stats.sort_stats("tottime").print_stats(25)
        stats.sort_stats("cumulative").print_stats("grainfrac", 45)
    total = time.perf_counter() - start + built_s
    rows = history(out / f"cube-{name}")
    steps = int(rows[-1]["step"]) if rows else 0
    # One history row per fluid step of an inject stage (max_time_step_ms grows them).
    fluid_steps = sum(r["stage"] == "inject" for r in rows)
    split = dict(clock.seconds)
    split["set-up"] = split.get("set-up", 0.0) + built_s
    # The timed calls do not nest; the rest is the host's work between them.
    rest = total - sum(split.values())
    split["host: coupling, histories, snapshots, checkpoints, figures"] = rest
    report = {
        "backend": name, "tets": int(assembly.mesh.n_elements),
        "contacts": int(assembly.mesh.n_contacts), "steps": steps, "fluid_steps": fluid_steps,
        "total_s": total,
        "split_s": split, "stopped": stopped, "last_stage": rows[-1]["stage"] if rows else None,
        "last_time_ms": 1e3 * float(rows[-1]["time_s"]) if rows else None,
        "breakdown_MPa": summary["breakdown_pressure_MPa"] if summary else None,
        "peak_expansive_MPa": summary["peak_expansive_pressure_MPa"] if summary else None,
        "n_cracks": summary["n_cracks"] if summary else None,
    }
    mechanics = split.get("GPU mechanics", split.get("CPU mechanics", 0.0))
    say(f"cube ({name}): {report['tets']:.3e} tets, {steps} steps in {total:.1f} s "
        f"({'stopped: ' + stopped if stopped else 'finished'}); last stage "
        f"{report['last_stage']}")
    for label, seconds in sorted(split.items(), key=lambda kv: -kv[1]):
        say(f"    {label:<58s} {seconds:8.1f} s  {100 * seconds / total:5.1f} %")
    if steps:
        say(f"    mechanics per step {1e3 * mechanics / steps:.3f} ms, "
            f"{report['tets'] * steps / max(mechanics, 1e-9):.3e} tet-steps/s")
    solve = split.get("pressure solve", 0.0)
    if fluid_steps:
        say(f"    {fluid_steps} fluid steps, {1e3 * solve / fluid_steps:.1f} ms of pressure "
            f"solve each")
    say(f"    pressure solve / time after set-up: "
        f"{solve / max(total - split['set-up'], 1e-9):.3f}")
    # The CPU's step is timed after the run and its report: on a fresh machine its
    # first cycle compiles the CPU kernels (33 s on this project's 2-core machine),
    # which before the run could push a run stopped at --limit-s past the device
    # command's own time limit, losing the whole report.
    say("cube: " + json.dumps(report))
    cpu = cpu_step_time(assembly, scenario, cpu_steps) if cpu_steps else None
    if cpu:
        say(f"cube: CPU backend ({cpu[1]} threads) {1e3 * cpu[0]:.2f} ms/step "
            f"({cpu_steps} steps timed)")
    if cpu and steps:
        per_step, threads = cpu
        host = total - mechanics - split.get("host-device copies", 0.0)
        estimate = steps * per_step + host
        report.update(cpu_s_per_step=per_step, cpu_threads=threads, cpu_estimate_s=estimate,
                      ratio=estimate / total)
        say(f"    this run on the CPU ({threads} threads) ~{estimate:.0f} s: {steps} steps x "
            f"{per_step:.4f} s + {host:.0f} s on the host as measured here; CPU/GPU "
            f"{estimate / total:.1f} x")
    say("cube: " + json.dumps(report))
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", nargs="+", choices=["same-answers", "cube"])
    parser.add_argument("--out", type=Path, default=Path("gpu-runs"))
    parser.add_argument("--backend", default="cuda", choices=["cpu", "cuda"],
                        help="backend of the cube run (default cuda)")
    parser.add_argument("--limit-s", type=float, help="stop the cube run after this long")
    parser.add_argument("--cpu-steps", type=int, default=20,
                        help="explicit steps of the cube model timed on the CPU (0: none)")
    parser.add_argument("--sums", nargs="+", choices=("ordered", "atomic"),
                        default=["ordered", "atomic"],
                        help="how the GPU sums nodal forces in same-answers (both by default)")
    parser.add_argument("--threads", default="all",
                        help="CPU threads of the host's parallel work, the 3D mesher's "
                             "pieces above all ($GRAINFRAC_THREADS; default all: the same "
                             "mesh and results on any number)")
    parser.add_argument("--profile", action="store_true",
                        help="profile the cube run (cProfile): cube-BACKEND.prof in --out, "
                             "and the top functions printed")
    args = parser.parse_args()
    os.environ[THREADS_VARIABLE] = args.threads
    say(f"# grainfrac whole-run GPU benchmark, "
        f"{datetime.datetime.now().isoformat(timespec='seconds')}, "
        f"{os.cpu_count()} CPU cores, numba threads {numba.config.NUMBA_NUM_THREADS}, "
        f"grainfrac threads {default_threads()}")
    if args.backend == "cuda" or "same-answers" in args.what:
        from grainfrac.physics.cuda import device_name

        say(f"device: {device_name()}")
    args.out.mkdir(parents=True, exist_ok=True)
    results = {}
    if "same-answers" in args.what:
        results["same_answers"] = same_answers(args.out, args.sums)
    if "cube" in args.what:
        results["cube"] = cube(args.out, args.backend, args.limit_s, args.cpu_steps,
                               args.profile)
    (args.out / "gpu_runs.json").write_text(json.dumps(results, indent=1, default=str))


if __name__ == "__main__":
    sys.exit(main())
