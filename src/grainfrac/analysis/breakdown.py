"""Breakdown pressure and the abruptness of the pressure drop after it.

docs/outputs.md (``breakdown_pressure_MPa``): *breakdown pressure is the peak
of the well pressure before its first sustained drop during injection*. All
functions take plain arrays in SI units (s, Pa), so they work on a run's
``history.csv`` (after converting MPa to Pa) as well as on in-memory histories.
Pass only the injection stage: the functions do not know when injection
started or stopped.

Samples whose time or pressure is not finite (e.g. ``NaN`` in a history column
before the well was pressurised) are ignored; indices returned always refer to
the arrays as passed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "BreakdownResult",
    "breakdown",
    "breakdown_summary",
    "max_drop_rate",
    "pressure_drop_after_peak",
]


@dataclass(frozen=True)
class BreakdownResult:
    """The breakdown point of a pressure history.

    Attributes
    ----------
    pressure : float
        Breakdown pressure (Pa): the running maximum before the first sustained drop.
    time : float
        Time of the breakdown sample (s).
    index : int
        Index of the breakdown sample in the arrays as passed.
    drop_index : int
        Index of the first sample of the sustained drop (pressure below
        ``(1 - drop_fraction) * pressure``).
    """

    pressure: float
    time: float
    index: int
    drop_index: int


def _clean(time, pressure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Finite samples as float arrays, with their indices in the input."""
    t = np.asarray(time, dtype=float).ravel()
    p = np.asarray(pressure, dtype=float).ravel()
    if t.shape != p.shape:
        raise ValueError(f"time and pressure differ in length ({t.size} != {p.size})")
    keep = np.flatnonzero(np.isfinite(t) & np.isfinite(p))
    t, p = t[keep], p[keep]
    if t.size > 1 and np.any(np.diff(t) < 0):
        raise ValueError("time must be non-decreasing")
    return t, p, keep


