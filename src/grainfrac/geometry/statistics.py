"""Grain size distribution of a tessellation."""

from __future__ import annotations

import numpy as np

from grainfrac.geometry.tessellation import GrainMap

PERCENTILES = (0, 10, 50, 90, 100)


def grain_size_distribution(grains: GrainMap) -> dict[str, dict[str, float]]:
    """Percentiles (mm) of grain equivalent diameter and of internal edge length.

    The equivalent diameter is that of the circle with the grain's area. Edge
    lengths are split into interior edges (held to the requested bounds) and
    edges cut by the specimen boundary.
    """
    diameter = np.sqrt(4.0 * grains.grain_areas() / np.pi) * 1e3
    lengths, cut = grains.edge_lengths()
    lengths = lengths * 1e3

    def describe(values: np.ndarray) -> dict[str, float]:
        if len(values) == 0:
            return {"count": 0}
        out = {"count": int(len(values)), "mean": float(values.mean())}
        for p, v in zip(PERCENTILES, np.percentile(values, PERCENTILES), strict=True):
            out[f"p{p}"] = float(v)
        return out

    return {
        "equivalent_diameter_mm": describe(diameter),
        "edge_length_mm": describe(lengths[~cut]),
        "boundary_cut_edge_length_mm": describe(lengths[cut]),
    }
