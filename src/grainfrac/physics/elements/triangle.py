"""Linear triangle (constant-strain triangle) in plane strain, thickness ``t``."""

from __future__ import annotations

import numpy as np

DIMENSION = 2
NODES_PER_CELL = 3


def gradients(x: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape-function gradients ``grad[m, 3, 2]`` and signed areas ``(m,)`` (m2).

    Counter-clockwise cells have positive area.
    """
    p = x[cells]
    px, py = p[..., 0], p[..., 1]
    two_a = ((px[:, 1] - px[:, 0]) * (py[:, 2] - py[:, 0])
             - (px[:, 2] - px[:, 0]) * (py[:, 1] - py[:, 0]))
    inv = 1.0 / two_a[:, None]
    grad = np.empty((len(cells), 3, 2))
    grad[:, :, 0] = np.column_stack((py[:, 1] - py[:, 2], py[:, 2] - py[:, 0],
                                     py[:, 0] - py[:, 1])) * inv
    grad[:, :, 1] = np.column_stack((px[:, 2] - px[:, 1], px[:, 0] - px[:, 2],
                                     px[:, 1] - px[:, 0])) * inv
    return grad, 0.5 * two_a


def measure(size: np.ndarray, thickness: float) -> np.ndarray:
    """Cell measure (m3): area x thickness of the plane-strain slice."""
    return size * thickness


def lumped_mass(density: np.ndarray, size: np.ndarray, thickness: float) -> np.ndarray:
    """Per-node lumped mass ``(m, 3)`` (kg): a third of each triangle's mass."""
    return np.repeat((density * size * thickness / 3.0)[:, None], 3, axis=1)
