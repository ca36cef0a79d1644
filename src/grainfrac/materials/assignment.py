"""Placing a recipe on an assembly: minerals over grains (the RDP method) and the
contacts that start as fissures.
"""

from __future__ import annotations

import numpy as np

from grainfrac.errors import ConfigError

__all__ = [
    "assign_minerals",
    "select_fissures",
]


def assign_minerals(
    grain_areas: np.ndarray, volume_fraction: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Assign a mineral to every grain so that area (volume) fractions meet targets.

    Random Distribution of Properties (RDP, Wang et al. 2022a): grains are
    visited in random order; each gets a mineral drawn with probability
    proportional to that mineral's remaining positive deficit
    (target area - assigned area). If no mineral has a deficit left, the grain
    goes to the mineral whose relative overshoot after adding it is smallest.
    A final greedy pass then moves single grains between minerals while that
    reduces the sum of squared area errors (typically a handful of grains),
    so the realised fractions land within about one small grain of target.
    Minerals with a zero target are never assigned.

    Parameters
    ----------
    grain_areas : array_like of float, shape (n_grains,)
        Grain areas (2D) or volumes (3D), positive.
    volume_fraction : array_like of float, shape (n_minerals,)
        Target fractions, non-negative, summing to 1 (renormalised).
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray of intp, shape (n_grains,)
        Mineral id of each grain.

    Raises
    ------
    ValueError
        If areas are not positive or fractions are negative / all zero.
    """
    areas = np.asarray(grain_areas, dtype=np.float64)
    fractions = np.asarray(volume_fraction, dtype=np.float64)
    if areas.ndim != 1 or np.any(~np.isfinite(areas)) or np.any(areas <= 0):
        raise ValueError("grain_areas must be a 1-D array of positive numbers")
    if fractions.ndim != 1 or np.any(fractions < 0) or not fractions.sum() > 0:
        raise ValueError("volume_fraction must be a 1-D array of non-negative numbers, not all 0")
    n_grains, n_minerals = areas.size, fractions.size
    target = fractions / fractions.sum() * areas.sum()
    allowed = target > 0
    assigned = np.zeros(n_minerals)
    mineral = np.empty(n_grains, dtype=np.intp)

    for g in rng.permutation(n_grains):
        deficit = np.clip(target - assigned, 0.0, None)
        total = deficit.sum()
        if total > 0:
            k = int(rng.choice(n_minerals, p=deficit / total))
        else:
            overshoot = np.full(n_minerals, np.inf)
            overshoot[allowed] = (assigned[allowed] + areas[g] - target[allowed]) / target[allowed]
            k = int(np.argmin(overshoot))
        mineral[g] = k
        assigned[k] += areas[g]

    # Greedy polish: move grain g from mineral p to q when it lowers sum(dev**2).
    # Change = 2 a (dev_q - dev_p) + 2 a**2, dev = assigned - target.
    for _ in range(n_grains):
        dev = assigned - target
        gain = 2.0 * areas[:, None] * (dev[None, :] - dev[mineral][:, None]) \
            + 2.0 * areas[:, None] ** 2
        gain[:, ~allowed] = np.inf
        gain[np.arange(n_grains), mineral] = np.inf
        g, q = np.unravel_index(int(np.argmin(gain)), gain.shape)
        if not gain[g, q] < -1e-12 * areas.sum() ** 2:
            break
        assigned[mineral[g]] -= areas[g]
        assigned[q] += areas[g]
        mineral[g] = q
    return mineral


def select_fissures(
    n_contacts: int, fraction: float, eligible: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Choose the contacts that start as fissures (unbonded: c = 0, sigma_T = 0).

    Exactly ``round(fraction * n_contacts)`` contacts are chosen, uniformly at
    random without replacement among the eligible ones; ``fraction`` is a
    fraction of *all* contacts, not of the eligible ones.

    Parameters
    ----------
    n_contacts : int
        Number of contacts.
    fraction : float
        Fissure fraction in ``[0, 1)``.
    eligible : array_like of bool, shape (n_contacts,)
        Contacts that may become fissures (e.g. outside the clear radius around
        the well).
    rng : numpy.random.Generator

    Returns
    -------
    numpy.ndarray of bool, shape (n_contacts,)
        True for fissure contacts.

    Raises
    ------
    ConfigError
        ``fissures.fraction`` out of range or more fissures needed than there
        are eligible contacts.
    """
    if not 0.0 <= fraction < 1.0:
        raise ConfigError("fissures.fraction", f"must be >= 0 and < 1 (got {fraction!r})")
    eligible = np.asarray(eligible, dtype=bool)
    if eligible.shape != (n_contacts,):
        raise ValueError(f"eligible must have shape ({n_contacts},), got {eligible.shape}")
    needed = round(fraction * n_contacts)
    candidates = np.flatnonzero(eligible)
    if needed > candidates.size:
        raise ConfigError(
            "fissures.fraction",
            f"fraction {fraction:g} needs {needed} contacts but only {candidates.size} "
            "lie outside the clear radius",
        )
    chosen = rng.choice(candidates, size=needed, replace=False)
    selected = np.zeros(n_contacts, dtype=bool)
    selected[chosen] = True
    return selected
