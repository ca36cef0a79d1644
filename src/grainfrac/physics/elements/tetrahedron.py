"""Linear tetrahedron (constant-strain tetrahedron)."""

from __future__ import annotations

import numpy as np

DIMENSION = 3
NODES_PER_CELL = 4


def gradients(x: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shape-function gradients ``grad[m, 4, 3]`` and signed volumes ``(m,)`` (m3).

    With the Jacobian ``J = [x1 - x0, x2 - x0, x3 - x0]`` (columns), the
    gradients of N1..N3 are the rows of ``J^-1`` and ``grad N0 = -(sum of the
    others)``; the volume is ``det J / 6``, positive when ``x3`` lies on the side
    of the face (x0, x1, x2) that its right-hand normal points to.
    """
    p = x[cells]
    jac = np.stack((p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]), axis=2)
    det = np.linalg.det(jac)
    grad = np.empty((len(cells), 4, 3))
    grad[:, 1:, :] = np.linalg.inv(jac)
    grad[:, 0, :] = -grad[:, 1:, :].sum(axis=1)
    return grad, det / 6.0


def measure(size: np.ndarray, thickness: float | None = None) -> np.ndarray:
    """Cell measure (m3): the volume."""
    return np.asarray(size, dtype=np.float64)


def lumped_mass(density: np.ndarray, size: np.ndarray, thickness: float | None = None
                ) -> np.ndarray:
    """Per-node lumped mass ``(m, 4)`` (kg): a quarter of each tetrahedron's mass."""
    return np.repeat((density * size / 4.0)[:, None], 4, axis=1)
