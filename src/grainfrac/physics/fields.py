"""Stress fields around the well (paper Fig. 10): minor principal and tangential stress.

Element stresses come tension positive, (sxx, syy, sxy[, szz]) in Pa. The
paper plots compression positive; these functions return tension-positive
values and the callers (figures, history) state their sign convention.

They live in physics, not analysis, because a run measures them while it runs
(the hoop stress near the well is a history column) and a run never imports
from the analysis layer above it.
"""

from __future__ import annotations

import numpy as np


def minor_principal_stress(stress: np.ndarray) -> np.ndarray:
    """In-plane minor principal stress (Pa, tension positive: the most compressive value)."""
    sxx, syy, sxy = stress[:, 0], stress[:, 1], stress[:, 2]
    centre = 0.5 * (sxx + syy)
    radius = np.hypot(0.5 * (sxx - syy), sxy)
    return centre - radius


def major_principal_stress(stress: np.ndarray) -> np.ndarray:
    """In-plane major principal stress (Pa, tension positive: the most tensile value)."""
    sxx, syy, sxy = stress[:, 0], stress[:, 1], stress[:, 2]
    return 0.5 * (sxx + syy) + np.hypot(0.5 * (sxx - syy), sxy)


def tangential_stress(points: np.ndarray, stress: np.ndarray,
                      center: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """Hoop stress (Pa, tension positive) about ``center`` at ``points``.

    sigma_tt = sxx sin^2(t) + syy cos^2(t) - 2 sxy sin(t) cos(t), with t the
    polar angle of the point about the centre.
    """
    return _hoop(stress, *_polar_sin_cos(points, center))


def _polar_sin_cos(points: np.ndarray, center) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos of each point's polar angle about ``center``."""
    d = np.asarray(points, dtype=float)[:, :2] - np.asarray(center, dtype=float)
    t = np.arctan2(d[:, 1], d[:, 0])
    return np.sin(t), np.cos(t)


def _hoop(stress: np.ndarray, s: np.ndarray, c: np.ndarray) -> np.ndarray:
    """sigma_tt from in-plane (sxx, syy, sxy) at polar angles of sine s, cosine c."""
    return stress[:, 0] * s * s + stress[:, 1] * c * c - 2.0 * stress[:, 2] * s * c


def in_plane(stress: np.ndarray) -> np.ndarray:
    """(sxx, syy, sxy) of 2D stresses (sxx, syy, sxy, szz) or 3D ones (sxx, syy, szz, syz,
    sxz, sxy): the components in the slab plane, about the borehole axis (z)."""
    return stress[:, [0, 1, 5]] if stress.shape[1] == 6 else stress[:, :3]


def ring_mean_tangential_stress(points: np.ndarray, stress: np.ndarray, weights: np.ndarray,
                                center: tuple[float, float], inner: float,
                                outer: float) -> float:
    """Weighted mean hoop stress (Pa, tension positive) of points with inner <= r < outer
    (in 3D: distance from the axis through ``center`` along z; points may carry a z)."""
    return Ring(points, weights, center, inner, outer).mean_tangential_stress(stress)


class Ring:
    """The points with inner <= r < outer about ``center`` (in 3D: about the axis through
    it along z), found once: a run reads their mean hoop stress after every chunk, and
    finding them costs as much as the whole 3D stress field (1e6 tetrahedra)."""

    def __init__(self, points: np.ndarray, weights: np.ndarray,
                 center: tuple[float, float], inner: float, outer: float):
        points = np.asarray(points)[:, :2]
        r = np.hypot(*(points - np.asarray(center)).T)
        self.index = np.flatnonzero((r >= inner) & (r < outer))
        self.weights = np.asarray(weights)[self.index]
        self._sin, self._cos = _polar_sin_cos(points[self.index], center)

    def mean_tangential_stress(self, stress: np.ndarray) -> float:
        """Weighted mean hoop stress (Pa, tension positive) of the ring's points, NaN if
        it holds none; ``stress`` for all points (the angles found once)."""
        if len(self.index) == 0:
            return float("nan")
        hoop = _hoop(in_plane(stress[self.index]), self._sin, self._cos)
        return float(np.average(hoop, weights=self.weights))
