"""The explicit stable step a tetrahedral mesh allows at each node, from its shape alone.

The central-difference step is bounded per node by ``2 sqrt(m_i / K_i)``, with ``m_i``
the node's lumped mass (a quarter of each tetrahedron around it) and ``K_i`` the
Gershgorin bound of its stiffness rows (absolute row sums of the element stiffness
matrices, the bound the mechanics uses). For one isotropic material both scale out, so
the ratio of a node's step to that of a free regular tetrahedron measures the mesh
alone: a node whose ratio is 0.3 forces a step 0.3 x as long as a regular zone would.
The mesher uses it to find and mend the few nodes that would set a whole run's step.
"""

from __future__ import annotations

import functools

import numpy as np

# Lame constants of the reference material (nu = 0.25: lambda = mu); the ratio depends
# on nu only weakly, and not on E or the density.
_LAME = 1.0


def _row_bound_over_mass(x: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Per node: largest Gershgorin row bound over the lumped mass (unit E scale and
    density); NaN for nodes no tetrahedron uses."""
    p = x[tets]
    jac = np.stack((p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]), axis=2)
    volume = np.linalg.det(jac) / 6.0
    g = np.empty((len(tets), 4, 3))
    g[:, 1:, :] = np.linalg.inv(jac)
    g[:, 0, :] = -g[:, 1:, :].sum(axis=1)
    # K_ab,ij = V (lambda g_ai g_bj + mu g_aj g_bi + mu delta_ij g_a . g_b)
    outer = np.einsum("mai,mbj->maibj", g, g)
    k = _LAME * (outer + outer.transpose(0, 1, 4, 3, 2)
                 + np.einsum("ij,mab->maibj", np.eye(3), np.einsum("mak,mbk->mab", g, g)))
    rows = np.abs(k).sum(axis=(3, 4)) * np.abs(volume)[:, None, None]
    bound = np.zeros((len(x), 3))
    np.add.at(bound, tets, rows)
    mass = np.zeros(len(x))
    np.add.at(mass, tets, np.repeat(np.abs(volume)[:, None] / 4.0, 4, axis=1))
    out = np.full(len(x), np.nan)
    used = mass > 0
    out[used] = bound[used].max(axis=1) / mass[used]
    return out


def regular_tetrahedron(edge: float) -> np.ndarray:
    """Corners (4, 3) of a regular tetrahedron of the given edge, right-handed."""
    h = edge
    return np.array([[0, 0, 0], [h, 0, 0], [h / 2, h * np.sqrt(3) / 2, 0],
                     [h / 2, h * np.sqrt(3) / 6, h * np.sqrt(2 / 3)]])


def node_step_ratio(x: np.ndarray, tets: np.ndarray, zone_size: float) -> np.ndarray:
    """Each node's stable step over that of a free regular tetrahedron of edge
    ``zone_size`` (same material); NaN where no tetrahedron uses the node.

    Parameters
    ----------
    x : np.ndarray
        (n, 3) node positions (m).
    tets : np.ndarray
        (m, 4) tetrahedra (either orientation).
    zone_size : float
        Edge of the reference tetrahedron (m).
    """
    return np.sqrt(_reference_bound(float(zone_size)) / _row_bound_over_mass(x, tets))


@functools.lru_cache(maxsize=64)
def _reference_bound(zone_size: float) -> float:
    """Row bound over mass of a free regular tetrahedron (the mesher asks once per
    piece and per trial, with a handful of zone sizes)."""
    return float(np.nanmax(_row_bound_over_mass(regular_tetrahedron(zone_size),
                                                np.array([[0, 1, 2, 3]]))))
