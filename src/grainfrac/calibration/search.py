"""The optimiser loop: the root finder over the factors, its replay of an
interrupted history, the choice of the best evaluation, and a0 from the
constant-head test.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from grainfrac import materials
from grainfrac.calibration.bench import (
    LabBench,
    _errors,
    no_peak_runs,
    run_means,
    search_means,
    seed_spread,
)
from grainfrac.calibration.config import (
    FACTORS,
    MEASURED,
    PAIRING,
    STRENGTHS,
    TEST_OF,
    CalibrationConfig,
)
from grainfrac.calibration.scaling import _with_start_fracture_energy, scaled_recipe
from grainfrac.errors import ConfigError, GrainfracError

__all__ = [
    "SIMILARITY_STEPS",
    "calibrate",
    "similar_rock",
]


SIMILARITY_STEPS = 3  # evaluations past max_evaluations, each while it promises better


def calibrate(config: CalibrationConfig, recipe: materials.RockRecipe, *,
              log: Callable[[str], None] | None = None,
              on_evaluation: Callable[[list[dict[str, Any]]], None] | None = None,
              replay: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Find the factors and a0 that reproduce the targets; return the result record.

    The record holds ``recipe`` (calibrated), ``factors``, ``initial_aperture_m``,
    ``history`` (one row per evaluation), ``achieved`` (means of the final
    recipe, with K_IC and permeability), ``per_seed`` and ``converged``.

    ``on_evaluation(history)`` is called after every evaluation (a checkpoint).
    ``replay`` is the history of an interrupted calibration of the same config:
    an evaluation at factors found there takes its means instead of running the
    lab tests. The lab tests are deterministic, so the root finder retraces the
    interrupted run and goes on from where it stopped.
    """
    say = log or (lambda _msg: None)
    grain_factors = [f for f in ("grain_tensile_strength", "grain_cohesion")
                     if f in config.pairing() or f in config.start]
    if grain_factors and recipe.intragranular is None:
        raise ConfigError(f"factors.{grain_factors[0]}",
                          "needs breakable grains: the rock recipe has no intragranular section")
    if config.dimension == 3 and recipe.intragranular is not None:
        raise ConfigError("rock", "breakable grains (intragranular) are 2D only for now: "
                                  "calibrate in 3D with intact grains")
    with LabBench(config.seeds, config.grains, config.workers,
                  dimension=config.dimension) as bench:
        return _calibrate(config, recipe, bench, say, on_evaluation, replay or [])


def _replayed(rows: list[dict[str, Any]], factors: dict[str, float]) -> dict[str, Any] | None:
    """The row of ``rows`` evaluated at ``factors`` (to rounding), if any."""
    for row in rows:
        if all(math.isclose(row[k], factors[k], rel_tol=1e-9) for k in FACTORS):
            return row
    return None


