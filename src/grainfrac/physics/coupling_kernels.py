"""Compiled kernels of the coupling's host work (numba, CPU).

A coupled step reads the contacts' openings, turns the pore apertures into pipe
conductances, assembles the pipes' Laplacian and finds the grains with no bond left,
every fluid step, on the host. On the
GPU backend the host does this while the device waits: on the 100 mm cube it was most
of a fluid step's time (``benchmarks/pressure_solve.py --mechanics-steps 1``). Each
kernel does the arithmetic of the numpy expression it replaces, in the same order, so
results are the same to the last bit (the tests compare them).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def contact_openings(u, contact_nodes, contact_normal):
    """Per sub-contact, ``sum_k (u[b, k] - u[a, k]) n[k]`` with ``(a, b)`` its nodes: the
    normal opening (m), summed over the components in order as ``np.sum(..., axis=1)``
    does for so few terms."""
    n, d = contact_nodes.shape[0], u.shape[1]
    out = np.empty(n)
    for c in range(n):
        a, b = contact_nodes[c, 0], contact_nodes[c, 1]
        total = (u[b, 0] - u[a, 0]) * contact_normal[c, 0]
        for k in range(1, d):
            total += (u[b, k] - u[a, k]) * contact_normal[c, k]
        out[c] = total
    return out


@njit(cache=True)
def mean_hydraulic_apertures(aperture, maximum_aperture, pipe_contacts, pipe_index):
    """Per pipe ``pipe_index[p]``, the mean of its two end sub-contacts' apertures, each
    capped at ``maximum_aperture`` (m)."""
    out = np.empty(pipe_index.shape[0])
    for p in range(pipe_index.shape[0]):
        i = pipe_index[p]
        first = np.minimum(aperture[pipe_contacts[i, 0]], maximum_aperture)
        second = np.minimum(aperture[pipe_contacts[i, 1]], maximum_aperture)
        out[p] = 0.5 * (first + second)
    return out


@njit(cache=True)
def laplacian_data(conductance, order, slot, n_slots):
    """The stored values of a pipe Laplacian of known pattern: entry ``order[e]`` of the
    list ``(C, C, -C, -C)`` (each pipe on its two diagonals, then its two off-diagonal
    places) added into ``slot[e]``, in the order of ``e``, as ``np.bincount`` adds."""
    n_pipes = conductance.shape[0]
    data = np.zeros(n_slots)
    for e in range(order.shape[0]):
        entry = order[e]
        value = conductance[entry % n_pipes]
        data[slot[e]] += value if entry < 2 * n_pipes else -value
    return data


@njit(cache=True)
def on_loose_grain(contact_grains, bonded, n_grains):
    """Per sub-contact, whether either of its grains (``contact_grains[c]``) has no
    bonded sub-contact left among those listed (``bonded``, the first ``len(bonded)``)."""
    held = np.zeros(n_grains, dtype=np.bool_)
    for c in range(bonded.shape[0]):
        if bonded[c]:
            held[contact_grains[c, 0]] = True
            held[contact_grains[c, 1]] = True
    out = np.empty(contact_grains.shape[0], dtype=np.bool_)
    for c in range(contact_grains.shape[0]):
        out[c] = not (held[contact_grains[c, 0]] and held[contact_grains[c, 1]])
    return out
