"""Claims about sweep results, decided from 95 % confidence intervals.

A claim names a quantity, the sweep points it is about and what the paper
says about them. :func:`evaluate` turns a claim and a :class:`SweepResult`
into a :class:`Verdict`:

``holds``
    the whole 95 % interval lies on the claimed side;
``does not hold``
    the whole interval lies on the other side;
``inconclusive``
    the interval straddles the boundary (more realisations may decide);
``undetermined``
    no interval can be made: the quantity is null/NaN in every run of a
    point (with the reason, e.g. no breakdown was detected), or there are
    too few valid runs (a mean needs two, a slope three).

Kinds of claim (see :class:`Claim`):

``at_least``
    at every point the mean is at least ``threshold`` (each point's t
    interval; fails if any point's interval lies wholly below);
``greater``
    ``points[0]`` exceeds ``points[1]``: the interval of the difference of
    means. When both points ran the same seeds (common random numbers: the
    same grain structures), the per-seed paired difference and its t
    interval are used, otherwise Welch's interval;
``trend``
    the quantity rises (``direction = +1``) or falls (-1) with ``x``: the
    least-squares slope over individual runs and its t(n-2) interval;
``exceeds``
    in the same runs, ``quantity`` exceeds ``other`` (paired over every run
    of ``points``);
``within``
    the mean lies within ``tolerance`` (relative) of ``reference``;
``every_run``
    a count, not an interval: every run at every point reaches ``threshold``
    (holds when all do, does not hold when any run falls short; at least two
    runs per point are needed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

from grainfrac.analysis import stats
from grainfrac.studies.sweep import SweepResult

Verdicts = Literal["holds", "does not hold", "inconclusive", "undetermined"]
HOLDS, FAILS, OPEN, UNDETERMINED = "holds", "does not hold", "inconclusive", "undetermined"

# Why a summary value is null (summary.json writes null where a measure does not apply).
NULL_REASONS = {
    "breakdown_pressure_MPa": "no breakdown was detected (no sustained drop of the well "
                              "pressure before injection ended)",
    "breakdown_time_s": "no breakdown was detected",
    "breakdown_drop_1ms_fraction": "no breakdown was detected",
    "tensile_shear_ratio": "no shear cracks formed, so T/S is undefined",
    "fracture_extent_mm": "no crack cluster is connected to the well",
    "tortuosity": "no fracture through the well to measure",
    "peak_expansive_pressure_MPa": "the runs have no SCDA stage",
}


@dataclass(frozen=True)
class Claim:
    """One statement of the paper about a quantity at some sweep points."""

    id: str
    text: str
    quantity: str
    kind: Literal["at_least", "greater", "trend", "exceeds", "within", "every_run"]
    points: tuple[str, ...]
    paper: str = ""
    threshold: float | None = None
    x: tuple[float, ...] = ()
    x_label: str = ""
    direction: int = 1
    other: str | None = None
    reference: float | None = None
    tolerance: float | None = None


@dataclass
class Verdict:
    """The decision on a claim, the interval it rests on and a one-line account."""

    claim: Claim
    verdict: str
    estimate: str
    reason: str
    interval: stats.Interval | None = None
    per_point: dict[str, stats.Summary] = field(default_factory=dict)

    def as_row(self, study: str) -> dict[str, Any]:
        iv = self.interval
        return {"study": study, "claim": self.claim.id, "quantity": self.claim.quantity,
                "statement": self.claim.text, "paper": self.claim.paper,
                "verdict": self.verdict, "estimate": self.estimate, "reason": self.reason,
                "ci95_low": None if iv is None or not iv.defined else iv.low,
                "ci95_high": None if iv is None or not iv.defined else iv.high}


def fmt(value: float, digits: int = 3) -> str:
    """A number with ``digits`` significant digits ('-' for NaN)."""
    if value is None or not math.isfinite(value):
        return "-"
    if value == 0:
        return "0"
    if abs(value) >= 1e5 or abs(value) < 1e-3:
        return f"{value:.{digits - 1}e}"
    return f"{value:.{digits}g}" if abs(value) < 10 ** digits else f"{value:.0f}"


def _interval_text(iv: stats.Interval) -> str:
    if not math.isfinite(iv.estimate):
        return "-"
    if not iv.defined:
        return f"{fmt(iv.estimate)} (no CI)"
    return f"{fmt(iv.estimate)} [95 % CI {fmt(iv.low)}, {fmt(iv.high)}]"


def _side(low: float, high: float, boundary: float, above: bool) -> str:
    if above:
        return HOLDS if low > boundary else FAILS if high < boundary else OPEN
    return HOLDS if high < boundary else FAILS if low > boundary else OPEN


def _all_null(result: SweepResult, claim: Claim, quantity: str) -> Verdict | None:
    """Undetermined when a point has no finite value of ``quantity`` in any run."""
    for point in claim.points:
        values = result.values(point, quantity)
        if not stats.finite(values).size:
            why = NULL_REASONS.get(quantity, "the quantity was not produced")
            runs = len(values)
            reason = (f"{quantity} is null/NaN in all {runs} run(s) at {point}: {why}"
                      if runs else f"no finished runs at {point}")
            return Verdict(claim, UNDETERMINED, "-", reason)
    return None


def _seeds(result: SweepResult, point: str) -> list[int]:
    return [r["seed"] for r in result.runs if r["point"] == point and r["status"] == "done"]


def evaluate(claim: Claim, result: SweepResult) -> Verdict:
    """Decide ``claim`` on ``result`` (see the module doc for the rules)."""
    null = _all_null(result, claim, claim.quantity)
    if claim.kind == "exceeds" and null is None and claim.other is not None:
        null = _all_null(result, claim, claim.other)
    if null is not None:
        return null
    per_point = {p: stats.summarise(result.values(p, claim.quantity)) for p in claim.points}
    verdict = _KINDS[claim.kind](claim, result, per_point)
    verdict.per_point = per_point
    return verdict


def _at_least(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]
              ) -> Verdict:
    v = float(claim.threshold)
    means = ", ".join(f"{p} {_interval_text(s.interval)}" for p, s in per_point.items())
    below = [p for p, s in per_point.items() if s.n >= 2 and s.ci_high < v]
    if below:
        return Verdict(claim, FAILS, means, f"95 % CI wholly below {v:g} at {', '.join(below)}")
    undefined = [p for p, s in per_point.items() if s.n < 2]
    if undefined:
        return Verdict(claim, UNDETERMINED, means, f"fewer than 2 valid runs at "
                       f"{', '.join(undefined)}; no 95 % CI (run more realisations)")
    if all(s.ci_low >= v for s in per_point.values()):
        return Verdict(claim, HOLDS, means, f"95 % CI at or above {v:g} at every point")
    straddle = [p for p, s in per_point.items() if s.ci_low < v]
    return Verdict(claim, OPEN, means, f"95 % CI includes values below {v:g} at "
                   + ", ".join(straddle))


def _greater(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]
             ) -> Verdict:
    hi, lo = claim.points
    a, b = result.values(hi, claim.quantity), result.values(lo, claim.quantity)
    paired = _seeds(result, hi) == _seeds(result, lo)
    if paired:
        pairs = [(x, y) for x, y in zip(a, b, strict=True)
                 if stats.finite([x]).size and stats.finite([y]).size]
        s = stats.summarise(x - y for x, y in pairs)
        iv, how = s.interval, f"paired over {s.n} common seeds"
    else:
        iv, how = stats.difference(a, b), "Welch"
    text = (f"{hi} - {lo} = {_interval_text(iv)} ({how}); {hi} "
            f"{fmt(per_point[hi].mean)}, {lo} {fmt(per_point[lo].mean)}")
    if not iv.defined:
        return Verdict(claim, UNDETERMINED, text, "fewer than 2 valid runs per point; no 95 % "
                       "CI of the difference (run more realisations)", iv)
    verdict = _side(iv.low, iv.high, 0.0, above=True)
    reason = {HOLDS: "95 % CI of the difference lies above 0",
              FAILS: "95 % CI of the difference lies below 0",
              OPEN: "95 % CI of the difference includes 0"}[verdict]
    return Verdict(claim, verdict, text, reason, iv)


def _trend(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]) -> Verdict:
    xs, ys = [], []
    for point, x in zip(claim.points, claim.x, strict=True):
        for y in result.values(point, claim.quantity):
            xs.append(x)
            ys.append(y)
    iv = stats.slope(xs, ys)
    word = "rises" if claim.direction > 0 else "falls"
    unit = f" per unit of {claim.x_label}" if claim.x_label else ""
    means = ", ".join(f"{p} {fmt(s.mean)}" for p, s in per_point.items())
    text = f"slope {_interval_text(iv)}{unit}; means {means}"
    if not iv.defined:
        return Verdict(claim, UNDETERMINED, text, f"{iv.n} valid run(s): a slope CI needs at "
                       "least 3 at 2 or more x values (run more realisations)", iv)
    verdict = _side(iv.low, iv.high, 0.0, above=claim.direction > 0)
    reason = {HOLDS: f"95 % CI of the slope excludes 0: the quantity {word}",
              FAILS: f"95 % CI of the slope excludes 0 on the other side: it does not {word[:-1]}",
              OPEN: "95 % CI of the slope includes 0"}[verdict]
    return Verdict(claim, verdict, text, reason, iv)


def _exceeds(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]
             ) -> Verdict:
    diffs = []
    for point in claim.points:
        for row in result.runs:
            if row["point"] != point or row["status"] != "done":
                continue
            a, b = row.get(claim.quantity), row.get(claim.other)
            if stats.finite([a]).size and stats.finite([b]).size:
                diffs.append(float(a) - float(b))
    s = stats.summarise(diffs)
    text = f"{claim.quantity} - {claim.other} = {_interval_text(s.interval)} over {s.n} runs"
    if s.n < 2:
        return Verdict(claim, UNDETERMINED, text, f"{s.n} run(s) with both values; no 95 % "
                       "CI (run more realisations)", s.interval)
    verdict = _side(s.ci_low, s.ci_high, 0.0, above=True)
    reason = {HOLDS: "95 % CI of the per-run difference lies above 0",
              FAILS: "95 % CI of the per-run difference lies below 0",
              OPEN: "95 % CI of the per-run difference includes 0"}[verdict]
    return Verdict(claim, verdict, text, reason, s.interval)


def _within(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]
            ) -> Verdict:
    (point,) = claim.points
    s = per_point[point]
    ref, tol = float(claim.reference), float(claim.tolerance)
    lo, hi = ref * (1 - tol), ref * (1 + tol)
    rel = (s.mean - ref) / ref
    text = f"{_interval_text(s.interval)} ({rel:+.1%} from {ref:g})"
    if s.n < 2:
        return Verdict(claim, UNDETERMINED, text, f"{s.n} valid run(s); no 95 % CI (run more "
                       "realisations)", s.interval)
    if lo <= s.ci_low and s.ci_high <= hi:
        verdict, reason = HOLDS, f"95 % CI inside [{lo:.3g}, {hi:.3g}]"
    elif s.ci_high < lo or s.ci_low > hi:
        verdict, reason = FAILS, f"95 % CI outside [{lo:.3g}, {hi:.3g}]"
    else:
        verdict, reason = OPEN, f"95 % CI overlaps the edge of [{lo:.3g}, {hi:.3g}]"
    return Verdict(claim, verdict, text, reason, s.interval)


def _every_run(claim: Claim, result: SweepResult, per_point: dict[str, stats.Summary]
               ) -> Verdict:
    v = float(claim.threshold)
    counts, short, few = [], [], []
    for point in claim.points:
        values = [float(x) for x in stats.finite(result.values(point, claim.quantity))]
        reached = sum(x >= v for x in values)
        counts.append(f"{point} {reached} of {len(values)} (min {fmt(min(values))})")
        if reached < len(values):
            short.append(point)
        if len(values) < 2:
            few.append(point)
    text = f"runs with {claim.quantity} >= {v:g}: " + ", ".join(counts)
    if short:
        return Verdict(claim, FAILS, text, f"some runs below {v:g} at {', '.join(short)}")
    if few:
        return Verdict(claim, UNDETERMINED, text, f"fewer than 2 valid runs at "
                       f"{', '.join(few)} (run more realisations)")
    return Verdict(claim, HOLDS, text, f"every run at or above {v:g}")


_KINDS = {"at_least": _at_least, "greater": _greater, "trend": _trend, "exceeds": _exceeds,
          "within": _within, "every_run": _every_run}

__all__ = ["FAILS", "HOLDS", "NULL_REASONS", "OPEN", "UNDETERMINED", "Claim", "Verdict",
           "evaluate", "fmt"]
