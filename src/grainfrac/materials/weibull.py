"""Weibull heterogeneity of micro-properties (paper Eq. 4): the multipliers and the
bounded draws, and which grain and contact properties get them.
"""

from __future__ import annotations

import math

import numpy as np

from grainfrac.errors import ConfigError
from grainfrac.materials.recipes import WeibullSpec

__all__ = [
    "WEIBULL_CONTACT_PROPERTIES",
    "WEIBULL_GRAIN_PROPERTIES",
    "WEIBULL_UPPER_BOUNDS",
    "weibull_draw",
    "weibull_multipliers",
]


WEIBULL_GRAIN_PROPERTIES: tuple[str, ...] = ("youngs_modulus_Pa", "poisson_ratio", "density_kg_m3")
""":class:`MineralTable` fields that get an independent Weibull multiplier per grain."""

WEIBULL_CONTACT_PROPERTIES: tuple[str, ...] = (
    "normal_stiffness_Pa_per_m",
    "shear_stiffness_Pa_per_m",
    "friction_angle_rad",
    "cohesion_Pa",
    "tensile_strength_Pa",
)
""":class:`ContactTable` fields that get an independent Weibull multiplier per contact.

The friction multiplier applies to the friction *angle* (not to its tangent).
"""

WEIBULL_UPPER_BOUNDS: dict[str, float] = {"poisson_ratio": 0.5,
                                          "friction_angle_rad": 0.5 * math.pi}
"""Bounds a drawn property must stay below: the Weibull is truncated there
(:func:`weibull_draw`). A wide spread (shape 2) draws mica grains with
nu > 0.5, whose elements blow up, and friction angles past 90 deg."""


def weibull_draw(base: np.ndarray, rng: np.random.Generator, spec: WeibullSpec,
                 upper: float | None = None) -> np.ndarray:
    """``base`` times :func:`weibull_multipliers`, kept below ``upper``.

    Entries at or above ``upper`` are drawn again (from the same stream, after
    the first draw) until they fall below it: the Weibull truncated at the
    bound. Draws that are valid at once are exactly those of the plain product,
    so a truncation that never acts changes nothing.

    Raises
    ------
    ConfigError
        When 1000 redraws do not fall below ``upper`` (``base`` far past it).
    """
    base = np.asarray(base, dtype=np.float64)
    x = base * weibull_multipliers(rng, len(base), spec)
    if upper is None:
        return x
    for _ in range(1000):
        bad = np.flatnonzero(x >= upper)
        if len(bad) == 0:
            return x
        x[bad] = base[bad] * weibull_multipliers(rng, len(bad), spec)
    raise ConfigError("weibull.shape", f"{spec.shape:g} spreads a value of {base.max():g} "
                      f"past its bound {upper:g} in 1000 draws; use a larger shape")


def weibull_multipliers(
    rng: np.random.Generator, size: int | tuple[int, ...], spec: WeibullSpec
) -> np.ndarray:
    """Independent Weibull multipliers for micro-properties (paper Eq. 4).

    ``x ~ Weibull(scale, shape)`` with CDF ``F(x) = 1 - exp(-(x/scale)**shape)``.

    * ``spec.table_value == "scale"`` (default, as the paper: scale 1, shape 7):
      the multipliers are returned as drawn, i.e. the table value is the Weibull
      scale and the realised mean of a property is
      ``scale * Gamma(1 + 1/shape)`` (~0.935 for scale 1, shape 7) times its
      table value.
    * ``spec.table_value == "mean"``: the draws are divided by the distribution
      mean ``scale * Gamma(1 + 1/shape)``, so the realised mean of the property
      equals its table value (multiplier mean 1, same coefficient of variation).

    The caller draws one independent set per property in
    :data:`WEIBULL_GRAIN_PROPERTIES` (per grain) and
    :data:`WEIBULL_CONTACT_PROPERTIES` (per contact).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness (made from the run's seed).
    size : int or tuple of int
        Shape of the output.
    spec : WeibullSpec
        Scale, shape and meaning of the table value.

    Returns
    -------
    numpy.ndarray of float64
        Positive multipliers of shape ``size``.
    """
    x = spec.scale * rng.weibull(spec.shape, size)
    if not spec.enabled:
        return np.ones(size)
    if spec.table_value == "mean":
        x /= spec.scale * math.gamma(1.0 + 1.0 / spec.shape)
    return x
