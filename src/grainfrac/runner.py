"""Running scenarios for the command line: progress display and the demo pair.

Kept apart from ``simulation`` (which knows nothing of terminals) and from
``cli`` (which only parses arguments and maps errors to exit codes).
"""

from __future__ import annotations

import multiprocessing as mp
import queue
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from grainfrac.run import Progress as RunProgress
from grainfrac.scenario import Scenario, hs_only, hybrid, load_scenario, resolved_dict
from grainfrac.simulation import run_scenario

DEMO_RUNS = ("hs-only", "hybrid")


def _columns():
    return (
        TextColumn("[bold]{task.fields[name]:<8}[/]"),
        BarColumn(bar_width=12),
        TextColumn("{task.fields[stage]:<13} {task.fields[time_ms]:6.2f} ms"),
        TextColumn("{task.fields[stage_time]}"),
        TextColumn("{task.fields[cracks]:4d} cracks"),
        TextColumn("{task.fields[pressure]}"),
        TimeElapsedColumn(),
        TextColumn("ETA {task.fields[eta]}"),
    )


def _fields(p: RunProgress) -> dict[str, Any]:
    if p.stage_kind == "scda":
        pressure = f"SCDA {p.expansive_pressure_Pa / 1e6:5.1f} MPa"
    else:
        pressure = f"well {p.well_pressure_Pa / 1e6:5.2f} MPa"
    if p.stage_planned_s:
        # The stage's simulated time against its planned duration.
        stage_time = f"stage {p.stage_time_s * 1e3:.3f}/{p.stage_planned_s * 1e3:.3f} ms"
    else:
        stage_time = f"stage {100 * p.stage_fraction:3.0f} % of max_steps"
    eta = "-" if p.eta_s is None else f"{p.eta_s:.0f} s"
    return {"stage": f"{p.stage_index + 1}/{p.n_stages} {p.stage_kind}",
            "time_ms": p.time_s * 1e3, "cracks": p.n_cracks, "pressure": pressure,
            "completed": p.stage_index + p.stage_fraction, "stage_time": stage_time,
            "eta": eta}


def run_with_progress(scenario_path: Path | None, out: Path, *, seed: int | None = None,
                      resume: bool = False, overwrite: bool = False,
                      console: Console | None = None) -> dict[str, Any]:
    """``grainfrac run``: one scenario with a live progress bar.

    With ``resume`` and no scenario file the run directory's own ``config.toml``
    is the scenario; with one (or a ``seed``) they must be the run's, which
    :func:`grainfrac.run.run_directory` checks against its fingerprint.
    """
    from grainfrac.io.config import read_toml, validate
    from grainfrac.run import RunDirectoryError

    if resume and scenario_path is None:
        # The run directory holds the resolved scenario: resume needs nothing else.
        config = out / "config.toml"
        if not config.is_file():
            raise RunDirectoryError(f"--resume: {out} holds no run to continue "
                                    f"({config} does not exist)")
        scenario = validate(Scenario, read_toml(config))
        recipe = scenario.recipe(out)
        base_dir = out
    else:
        scenario, recipe = load_scenario(scenario_path)
        base_dir = scenario_path.parent
    if seed is not None:
        scenario = scenario.with_seed(seed)
    # Off a terminal (nohup, a batch job) the bar shows nothing until the end: the
    # run log's lines go to stderr as well. GRAINFRAC_LOG_EVERY_S sets their interval.
    import logging
    import os
    import sys

    every = float(os.environ.get("GRAINFRAC_LOG_EVERY_S", "0") or 0) or None
    stream = None
    if not sys.stderr.isatty():
        stream = logging.StreamHandler(sys.stderr)
        stream.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        stream.setLevel(logging.INFO)
        logging.getLogger("grainfrac").addHandler(stream)
    # The bar starts with the first chunk, so that a refused run directory or a
    # bad input is one line on its own.
    bar = Progress(*_columns(), console=console, transient=False)
    task = bar.add_task("run", total=len(scenario.stages), name=scenario.name,
                        stage="", time_ms=0.0, cracks=0, pressure="", stage_time="", eta="-")

    def show(p: RunProgress) -> None:
        if not bar.live.is_started:
            bar.start()
        bar.update(task, **_fields(p))

    try:
        return run_scenario(scenario, recipe, out, base_dir=base_dir, resume=resume,
                            overwrite=overwrite, progress=show, log_every_s=every)
    finally:
        bar.stop()
        if stream is not None:
            logging.getLogger("grainfrac").removeHandler(stream)


def _demo_worker(name: str, scenario_dict: dict, out: str, events,
                 overwrite: bool = False) -> dict[str, Any]:
    from grainfrac.io.config import validate

    scenario = validate(Scenario, scenario_dict)

    def report(p: RunProgress) -> None:
        events.put((name, _fields(p)))

    return run_scenario(scenario, scenario.recipe(), Path(out) / name, overwrite=overwrite,
                        progress=report)


def demo_scenarios(seed: int = 0) -> dict[str, Scenario]:
    """The headline comparison: HS-only vs hybrid, default slab, Case 2, 90 ml/min."""
    return {"hs-only": hs_only(seed=seed), "hybrid": hybrid(seed=seed)}


def run_demo(out: Path, *, seed: int = 0, console: Console | None = None,
             workers: int | None = None, overwrite: bool = False) -> dict[str, dict[str, Any]]:
    """Run both demo scenarios (in parallel where there are two cores) into ``out``.

    ``out/hs-only`` and ``out/hybrid`` are run directories: each must be new or
    empty unless ``overwrite`` (checked here first, so that neither run starts
    when one of them would be refused).
    """
    from grainfrac.run import RunDirectoryError

    scenarios = demo_scenarios(seed)
    if not overwrite:
        for name in scenarios:
            run_dir = Path(out) / name
            if run_dir.is_dir() and any(p.name != "run.lock" for p in run_dir.iterdir()):
                raise RunDirectoryError(f"--out {run_dir} is not empty; clear it with "
                                        "--overwrite or use another --out")
    workers = workers or min(len(scenarios), max(1, mp.cpu_count()))
    payload = {name: resolved_dict(sc, sc.recipe()) for name, sc in scenarios.items()}
    results: dict[str, dict[str, Any]] = {}
    with mp.Manager() as manager, Progress(*_columns(), console=console) as bar:
        events = manager.Queue()
        tasks = {name: bar.add_task(name, total=len(sc.stages), name=name, stage="",
                                    time_ms=0.0, cracks=0, pressure="", stage_time="",
                                    eta="-")
                 for name, sc in scenarios.items()}
        with ProcessPoolExecutor(max_workers=workers,
                                 mp_context=mp.get_context("spawn")) as pool:
            futures = {name: pool.submit(_demo_worker, name, payload[name], str(out), events,
                                             overwrite)
                       for name in scenarios}
            while not all(f.done() for f in futures.values()):
                try:
                    name, fields = events.get(timeout=0.2)
                    bar.update(tasks[name], **fields)
                except queue.Empty:
                    pass
            for name, fut in futures.items():
                results[name] = fut.result()
                bar.update(tasks[name], completed=len(scenarios[name].stages))
    return results