def breakdown(time, pressure, *, drop_fraction: float = 0.05, sustain: float = 0.0,
              min_samples: int = 3) -> BreakdownResult | None:
    """Breakdown pressure: the peak of the well pressure before its first sustained drop.

    Scanning forward, a *drop* starts at the first sample ``j`` whose pressure is
    below ``M - drop_fraction * |M|``, where ``M`` is the running maximum of the
    pressure up to ``j``. The drop is *sustained* when the pressure then stays
    below that threshold for at least ``min_samples`` consecutive samples
    spanning at least ``sustain`` seconds (first to last sample below), or
    until the end of the record. Dips smaller than ``drop_fraction`` of the
    running maximum, and brief larger dips that recover, are ignored. The
    breakdown is the (first) sample holding the running maximum at the start of
    the first sustained drop.

    Parameters
    ----------
    time : array_like
        Sample times (s), non-decreasing.
    pressure : array_like
        Well pressure (Pa) at those times.
    drop_fraction : float, optional
        Relative fall below the running maximum that counts as a drop (default 5 %).
    sustain : float, optional
        Minimum duration (s) the pressure must stay below the threshold.
    min_samples : int, optional
        Minimum number of consecutive samples below the threshold.

    Returns
    -------
    BreakdownResult or None
        ``None`` when the pressure never drops in a sustained way (e.g. a
        monotone curve, or an empty record).

    Examples
    --------
    >>> t = [0, 1, 2, 3, 4, 5, 6]
    >>> p = [0, 4e6, 8e6, 9e6, 3e6, 2.9e6, 2.8e6]
    >>> breakdown(t, p).pressure
    9000000.0
    """
    if not 0 < drop_fraction < 1:
        raise ValueError(f"drop_fraction must be in (0, 1) (got {drop_fraction})")
    if min_samples < 1:
        raise ValueError(f"min_samples must be >= 1 (got {min_samples})")
    if sustain < 0:
        raise ValueError(f"sustain must be >= 0 (got {sustain})")
    t, p, keep = _clean(time, pressure)
    n = p.size
    if n < 2:
        return None
    running = np.maximum.accumulate(p)
    below = p < running - drop_fraction * np.abs(running)
    # While the pressure is below the threshold the running maximum cannot grow,
    # so each contiguous run of `below` samples is one drop with one threshold.
    edges = np.diff(np.concatenate(([0], below.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # exclusive
    for s, e in zip(starts, ends, strict=True):
        reaches_end = e == n
        long_enough = (e - s) >= min_samples and (t[e - 1] - t[s]) >= sustain
        if reaches_end or long_enough:
            peak = int(np.argmax(p[:s]))  # first sample holding the running maximum
            return BreakdownResult(pressure=float(p[peak]), time=float(t[peak]),
                                   index=int(keep[peak]), drop_index=int(keep[s]))
    return None


DROP_WINDOW_S = 1e-3  # how long after breakdown the fall of the well pressure is measured


def breakdown_summary(time, pressure, **kwargs) -> dict[str, float | None]:
    """The summary.json breakdown keys (docs/outputs.md).

    Parameters
    ----------
    time, pressure : array_like
        As for :func:`breakdown` (s, Pa).
    **kwargs
        Passed on to :func:`breakdown`.

    Returns
    -------
    dict
        ``breakdown_pressure_MPa``, ``breakdown_time_s`` and
        ``breakdown_drop_1ms_fraction`` (the fraction of the breakdown
        pressure lost within 1 ms after it: how abrupt the breakdown is,
        paper Fig. 17d), ``None`` where there is no breakdown.
    """
    result = breakdown(time, pressure, **kwargs)
    if result is None:
        return {"breakdown_pressure_MPa": None, "breakdown_time_s": None,
                "breakdown_drop_1ms_fraction": None}
    drop = pressure_drop_after_peak(time, pressure, DROP_WINDOW_S, peak_index=result.index,
                                    relative=True)
    return {"breakdown_pressure_MPa": result.pressure / 1e6, "breakdown_time_s": result.time,
            "breakdown_drop_1ms_fraction": drop}


def max_drop_rate(time, pressure) -> float:
    """Largest fall of pressure per unit time between consecutive samples (Pa/s).

    Quantifies how abrupt a breakdown is: a hydraulic breakdown drops the well
    pressure within a few steps, a pre-conditioned (hybrid) specimen may show
    no abrupt drop at all.

    Parameters
    ----------
    time : array_like
        Sample times (s), non-decreasing; pairs of samples at the same time are skipped.
    pressure : array_like
        Pressure (Pa).

    Returns
    -------
    float
        ``max(-(p[i+1] - p[i]) / (t[i+1] - t[i]))`` over consecutive samples,
        and ``0.0`` when the pressure never falls.
    """
    t, p, _ = _clean(time, pressure)
    if p.size < 2:
        return 0.0
    dt = np.diff(t)
    dp = np.diff(p)
    ok = dt > 0
    if not np.any(ok):
        return 0.0
    return float(max(0.0, np.max(-dp[ok] / dt[ok])))


def pressure_drop_after_peak(time, pressure, window: float, *, peak_index: int | None = None,
                             relative: bool = False) -> float:
    """Fall of pressure from a peak to the lowest value within ``window`` seconds after it.

    Parameters
    ----------
    time : array_like
        Sample times (s), non-decreasing.
    pressure : array_like
        Pressure (Pa).
    window : float
        Duration (s) after the peak over which the minimum is taken.
    peak_index : int, optional
        Index (in the arrays as passed) of the peak, e.g. ``breakdown(...).index``;
        default: the global maximum.
    relative : bool, optional
        Return the drop as a fraction of the peak pressure instead of in Pa.

    Returns
    -------
    float
        ``p_peak - min(p[t_peak <= t <= t_peak + window])`` (Pa, >= 0), or that
        divided by ``|p_peak|`` when ``relative``; ``0.0`` for an empty record.
    """
    if window < 0:
        raise ValueError(f"window must be >= 0 (got {window})")
    t, p, keep = _clean(time, pressure)
    if p.size == 0:
        return 0.0
    if peak_index is None:
        k = int(np.argmax(p))
    else:
        hit = np.flatnonzero(keep == peak_index)
        if hit.size == 0:
            raise ValueError(f"peak_index {peak_index} is out of range or not a finite sample")
        k = int(hit[0])
    after = (t >= t[k]) & (t <= t[k] + window)
    after[:k] = False
    drop = max(0.0, float(p[k] - p[after].min()))
    if relative:
        return drop / abs(p[k]) if p[k] != 0 else 0.0
    return drop
