"""Linear tetrahedron (constant-strain tetrahedron)."""

from __future__ import annotations

import numpy as np
from numba import njit

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


# -- kernels (numba): the element's strain, stress and nodal forces ----------------------
@njit(cache=True, inline="always")
def elastic_strain(u, cells, grad, initial_strain, eigenstrain, e):
    """Elastic strain (xx, yy, zz, yz, xz, xy engineering) of tetrahedron ``e``."""
    exx = -initial_strain[e, 0] - eigenstrain[e]
    eyy = -initial_strain[e, 1] - eigenstrain[e]
    ezz = -initial_strain[e, 2] - eigenstrain[e]
    gyz = -initial_strain[e, 3]
    gxz = -initial_strain[e, 4]
    gxy = -initial_strain[e, 5]
    for k in range(4):
        n = cells[e, k]
        gx, gy, gz = grad[e, k, 0], grad[e, k, 1], grad[e, k, 2]
        ux, uy, uz = u[n, 0], u[n, 1], u[n, 2]
        exx += gx * ux
        eyy += gy * uy
        ezz += gz * uz
        gyz += gz * uy + gy * uz
        gxz += gz * ux + gx * uz
        gxy += gy * ux + gx * uy
    return exx, eyy, ezz, gyz, gxz, gxy


@njit(cache=True, inline="always")
def stress(u, elements, state, e):
    """Stress (sxx, syy, szz, syz, sxz, sxy) of tetrahedron ``e``: lam tr(eps) I + 2 mu eps."""
    exx, eyy, ezz, gyz, gxz, gxy = elastic_strain(u, elements.cells, elements.grad,
                                                  state.initial_strain, state.eigenstrain, e)
    tr = elements.lam[e] * (exx + eyy + ezz)
    two_mu = 2.0 * elements.mu[e]
    mu = elements.mu[e]
    return (tr + two_mu * exx, tr + two_mu * eyy, tr + two_mu * ezz, mu * gyz, mu * gxz,
            mu * gxy)


@njit(cache=True, inline="always")
def node_force(elements, e, k, vol, sxx, syy, szz, syz, sxz, sxy):
    """V B_k^T sigma: what node ``k`` of tetrahedron ``e`` loses to the stress (N)."""
    gx = elements.grad[e, k, 0]
    gy = elements.grad[e, k, 1]
    gz = elements.grad[e, k, 2]
    return (vol * (gx * sxx + gy * sxy + gz * sxz), vol * (gx * sxy + gy * syy + gz * syz),
            vol * (gx * sxz + gy * syz + gz * szz))


@njit(cache=True)
def range_forces(u, elements, state, first, stop, force):
    """:func:`internal_forces` of the tetrahedra ``first`` to ``stop - 1``."""
    # Unsigned: a signed index from a runtime start gets a negative-index check per
    # access (12 % slower on a 2D slab).
    out = state.stress
    for e in range(np.uint64(first), np.uint64(stop)):
        sxx, syy, szz, syz, sxz, sxy = stress(u, elements, state, e)
        vol = elements.measure[e]
        out[e, 0] = sxx
        out[e, 1] = syy
        out[e, 2] = szz
        out[e, 3] = syz
        out[e, 4] = sxz
        out[e, 5] = sxy
        for k in range(4):
            n = elements.cells[e, k]
            fx, fy, fz = node_force(elements, e, k, vol, sxx, syy, szz, syz, sxz, sxy)
            force[n, 0] -= fx
            force[n, 1] -= fy
            force[n, 2] -= fz


@njit(cache=True)
def internal_forces(u, elements, state, force):
    """Add internal forces of linear tetrahedra to ``force``; store stresses.

    f_a = -V B_a^T sigma with V the volume; ``stress[e] = (sxx, syy, szz, syz, sxz, sxy)``.
    """
    range_forces(u, elements, state, 0, elements.cells.shape[0], force)


@njit(cache=True)
def strain_energy(u, elements, state):
    """Elastic strain energy stored in the tetrahedra (J)."""
    cells, grad, measure, lam, mu = elements
    total = 0.0
    for e in range(cells.shape[0]):
        exx, eyy, ezz, gyz, gxz, gxy = elastic_strain(u, cells, grad, state.initial_strain,
                                                      state.eigenstrain, e)
        tr = lam[e] * (exx + eyy + ezz)
        w = (tr * (exx + eyy + ezz) + 2.0 * mu[e] * (exx * exx + eyy * eyy + ezz * ezz)
             + mu[e] * (gyz * gyz + gxz * gxz + gxy * gxy))
        total += 0.5 * w * measure[e]
    return total
