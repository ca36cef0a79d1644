"""Rock recipes: minerals, grain-contact tables, Weibull draws, mineral maps, fissures.

A *recipe* says what a rock is made of, in the units of the paper's tables
(GPa, GPa/m, MPa, degrees, volume percent). :func:`mineral_table` and
:func:`contact_table` resolve it once into frozen records of SI arrays
(Pa, Pa/m, rad, kg/m3, fractions) that the kernels index by mineral id and by
mineral-pair id (:func:`pair_index`).

Presets shipped with the package (``grainfrac/presets/*.toml``):

* ``strathbogie-granite`` -- paper Table 2 (mica, feldspar, quartz);
* ``scda`` -- paper Table 5, the expansive agent (:func:`load_scda`).

Contact properties of mixed mineral pairs default to the arithmetic mean of the
two like pairs (paper Table 2), e.g. ``kn(M-F) = (kn(M-M) + kn(F-F)) / 2``.

Weibull heterogeneity (paper Eq. 4)
-----------------------------------
Every grain and contact micro-property listed in :data:`WEIBULL_GRAIN_PROPERTIES`
and :data:`WEIBULL_CONTACT_PROPERTIES` is multiplied by its own independent
sample ``x ~ Weibull(scale, shape)``, ``F(x) = 1 - exp(-(x/scale)**shape)``,
drawn by :func:`weibull_multipliers`. The paper uses ``scale = 1`` and
``shape = 7`` and treats the table value as the Weibull *scale*: that is the
default here (``table_value = "scale"``), so the **realised mean of a property is
Gamma(1 + 1/7) ~= 0.935 times its table value**. With ``table_value = "mean"``
the multipliers are divided by their distribution mean, so the realised mean
equals the table value.

Mineral maps and fissures
-------------------------
:func:`assign_minerals` distributes minerals over grains by the Random
Distribution of Properties (RDP) method so that the area (2D) or volume (3D)
fractions meet their targets; :func:`select_fissures` picks the contacts that
start unbonded.

The package's modules, one job each:

* ``materials.recipes``: the recipe schemas (minerals, contacts, Weibull,
  hydraulic, breakable grains, SCDA);
* ``materials.presets``: preset names, loading recipes from presets or TOML files;
* ``materials.tables``: the SI tables of a recipe and the mineral-pair index;
* ``materials.weibull``: the Weibull multipliers and bounded draws;
* ``materials.assignment``: minerals over grains and the fissure selection.

Every public name is importable from ``grainfrac.materials`` itself.
"""

from __future__ import annotations

from grainfrac.materials.assignment import assign_minerals, select_fissures
from grainfrac.materials.presets import (
    homogeneous_recipe as homogeneous_recipe,
)
from grainfrac.materials.presets import (
    load_recipe,
    load_scda,
    preset_names,
)
from grainfrac.materials.recipes import (
    MINERAL_CODES,
    ContactProperties,
    IntragranularSpec,
    Mineral,
    RockRecipe,
    ScdaRecipe,
    WeibullSpec,
)
from grainfrac.materials.recipes import HydraulicSpec as HydraulicSpec
from grainfrac.materials.tables import (
    ContactTable,
    MineralTable,
    contact_table,
    mineral_table,
    pair_index,
)
from grainfrac.materials.weibull import (
    WEIBULL_CONTACT_PROPERTIES,
    WEIBULL_GRAIN_PROPERTIES,
    weibull_draw,
    weibull_multipliers,
)
from grainfrac.materials.weibull import WEIBULL_UPPER_BOUNDS as WEIBULL_UPPER_BOUNDS

__all__ = [
    "MINERAL_CODES",
    "WEIBULL_CONTACT_PROPERTIES",
    "WEIBULL_GRAIN_PROPERTIES",
    "ContactProperties",
    "ContactTable",
    "IntragranularSpec",
    "Mineral",
    "MineralTable",
    "RockRecipe",
    "ScdaRecipe",
    "WeibullSpec",
    "assign_minerals",
    "contact_table",
    "load_recipe",
    "load_scda",
    "mineral_table",
    "pair_index",
    "preset_names",
    "select_fissures",
    "weibull_draw",
    "weibull_multipliers",
]
