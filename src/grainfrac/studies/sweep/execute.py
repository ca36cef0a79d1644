"""Running sweeps on Dask: the cluster session, the submission of every run that
is not done, progress counts, and the tables written at the end.
"""

from __future__ import annotations

import logging
import os
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grainfrac.errors import GrainfracError
from grainfrac.io.files import write_json
from grainfrac.studies.sweep.plan import PlannedRun, SweepPlan
from grainfrac.studies.sweep.runs import FAILED_FILE, execute_run, run_state
from grainfrac.studies.sweep.tables import SweepResult, _write_plan, collect, write_tables

__all__ = [
    "DaskSession",
    "SweepError",
    "SweepProgress",
    "run_sweep",
    "run_sweeps",
]


class SweepError(GrainfracError):
    """A sweep cannot start or continue (stale results, unreachable scheduler)."""


class DaskSession:
    """A Dask client made on first use: a LocalCluster, an address, or a given client.

    ``scheduler``: None for a ``distributed.LocalCluster`` (processes, one thread
    each, ``n_workers`` default: the number of cores), an address such as
    ``tcp://host:8786`` for an existing cluster, or a ``distributed.Client``.
    """

    def __init__(self, scheduler: Any = None, n_workers: int | None = None):
        self.scheduler = scheduler
        self.n_workers = n_workers
        self._client: Any = None
        self._owned: list[Any] = []

    @property
    def client(self) -> Any:
        if self._client is None:
            self._client = self._connect()
        return self._client

    def _connect(self) -> Any:
        from distributed import Client, LocalCluster

        if isinstance(self.scheduler, Client):
            return self.scheduler
        if self.scheduler:
            try:
                client = Client(str(self.scheduler), timeout="15s")
            except (OSError, TimeoutError) as exc:
                raise SweepError(f"cannot reach the Dask scheduler at {self.scheduler}: "
                                 f"{exc}") from None
            self._owned.append(client)
            return client
        n = self.n_workers or max(1, os.cpu_count() or 1)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
        self._owned += [client, cluster]
        return client

    def close(self) -> None:
        for thing in self._owned:
            thing.close()
        self._owned.clear()
        self._client = None

    def __enter__(self) -> DaskSession:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextmanager
def _session(scheduler: Any, n_workers: int | None) -> Iterator[DaskSession]:
    if isinstance(scheduler, DaskSession):
        yield scheduler
    else:
        with DaskSession(scheduler, n_workers) as session:
            yield session


@dataclass
class SweepProgress:
    """Counts after each finished run (for a progress bar)."""

    sweep: str
    total: int
    skipped: int = 0
    computed: int = 0
    failed: int = 0
    last: str = ""

    @property
    def finished(self) -> int:
        return self.skipped + self.computed + self.failed


def run_sweeps(jobs: Sequence[tuple[SweepPlan, str | Path]], *, scheduler: Any = None,
               n_workers: int | None = None,
               progress: Callable[[SweepProgress], None] | None = None) -> list[SweepResult]:
    """Run several planned sweeps on one Dask cluster (all runs submitted together).

    Done runs are skipped without starting a cluster; a stale run directory
    is a :class:`SweepError` before any compute. Tables are written per sweep.
    """
    if n_workers is not None and n_workers < 1:
        # A local cluster of no workers never runs a task: the sweep would wait forever.
        raise SweepError(f"n_workers: must be >= 1 (got {n_workers})")
    start = time.perf_counter()
    outs = [Path(out) for _, out in jobs]
    todo: list[tuple[int, PlannedRun]] = []
    counters = [SweepProgress(plan.name, len(plan.runs)) for plan, _ in jobs]
    for j, ((plan, _), out) in enumerate(zip(jobs, outs, strict=True)):
        for run in plan.runs:
            state, detail = run_state(out / run.rel_dir, run.scenario)
            if state == "stale":
                raise SweepError(
                    f"{out / run.rel_dir} holds a finished run of another scenario ({detail}); "
                    "remove it or choose another --out")
            if state == "done":
                counters[j].skipped += 1
            else:
                todo.append((j, run))
        _write_plan(plan, out, None)
    if progress:
        for c in counters:
            progress(c)
    failures: list[dict[str, str]] = [{} for _ in jobs]
    if todo:
        from distributed import as_completed

        with _session(scheduler, n_workers or min(len(todo), os.cpu_count() or 1)) as session:
            client = session.client
            token = uuid.uuid4().hex[:8]
            futures = {}
            for j, run in todo:
                key = f"grainfrac-run-{jobs[j][0].name}-{run.point}-r{run.realisation}-{token}"
                fut = client.submit(execute_run, str(outs[j] / run.rel_dir), run.scenario,
                                    key=key, retries=jobs[j][0].retries, pure=False)
                futures[fut] = (j, run)
            for fut in as_completed(futures):
                j, run = futures[fut]
                try:
                    result = fut.result()
                except Exception as exc:  # a bug or a worker that kept dying: keep going
                    result = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
                    write_json(outs[j] / run.rel_dir / FAILED_FILE,
                               {"error": result["error"], "type": type(exc).__name__})
                counter = counters[j]
                if result["status"] == "done":
                    if result.get("computed"):
                        counter.computed += 1
                    else:
                        counter.skipped += 1
                else:
                    counter.failed += 1
                    failures[j][run.rel_dir] = result.get("error", "")
                counter.last = run.rel_dir
                if progress:
                    progress(counter)
                fut.release()
    results = []
    wall = time.perf_counter() - start
    for j, ((plan, _), out) in enumerate(zip(jobs, outs, strict=True)):
        result = collect(plan, out)
        result.skipped, result.computed = counters[j].skipped, counters[j].computed
        result.failures, result.wall_time_s = failures[j], wall
        result.files = write_tables(result)
        _write_plan(plan, out, result)
        results.append(result)
    return results


def run_sweep(plan: SweepPlan, out: str | Path, *, scheduler: Any = None,
              n_workers: int | None = None,
              progress: Callable[[SweepProgress], None] | None = None) -> SweepResult:
    """Run a planned sweep into ``out`` on Dask and write its tables; see the module doc."""
    return run_sweeps([(plan, out)], scheduler=scheduler, n_workers=n_workers,
                      progress=progress)[0]
