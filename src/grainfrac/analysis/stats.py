"""Ensemble statistics: mean, standard deviation and Student-t confidence intervals.

Plain functions on lists of numbers. ``None`` and NaN mark a quantity a run
did not produce (e.g. no breakdown in an SCDA-only run); they are left out and
counted, never treated as zero. Intervals are two-sided at ``level`` (95 %)
with Student's t, so they are honest for the handful of realisations a sweep
affords:

* a mean: ``mean +- t(n-1) s / sqrt(n)``;
* a difference of two means: Welch's interval, ``t(nu) sqrt(s1^2/n1 + s2^2/n2)``
  with the Welch-Satterthwaite degrees of freedom ``nu``;
* a trend: the least-squares slope of ``y`` on ``x`` over individual runs,
  ``b +- t(n-2) se(b)``.

Every interval needs at least two values per mean (three for a slope); with
fewer the bounds are NaN and :attr:`Interval.defined` is False.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy import stats as sps

LEVEL = 0.95


def finite(values: Iterable[float | int | None]) -> np.ndarray:
    """The finite values of ``values`` as floats (None, NaN and inf left out)."""
    out = [float(v) for v in values if v is not None and not isinstance(v, bool)]
    arr = np.asarray(out, dtype=float)
    return arr[np.isfinite(arr)]


def t_quantile(dof: float, level: float = LEVEL) -> float:
    """Two-sided Student-t quantile ``t_{(1+level)/2}(dof)`` (12.706 for dof 1 at 95 %)."""
    return float(sps.t.ppf(0.5 + level / 2.0, dof))


@dataclass(frozen=True)
class Interval:
    """An estimate with its confidence interval; bounds NaN when undefined."""

    n: int
    estimate: float
    low: float
    high: float

    @property
    def defined(self) -> bool:
        return math.isfinite(self.low) and math.isfinite(self.high)

    @property
    def half_width(self) -> float:
        return (self.high - self.low) / 2.0


@dataclass(frozen=True)
class Summary:
    """Mean, sample standard deviation (ddof 1) and CI of one quantity at one point."""

    n: int
    n_missing: int
    mean: float
    std: float
    ci_low: float
    ci_high: float

    @property
    def ci_half_width(self) -> float:
        return (self.ci_high - self.ci_low) / 2.0

    @property
    def interval(self) -> Interval:
        return Interval(self.n, self.mean, self.ci_low, self.ci_high)


def summarise(values: Iterable[float | int | None], level: float = LEVEL) -> Summary:
    """Mean, std and Student-t CI of the finite values; NaN where undefined (n < 2)."""
    values = list(values)
    x = finite(values)
    n = int(x.size)
    nan = float("nan")
    if n == 0:
        return Summary(0, len(values), nan, nan, nan, nan)
    mean = float(np.mean(x))
    if n < 2:
        return Summary(n, len(values) - n, mean, nan, nan, nan)
    std = float(np.std(x, ddof=1))
    half = t_quantile(n - 1, level) * std / math.sqrt(n)
    return Summary(n, len(values) - n, mean, std, mean - half, mean + half)


def difference(a: Iterable[float | None], b: Iterable[float | None],
               level: float = LEVEL) -> Interval:
    """Welch CI of ``mean(a) - mean(b)``; undefined unless both have >= 2 values.

    Two samples without spread (e.g. the same integer count in every run)
    give a zero-width interval at the difference of the means.
    """
    x, y = finite(a), finite(b)
    nan = float("nan")
    if x.size == 0 or y.size == 0:
        return Interval(int(x.size + y.size), nan, nan, nan)
    d = float(np.mean(x) - np.mean(y))
    if x.size < 2 or y.size < 2:
        return Interval(int(x.size + y.size), d, nan, nan)
    vx, vy = np.var(x, ddof=1) / x.size, np.var(y, ddof=1) / y.size
    se2 = float(vx + vy)
    if se2 == 0.0:
        return Interval(int(x.size + y.size), d, d, d)
    dof = se2**2 / (vx**2 / (x.size - 1) + vy**2 / (y.size - 1))
    half = t_quantile(dof, level) * math.sqrt(se2)
    return Interval(int(x.size + y.size), d, d - half, d + half)


def slope(x: Iterable[float], y: Iterable[float | None], level: float = LEVEL) -> Interval:
    """Least-squares slope of ``y`` on ``x`` with its t(n-2) CI (pairs with a missing y dropped)."""
    xs, ys = [], []
    for xi, yi in zip(x, y, strict=True):
        if yi is None or isinstance(yi, bool) or not math.isfinite(float(yi)):
            continue
        xs.append(float(xi))
        ys.append(float(yi))
    xa, ya = np.asarray(xs), np.asarray(ys)
    n = int(xa.size)
    nan = float("nan")
    if n < 2 or np.ptp(xa) == 0.0:
        return Interval(n, nan, nan, nan)
    xc = xa - xa.mean()
    sxx = float(np.sum(xc**2))
    b = float(np.sum(xc * (ya - ya.mean())) / sxx)
    if n < 3:
        return Interval(n, b, nan, nan)
    resid = ya - ya.mean() - b * xc
    s2 = float(np.sum(resid**2)) / (n - 2)
    half = t_quantile(n - 2, level) * math.sqrt(s2 / sxx)
    return Interval(n, b, b - half, b + half)


__all__ = ["LEVEL", "Interval", "Summary", "difference", "finite", "slope", "summarise",
           "t_quantile"]
