"""SI tables of a recipe: per-mineral and per-pair arrays that the kernels index by
mineral id and by mineral-pair id (:func:`pair_index`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainfrac.materials.recipes import RockRecipe
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA

__all__ = [
    "ContactTable",
    "MineralTable",
    "contact_table",
    "mineral_table",
    "pair_index",
]


@dataclass(frozen=True)
class MineralTable:
    """Per-mineral block properties in SI, indexed by mineral id (recipe order)."""

    names: tuple[str, ...]
    codes: tuple[str, ...]
    youngs_modulus_Pa: np.ndarray
    poisson_ratio: np.ndarray
    density_kg_m3: np.ndarray
    volume_fraction: np.ndarray  # 0..1, sums to 1

    @property
    def n_minerals(self) -> int:
        """Number of minerals."""
        return len(self.names)


@dataclass(frozen=True)
class ContactTable:
    """Per-pair contact properties in SI, indexed by pair id (:func:`pair_index`)."""

    pair_names: tuple[str, ...]
    normal_stiffness_Pa_per_m: np.ndarray
    shear_stiffness_Pa_per_m: np.ndarray
    friction_angle_rad: np.ndarray
    cohesion_Pa: np.ndarray
    tensile_strength_Pa: np.ndarray
    tensile_fracture_energy_J_per_m2: np.ndarray
    shear_fracture_energy_J_per_m2: np.ndarray


def _frozen(values: list[float]) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    array.flags.writeable = False
    return array


def mineral_table(recipe: RockRecipe) -> MineralTable:
    """Resolve a recipe's minerals into SI arrays.

    Parameters
    ----------
    recipe : RockRecipe

    Returns
    -------
    MineralTable
        Read-only float64 arrays of length ``len(recipe.minerals)``; volume
        fractions are renormalised to sum exactly to 1.
    """
    minerals = recipe.minerals
    percent = np.array([m.volume_percent for m in minerals], dtype=np.float64)
    return MineralTable(
        names=tuple(m.name for m in minerals),
        codes=tuple(m.code for m in minerals),
        youngs_modulus_Pa=_frozen([m.youngs_modulus_GPa * GPA for m in minerals]),
        poisson_ratio=_frozen([m.poisson_ratio for m in minerals]),
        density_kg_m3=_frozen([m.density_kg_m3 for m in minerals]),
        volume_fraction=_frozen(list(percent / percent.sum())),
    )


def contact_table(recipe: RockRecipe) -> ContactTable:
    """Resolve a recipe's contact properties into SI arrays, one entry per pair id.

    Mixed pairs not given in the recipe take the arithmetic mean of the two like
    pairs (paper Table 2).

    Parameters
    ----------
    recipe : RockRecipe

    Returns
    -------
    ContactTable
        Read-only float64 arrays of length ``n (n + 1) / 2`` in the order of
        ``recipe.pair_names()``.
    """
    names = recipe.pair_names()
    props = [recipe.contact(name) for name in names]
    kn = [p.normal_stiffness_GPa_per_m * GPA_PER_M for p in props]
    ks = [p.shear_stiffness_GPa_per_m * GPA_PER_M for p in props]
    return ContactTable(
        pair_names=tuple(names),
        normal_stiffness_Pa_per_m=_frozen(kn),
        shear_stiffness_Pa_per_m=_frozen(ks),
        friction_angle_rad=_frozen([p.friction_angle_deg * DEG for p in props]),
        cohesion_Pa=_frozen([p.cohesion_MPa * MPA for p in props]),
        tensile_strength_Pa=_frozen([p.tensile_strength_MPa * MPA for p in props]),
        tensile_fracture_energy_J_per_m2=_frozen(
            [p.tensile_fracture_energy_J_per_m2 for p in props]),
        shear_fracture_energy_J_per_m2=_frozen([p.shear_fracture_energy_J_per_m2 for p in props]),
    )


def pair_index(mineral_a: np.ndarray, mineral_b: np.ndarray, n_minerals: int) -> np.ndarray:
    """Symmetric pair id of two mineral ids (vectorised).

    The pair ``(i, j)`` with ``i <= j`` gets the id of its position in
    ``(0,0), (0,1), ..., (0,n-1), (1,1), (1,2), ..., (n-1,n-1)``, i.e.
    ``i*n - i*(i-1)/2 + (j - i)``; ``pair_index(a, b) == pair_index(b, a)``.
    :meth:`RockRecipe.pair_names` and :class:`ContactTable` use the same order.

    Parameters
    ----------
    mineral_a, mineral_b : array_like of int
        Mineral ids in ``[0, n_minerals)``, broadcastable.
    n_minerals : int
        Number of minerals in the recipe.

    Returns
    -------
    numpy.ndarray of intp
        Pair ids in ``[0, n (n + 1) / 2)``.

    Raises
    ------
    ValueError
        If an id lies outside ``[0, n_minerals)``.
    """
    a = np.asarray(mineral_a, dtype=np.intp)
    b = np.asarray(mineral_b, dtype=np.intp)
    if a.size and (a.min() < 0 or a.max() >= n_minerals):
        raise ValueError(f"mineral ids must lie in [0, {n_minerals})")
    if b.size and (b.min() < 0 or b.max() >= n_minerals):
        raise ValueError(f"mineral ids must lie in [0, {n_minerals})")
    i = np.minimum(a, b)
    j = np.maximum(a, b)
    return i * n_minerals - (i * (i - 1)) // 2 + (j - i)
