"""What the linear triangle and tetrahedron share: Voigt layout, B matrices, row sums."""

from __future__ import annotations

from types import ModuleType

import numpy as np
from numba import njit, prange


def n_strain_components(dimension: int) -> int:
    """Independent strain components: 3 in 2D (xx, yy, xy), 6 in 3D."""
    return dimension * (dimension + 1) // 2


def n_stress_components(dimension: int) -> int:
    """Stored stress components: 4 in 2D (plane strain adds zz), 6 in 3D."""
    return 4 if dimension == 2 else 6


def shear_pairs(dimension: int) -> list[tuple[int, int]]:
    """The (i, j) axes of each shear component, in Voigt order after the normal ones."""
    return [(0, 1)] if dimension == 2 else [(1, 2), (0, 2), (0, 1)]


def lame_parameters(youngs_modulus: np.ndarray, poisson_ratio: np.ndarray):
    """Lame lambda and mu from E and nu (3D; plane strain uses the same pair)."""
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    return lam, mu


def strain_displacement(grad: np.ndarray) -> np.ndarray:
    """B matrices ``(m, n_strain, K d)`` from shape gradients ``grad[m, K, d]``.

    Degrees of freedom are ordered node by node (x, y[, z] of node 0, then node 1...).
    """
    m, k, d = grad.shape
    b = np.zeros((m, n_strain_components(d), k * d))
    for i in range(d):
        b[:, i, i::d] = grad[:, :, i]
    for s, (i, j) in enumerate(shear_pairs(d)):
        b[:, d + s, i::d] = grad[:, :, j]
        b[:, d + s, j::d] = grad[:, :, i]
    return b


def elasticity_matrix(lam: np.ndarray, mu: np.ndarray, dimension: int) -> np.ndarray:
    """Isotropic D matrices ``(m, n_strain, n_strain)`` (plane strain in 2D)."""
    n = n_strain_components(dimension)
    dmat = np.zeros((len(lam), n, n))
    for i in range(dimension):
        for j in range(dimension):
            dmat[:, i, j] = lam
        dmat[:, i, i] = lam + 2 * mu
    for s in range(dimension, n):
        dmat[:, s, s] = mu
    return dmat


def element_row_sums(grad: np.ndarray, measure: np.ndarray, lam: np.ndarray,
                     mu: np.ndarray) -> np.ndarray:
    """Absolute row sums of each element stiffness matrix, per (element, node, dof).

    ``K_e = measure B^T D B``; the row sums are the Gershgorin bounds behind the
    stable time step. Computed by :func:`_row_sums` with the same values, bit for bit,
    as the absolute row sums of :func:`element_stiffness` (every documented result
    depends on them through the mass scaling), at a fraction of its time: that
    function's three-operand ``einsum`` took 10 s a call on the 100 mm cube's 962,131
    tetrahedra.
    """
    m, k, d = grad.shape
    pairs = np.array(shear_pairs(d), dtype=np.int64)
    return _row_sums(np.ascontiguousarray(grad, dtype=float),
                     np.ascontiguousarray(measure, dtype=float),
                     np.ascontiguousarray(lam, dtype=float),
                     np.ascontiguousarray(mu, dtype=float), pairs).reshape(m, k, d)


@njit(cache=True, parallel=True)
def _row_sums(grad, measure, lam, mu, pairs):
    """The reference's arithmetic in its order: ``einsum`` sums the products
    (B_ia D_ij) B_jc over i, then j; numpy's sum over a row adds fewer than 8 values
    in turn and 8 or more pairwise in blocks of 8, then the rest in turn.

    Each element's B and D are written out once, and each row keeps only its nonzero
    products B_ia D_ij, in that order (a zero product adds nothing to a sum): d + 2
    terms an entry in 3D instead of the whole double loop.
    """
    m, k, d = grad.shape
    kd = k * d
    n = d * (d + 1) // 2
    out = np.empty((m, kd))
    for e in prange(m):
        b = np.zeros((n, kd))
        for node in range(k):
            for i in range(d):
                b[i, node * d + i] = grad[e, node, i]
            for s in range(n - d):
                p, q = pairs[s, 0], pairs[s, 1]
                b[d + s, node * d + p] = grad[e, node, q]
                b[d + s, node * d + q] = grad[e, node, p]
        dm = np.zeros((n, n))
        for i in range(d):
            for j in range(d):
                dm[i, j] = lam[e] + 2 * mu[e] if i == j else lam[e]
        for i in range(d, n):
            dm[i, i] = mu[e]
        factor = np.empty(n * n)
        row = np.empty(n * n, dtype=np.int64)
        v = np.empty(kd)
        for a in range(kd):
            terms = 0
            for i in range(n):
                if b[i, a] == 0.0:
                    continue
                for j in range(n):
                    t = b[i, a] * dm[i, j]
                    if t != 0.0:
                        factor[terms] = t
                        row[terms] = j
                        terms += 1
            for c in range(kd):
                s = 0.0
                for t in range(terms):
                    s += factor[t] * b[row[t], c]
                v[c] = abs(s * measure[e])
            if kd < 8:
                total = 0.0
                for c in range(kd):
                    total += v[c]
            else:
                total = ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))
                for c in range(8, kd):
                    total += v[c]
            out[e, a] = total
    return out


def element_stiffness(grad: np.ndarray, measure: np.ndarray, lam: np.ndarray,
                      mu: np.ndarray) -> np.ndarray:
    """Element stiffness matrices ``(m, K d, K d)`` (N/m)."""
    b = strain_displacement(grad)
    dmat = elasticity_matrix(lam, mu, grad.shape[2])
    return np.einsum("mia,mij,mjb->mab", b, dmat, b) * measure[:, None, None]


def element_for_dimension(dimension: int) -> ModuleType:
    """The element module of a dimension: :mod:`.triangle` (2) or :mod:`.tetrahedron` (3)."""
    from grainfrac.physics.elements import tetrahedron, triangle

    if dimension == 2:
        return triangle
    if dimension == 3:
        return tetrahedron
    raise ValueError(f"dimension must be 2 or 3, got {dimension}")
