"""The measurement: lab tests of a recipe over the realisations in worker
processes (:class:`LabBench`), and the means, spreads and errors made of them.
"""

from __future__ import annotations

import os
import signal
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from grainfrac import materials
from grainfrac.analysis import stats
from grainfrac.assembly import FissureSpec, GrainSpec
from grainfrac.calibration.config import MEASURED, REPORTED, STRENGTHS
from grainfrac.labtests.config import LabTestConfig

__all__ = [
    "LabBench",
    "measured_values",
    "no_peak_runs",
    "run_means",
    "search_means",
    "seed_spread",
]


def _lab_value(job: tuple[str, int, materials.RockRecipe, GrainSpec, FissureSpec, int,
                          dict[str, Any]]) -> dict[str, Any]:
    """One lab test (worker process): returns its summary."""
    from grainfrac.labtests.run import measure

    test, seed, recipe, grains, fissures, dimension, loading = job
    config = LabTestConfig(test=test, seed=seed, rock=recipe, grains=grains, fissures=fissures,
                           dimension=dimension, loading=loading)
    return measure(config, recipe=recipe)["summary"]


def _ignore_interrupt() -> None:
    # Ctrl-C reaches the whole process group: the parent stops the calibration
    # (and keeps its history); workers finish their test instead of each
    # printing a traceback.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LabBench:
    """Runs lab tests over the realisations, in parallel processes; means per quantity.

    One process pool serves every evaluation (workers keep their compiled
    kernels); ``close()`` it, or use the bench as a context manager.
    ``dimension`` 3 runs the Table 3 specimens as solids. ``loading`` gives a test's
    :class:`~grainfrac.labtests.config.LoadingSpec` fields in place of its defaults,
    e.g. ``{"nscb": {"platen_speed_mm_per_s": 5.0}}``.
    """

    def __init__(self, seeds: list[int], grains: GrainSpec, workers: int | None = None,
                 fissures: FissureSpec | None = None, dimension: int = 2,
                 loading: dict[str, dict[str, Any]] | None = None):
        self.seeds = list(seeds)
        self.loading = dict(loading or {})
        self.grains = grains
        self.fissures = fissures or FissureSpec()
        self.dimension = dimension
        self.workers = workers or os.cpu_count() or 1
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> LabBench:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def measure(self, recipe: materials.RockRecipe, tests: tuple[str, ...],
                seeds: list[int] | None = None,
                ) -> tuple[dict[str, float], list[dict[str, Any]]]:
        """Mean of each reported quantity over the seeds (the bench's unless
        ``seeds`` is given), and every test's summary."""
        seeds = self.seeds if seeds is None else list(seeds)
        jobs = [(t, s, recipe, self.grains, self.fissures, self.dimension,
                 self.loading.get(t, {})) for t in tests for s in seeds]
        if self.workers > 1 and len(jobs) > 1:
            if self._pool is None:
                self._pool = ProcessPoolExecutor(max_workers=self.workers,
                                                 initializer=_ignore_interrupt)
            runs = list(self._pool.map(_lab_value, jobs))
        else:
            runs = [_lab_value(j) for j in jobs]
        return run_means(runs), runs


def run_means(runs: list[dict[str, Any]]) -> dict[str, float]:
    """Mean of each reported quantity over the runs that measured it."""
    means = {}
    for key in REPORTED:
        values = measured_values(runs, key)
        if values:
            means[key] = float(np.mean(values))
    return means


def measured_values(runs: list[dict[str, Any]], key: str) -> list[float]:
    """``key`` of the runs that measured it; a platen test that found no peak
    before its strain limit (a 2D specimen whose split columns carry on, e.g.
    Table 2 UCS seed 21: no 2 % fall up to 3 % strain, 442 MPa, and the split
    columns' lateral strain making nu 0.93) measured no strength, E or nu."""
    return [r[key] for r in runs
            if r.get(key) is not None and r.get("peak_found", True)]


def search_means(runs: list[dict[str, Any]]) -> dict[str, float]:
    """Means the root finder works on: as :func:`measured_values`, except that a
    strength whose test found no peak enters at the highest load it carried.

    That load is a lower bound on the strength. Leaving such a test out would
    make the mean a mean over the realisations that failed: with a high friction
    half the UCS specimens can lock up (measured, seeds 0-5 at 2.58 x tan(phi):
    98-115 MPa for three, no peak up to 436-554 MPa for the others) and the
    mean of the other three would look on target.
    """
    means = {}
    for key in MEASURED:
        values = ([r[key] for r in runs if r.get(key) is not None] if key in STRENGTHS
                  else measured_values(runs, key))
        if values:
            means[key] = float(np.mean(values))
    return means


def no_peak_runs(runs: list[dict[str, Any]]) -> list[str]:
    """``"test seed N"`` of each platen test that found no peak (left out of the means)."""
    return [f"{r['test']} seed {r['seed']}" for r in runs if r.get("peak_found") is False]


def _errors(achieved: dict[str, float], targets: dict[str, float]) -> dict[str, float]:
    return {k: achieved[k] / targets[k] - 1.0 for k in REPORTED if k in achieved}


def seed_spread(runs: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Spread over the realisations of each reported quantity: smallest and
    largest value, and the Student-t 95 % interval of the mean (``ci_low``,
    ``ci_high``; NaN with one realisation).

    A mean on target can hide realisations far apart (measured: BTS 1.2, 15.7
    and 2.5 MPa over seeds 0-2 for a mean of 6.45), and K_IC (NSCB) depends on
    where the notch tip sits among the grains (0.67-1.98 MPa m^0.5 over seeds
    0-5 with Table 2): the table shows how well the mean is known.
    """
    out = {}
    for key in REPORTED:
        values = measured_values(runs, key)
        if values:
            mean = stats.summarise(values)
            out[key] = {"min": float(min(values)), "max": float(max(values)),
                        "ci_low": mean.ci_low, "ci_high": mean.ci_high}
    return out