def _calibrate(config: CalibrationConfig, recipe: materials.RockRecipe, bench: LabBench,
               say: Callable[[str], None],
               on_evaluation: Callable[[list[dict[str, Any]]], None] | None,
               replay: list[dict[str, Any]]) -> dict[str, Any]:
    from scipy.optimize import root

    targets = config.targets.model_dump()
    history: list[dict[str, Any]] = []

    pairing = config.pairing()
    unknowns = list(pairing)
    start_factors = {name: config.start.get(name, 1.0) for name in FACTORS}
    if {"fracture_energy", "shear_fracture_energy"} & (set(unknowns) | set(config.start)):
        recipe = _with_start_fracture_energy(recipe, config)
    needed = {TEST_OF[target] for target in pairing.values()}
    tests = tuple(t for t in ("ucs", "bts", "nscb") if t in needed)
    # d log(target) / d log(factor) has a known sign for the default pairs; with it the
    # unknowns move their targets up (a Jacobian close to the identity to start from).
    sign = {name: PAIRING[name][2] if PAIRING[name][0] == target else 1.0
            for name, target in pairing.items()}

    def factors_of(x: np.ndarray) -> dict[str, float]:
        return {**start_factors, **{name: start_factors[name] * math.exp(sign[name] * xi)
                            for name, xi in zip(unknowns, x, strict=True)}}

    seen: dict[tuple[float, ...], np.ndarray] = {}
    runs_of: dict[int, list[dict[str, Any]]] = {}  # evaluation -> its lab tests (run here)

    def evaluate(factors: dict[str, float], label: str = "") -> np.ndarray:
        """Run (or replay) the lab tests at ``factors``; record the row; return residuals."""
        start = time.perf_counter()
        earlier = _replayed(replay, factors)
        if earlier is not None:
            means = {k: earlier[k] for k in MEASURED if earlier.get(k) is not None}
            no_peak = int(earlier["no_peak_runs"])
        else:
            _, runs = bench.measure(scaled_recipe(recipe, factors), tests)
            means, no_peak = search_means(runs), len(no_peak_runs(runs))
            runs_of[len(history) + 1] = runs
        missing = sorted({pairing[n] for n in unknowns} - set(means))
        if missing:
            # Every realisation locked up (no peak): no value for the root finder.
            reason = (f"evaluation {len(history) + 1}: no realisation measured "
                      f"{', '.join(missing)} (no peak before the strain limit) at factors "
                      + ", ".join(f"{k} {v:.4g}" for k, v in factors.items()))
            if not history:
                raise GrainfracError(f"calibration: {reason}")
            say(f"{reason}; the search stops at the best evaluation so far")
            raise _Stop
        r = np.array([math.log(means[pairing[n]] / targets[pairing[n]]) for n in unknowns])
        if not np.all(np.isfinite(r)):
            raise GrainfracError(f"calibration: a lab test gave no value at factors {factors}")
        history.append({"evaluation": len(history) + 1, **factors, **means,
                        "no_peak_runs": no_peak,
                        "max_error": float(np.max(np.abs(np.expm1(r)))),
                        "wall_time_s": (time.perf_counter() - start if earlier is None
                                        else earlier["wall_time_s"])})
        say(f"evaluation {len(history)}{label}{' (from the history)' if earlier else ''}: "
            + ", ".join(f"{pairing[n]} {means[pairing[n]]:.4g} ({math.expm1(ri):+.1%})"
                        for n, ri in zip(unknowns, r, strict=True))
            + (f"; {no_peak} tests found no peak (their highest load enters the mean)"
               if no_peak else ""))
        if on_evaluation is not None:
            on_evaluation(history)
        return r

    def residual(x: np.ndarray) -> np.ndarray:
        key = tuple(np.round(x, 12))
        if key in seen:  # MINPACK asks for the starting point twice
            return seen[key]
        if len(history) >= config.max_evaluations:
            raise _Stop
        r = evaluate(factors_of(x))
        if history[-1]["max_error"] <= config.tolerance and not history[-1]["no_peak_runs"]:
            raise _Stop
        seen[key] = r
        return r

    try:
        root(residual, np.zeros(len(unknowns)), method="hybr",
             options={"eps": 0.01, "factor": 1.0, "maxfev": config.max_evaluations})
    except _Stop:
        pass
    if not history:
        raise GrainfracError("calibration: no evaluation finished")
    best = _best(history)
    calibrated = list(pairing.values())
    scaled_from: set[float] = set()
    for _ in range(SIMILARITY_STEPS):
        if best["max_error"] <= config.tolerance:
            break
        candidates = [(row, *similar_rock(row, calibrated, targets))
                      for row in _clean(history) if row["evaluation"] not in scaled_from]
        if not candidates:
            break
        row, scale, predicted = min(candidates, key=lambda item: item[2])
        if predicted >= best["max_error"]:
            break
        scaled_from.add(row["evaluation"])
        say(f"similarity step: evaluation {row['evaluation']:g} with its strengths x "
            f"{scale:.4f} (fracture energies x {scale ** 2:.4f}) is predicted at "
            f"{predicted:.1%}")
        evaluate({**{k: row[k] for k in FACTORS},
                  "strength_scale": row["strength_scale"] * scale}, label=" (similarity step)")
        best = _best(history)
    factors = {name: best[name] for name in FACTORS}
    say(f"best: evaluation {best['evaluation']} (largest error {best['max_error']:.1%})")

    a0 = _calibrate_aperture(recipe, factors, bench, targets["permeability_m2"])
    final = scaled_recipe(recipe, factors, initial_aperture_m=a0, name=config.name)
    say("measuring the calibrated recipe (UCS, BTS, NSCB, permeability)...")
    all_tests = ("ucs", "bts", "nscb", "permeability")
    # a0 and the name do not enter the platen tests: the best evaluation's runs stand.
    kept = [{**run, "rock": config.name} for run in runs_of.get(int(best["evaluation"]), [])
            if "test" in run]
    done = {run["test"] for run in kept}
    _, new_runs = bench.measure(final, tuple(t for t in all_tests if t not in done))
    runs = kept + new_runs
    achieved = run_means(runs)
    held_out = None
    if config.validation_seeds:
        say(f"measuring it on the held-out seeds {config.validation_seeds}...")
        means, held_runs = bench.measure(final, all_tests, seeds=config.validation_seeds)
        held_out = {"achieved": means, "errors": _errors(means, targets),
                    "spread": seed_spread(held_runs), "per_seed": held_runs}
    return {
        "recipe": final,
        "held_out": held_out,
        "spread": seed_spread(runs),
        "factors": factors,
        "initial_aperture_m": a0,
        "history": history,
        "achieved": achieved,
        "errors": _errors(achieved, targets),
        "per_seed": runs,
        "converged": best["max_error"] <= config.tolerance and not best["no_peak_runs"],
        "targets": targets,
    }


def _clean(history: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Evaluations where every test peaked (a mean holding a lower bound is not a
    measured strength); all of them if none did."""
    return [row for row in history if not row["no_peak_runs"]] or history


def _best(history: list[dict[str, Any]]) -> dict[str, Any]:
    return min(_clean(history), key=lambda row: row["max_error"])


def similar_rock(row: dict[str, Any], calibrated: list[str], targets: dict[str, float]
                 ) -> tuple[float, float]:
    """The ``strength_scale`` multiplier that centres the strength errors of one
    evaluation (UCS, BTS and K_IC scale alike with it; E and nu do not move), and
    the largest error it predicts over the ``calibrated`` targets."""
    logs = {k: math.log(row[k] / targets[k]) for k in calibrated}
    strengths = [logs[k] for k in STRENGTHS if k in logs]
    if not strengths:
        return 1.0, float(row["max_error"])
    shift = -0.5 * (max(strengths) + min(strengths))
    predicted = max(abs(math.expm1(v + shift if k in STRENGTHS else v)) for k, v in logs.items())
    return math.exp(shift), predicted


class _Stop(Exception):
    """Converged, or the evaluation budget is spent."""


def _calibrate_aperture(recipe, factors, bench, target: float) -> float:
    """a0 from one constant-head test per seed: k ~ a0^3 on an intact assembly."""
    start_a0 = recipe.hydraulic.initial_aperture_m
    means, _ = bench.measure(scaled_recipe(recipe, factors), ("permeability",))
    return start_a0 * (target / means["permeability_m2"]) ** (1.0 / 3.0)
