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
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_serializer,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from grainfrac.errors import ConfigError
from grainfrac.io.config import StrictModel, load_toml, validate
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA

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

MINERAL_CODES: dict[str, str] = {"mica": "M", "feldspar": "F", "quartz": "Q"}
"""Known minerals and the one-letter codes used in pair names (``"M-F"``)."""

_CODE_TO_MINERAL = {code: name for name, code in MINERAL_CODES.items()}

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


# --------------------------------------------------------------------------- schemas


class Mineral(StrictModel):
    """One mineral phase of a rock recipe (paper Table 2, block properties)."""

    name: str = Field(description="mineral name: one of " + ", ".join(MINERAL_CODES))
    density_kg_m3: float = Field(gt=0, description="grain density [kg/m3]")
    youngs_modulus_GPa: float = Field(gt=0, description="Young's modulus of the grain [GPa]")
    poisson_ratio: float = Field(gt=-1, lt=0.5, description="Poisson's ratio of the grain [-]")
    volume_percent: float = Field(ge=0, le=100, description="target volume fraction [%]")

    @field_validator("name", mode="before")
    @classmethod
    def _known_mineral(cls, value: Any) -> Any:
        if isinstance(value, str):
            key = value.strip().lower()
            if key in MINERAL_CODES:
                return key
        raise ValueError("unknown mineral; allowed: " + ", ".join(MINERAL_CODES))

    @property
    def code(self) -> str:
        """One-letter code of the mineral (``"M"``, ``"F"``, ``"Q"``)."""
        return MINERAL_CODES[self.name]


class ContactProperties(StrictModel):
    """Grain-contact (interface) properties (paper Table 2 / Table 5, contacts)."""

    normal_stiffness_GPa_per_m: float = Field(gt=0, description="normal stiffness kn [GPa/m]")
    shear_stiffness_GPa_per_m: float = Field(gt=0, description="shear stiffness ks [GPa/m]")
    friction_angle_deg: float = Field(ge=0, lt=90, description="friction angle phi [deg]")
    cohesion_MPa: float = Field(ge=0, description="cohesion c [MPa]")
    tensile_strength_MPa: float = Field(ge=0, description="tensile strength sigma_T [MPa]")
    tensile_fracture_energy_J_per_m2: float = Field(
        default=0.0, ge=0, le=1.0e4,
        description="mode-I fracture energy G_I of linear softening [J/m2]; 0: brittle "
                    "(the paper's Coulomb slip joint)")
    shear_fracture_energy_J_per_m2: float = Field(
        default=0.0, ge=0, le=1.0e5,
        description="mode-II fracture energy G_II of linear softening [J/m2]; 0: brittle")

    @classmethod
    def mean(cls, a: ContactProperties, b: ContactProperties) -> ContactProperties:
        """Arithmetic mean of two contact property sets (paper Table 2 mixed-pair rule)."""
        da, db = a.model_dump(), b.model_dump()
        return cls(**{key: 0.5 * (da[key] + db[key]) for key in da})


class WeibullSpec(StrictModel):
    """Weibull heterogeneity of micro-properties (paper Eq. 4).

    ``table_value = "scale"`` (default, as the paper): the table value is the
    Weibull scale, realised mean = Gamma(1 + 1/shape) x table value (0.935 for
    shape 7). ``"mean"``: multipliers are normalised to mean 1.
    """

    scale: float = Field(default=1.0, gt=0, description="Weibull scale lambda of multipliers")
    shape: float = Field(default=7.0, gt=0, description="Weibull shape k of multipliers")
    table_value: Literal["scale", "mean"] = Field(
        default="scale", description="whether table values are the Weibull scale or the mean"
    )
    enabled: bool = Field(default=True, description="false: no scatter (homogeneous checks)")


class HydraulicSpec(StrictModel):
    """Hydraulic property of the intact grain boundaries (paper Sect. 3.2, Table 4).

    ``initial_aperture_m`` is a0, the aperture of an unloaded intact grain
    boundary, calibrated to the intact permeability by the constant-head test.
    Scenarios use it unless their ``fluid.initial_aperture_m`` is given.
    """

    initial_aperture_m: float = Field(default=2.0e-7, gt=0, lt=3.0e-5,
                                      description="initial hydraulic aperture a0 [m]")


class IntragranularSpec(StrictModel):
    """Breakable grains: every zone of a grain is a block of its own (UDEC's Trigon).

    The contacts between blocks of one grain take the like pair's properties
    (``Q-Q`` inside a quartz grain) times these factors, with their own Weibull
    draws; friction is the like pair's. Without this section grains never break
    (the paper's model: intergranular cracks only). In 2D, unbreakable grains
    lock up in compression: the split columns of a UCS specimen carry on
    without a peak at the friction that the lab's UCS / BTS asks for.
    """

    tensile_strength_factor: float = Field(gt=0, le=100, description=(
        "grain-interior tensile strength / the like pair's [-]"))
    cohesion_factor: float = Field(gt=0, le=100, description=(
        "grain-interior cohesion / the like pair's [-]"))
    stiffness_factor: float = Field(default=1.0, gt=0, le=1000, description=(
        "grain-interior kn and ks / the like pair's [-]"))
    fracture_energy_factor: float = Field(default=1.0, ge=0, le=100, description=(
        "grain-interior G_I and G_II / the like pair's [-]"))


def _pair_error(key: str, message: str, value: Any) -> ValidationError:
    """A ValidationError located at ``<field>.<key>`` (pydantic prefixes the field)."""
    return ValidationError.from_exception_data(
        "contacts",
        [InitErrorDetails(type=PydanticCustomError("contact_pair", message), loc=(key,),
                          input=value)],
    )


class RockRecipe(StrictModel):
    """A rock: its minerals, grain-contact properties and Weibull heterogeneity.

    ``contacts`` maps pair names built from :data:`MINERAL_CODES` (``"M-M"``,
    ``"F-Q"``...) to :class:`ContactProperties`. Every like pair of each mineral
    in the recipe is required; mixed pairs are optional and default to the mean
    of the two like pairs. Keys are normalised to the canonical order of
    :meth:`pair_names` (``"Q-F"`` becomes ``"F-Q"`` for a mica, feldspar,
    quartz recipe).
    """

    name: str = Field(description="recipe name")
    minerals: list[Mineral] = Field(min_length=1, description="mineral phases")
    contacts: dict[str, ContactProperties] = Field(description="contact properties per pair")
    weibull: WeibullSpec = Field(default_factory=WeibullSpec, description="Weibull draws")
    hydraulic: HydraulicSpec = Field(default_factory=HydraulicSpec,
                                     description="intact grain-boundary aperture")
    intragranular: IntragranularSpec | None = Field(
        default=None, description="breakable grains (none: grains never break)")

    @model_serializer(mode="wrap")
    def _without_absent_sections(self, handler: Any) -> dict[str, Any]:
        # TOML has no null: a recipe without breakable grains dumps as before.
        data = handler(self)
        if data.get("intragranular") is None:
            data.pop("intragranular", None)
        return data

    @field_validator("minerals")
    @classmethod
    def _check_minerals(cls, minerals: list[Mineral]) -> list[Mineral]:
        names = [m.name for m in minerals]
        duplicated = sorted({n for n in names if names.count(n) > 1})
        if duplicated:
            repeated = ", ".join(duplicated)
            raise ValueError(f"mineral names must be unique (repeated: {repeated})")
        total = math.fsum(m.volume_percent for m in minerals)
        if abs(total - 100.0) > 0.01:
            raise ValueError(f"volume_percent must sum to 100 (got {round(total, 6)!r})")
        return minerals

    @field_validator("contacts")
    @classmethod
    def _check_contacts(
        cls, contacts: dict[str, ContactProperties], info: ValidationInfo
    ) -> dict[str, ContactProperties]:
        minerals = info.data.get("minerals")
        if minerals is None:  # minerals invalid: that error is reported instead
            return contacts
        order = [MINERAL_CODES[m.name] for m in minerals]
        present = ", ".join(order)
        normalised: dict[str, ContactProperties] = {}
        for key, props in contacts.items():
            parts = key.strip().upper().replace("\u2013", "-").split("-")
            if len(parts) != 2 or not all(p in _CODE_TO_MINERAL for p in parts):
                known = ", ".join(f"{c} ({n})" for n, c in MINERAL_CODES.items())
                raise _pair_error(key, f"pair must be two mineral codes like 'F-Q'; codes: {known}",
                                  key)
            missing = [p for p in parts if p not in order]
            if missing:
                raise _pair_error(key, f"mineral {_CODE_TO_MINERAL[missing[0]]} is not in the "
                                  f"recipe (codes present: {present})", key)
            a, b = sorted(parts, key=order.index)
            canonical = f"{a}-{b}"
            if canonical in normalised:
                raise _pair_error(key, f"pair given twice (as {canonical} too)", key)
            normalised[canonical] = props
        for code in order:
            like = f"{code}-{code}"
            if like not in normalised:
                raise _pair_error(
                    like,
                    f"missing like-pair contact properties for {_CODE_TO_MINERAL[code]}; "
                    "like pairs are required (mixed pairs default to their mean)",
                    contacts,
                )
        canonical_order = _pair_names(order)
        return {name: normalised[name] for name in canonical_order if name in normalised}

    def mineral_index(self, name: str) -> int:
        """Index of mineral ``name`` in :attr:`minerals` (the mineral id used in arrays).

        Raises
        ------
        ConfigError
            If the recipe has no such mineral.
        """
        key = name.strip().lower()
        for i, mineral in enumerate(self.minerals):
            if mineral.name == key:
                return i
        allowed = ", ".join(m.name for m in self.minerals)
        raise ConfigError("minerals", f"recipe {self.name!r} has no mineral {name!r} "
                          f"(has: {allowed})")

    def pair_names(self) -> list[str]:
        """Pair names in canonical pair-id order (see :func:`pair_index`).

        Built from the codes in mineral order: for mica, feldspar, quartz that is
        ``["M-M", "M-F", "M-Q", "F-F", "F-Q", "Q-Q"]``.
        """
        return _pair_names([m.code for m in self.minerals])

    def contact(self, pair: str) -> ContactProperties:
        """Contact properties of a pair (either order), mixed pairs resolved by the mean rule."""
        parts = pair.strip().upper().replace("\u2013", "-").split("-")
        if len(parts) != 2 or any(p not in _CODE_TO_MINERAL for p in parts):
            raise ConfigError("contacts", f"unknown pair {pair!r}")
        codes = [m.code for m in self.minerals]
        for p in parts:
            if p not in codes:
                raise ConfigError("contacts", f"unknown pair {pair!r} for recipe {self.name!r}")
        a, b = sorted(parts, key=codes.index)
        key = f"{a}-{b}"
        if key in self.contacts:
            return self.contacts[key]
        return ContactProperties.mean(self.contacts[f"{a}-{a}"], self.contacts[f"{b}-{b}"])


class ScdaRecipe(StrictModel):
    """The soundless cracking demolition agent as a block material (paper Table 5)."""

    name: str = Field(description="material name")
    density_kg_m3: float = Field(gt=0, description="density [kg/m3]")
    youngs_modulus_GPa: float = Field(gt=0, description="Young's modulus [GPa]")
    poisson_ratio: float = Field(gt=-1, lt=0.5, description="Poisson's ratio [-]")
    contact: ContactProperties = Field(
        description="contact properties between SCDA elements (paper Table 5)")
    wall_contact: ContactProperties | None = Field(
        None, description="SCDA-rock contact properties; default: the SCDA contact's "
                          "stiffnesses, no friction, cohesion or tensile strength")

    @model_validator(mode="before")
    @classmethod
    def _default_wall(cls, data: Any) -> Any:
        """The paper gives no SCDA-rock properties (Table 5 lists the SCDA's own
        contacts). By default the interface carries pressure only, as the
        pressurised borehole of SCDA analyses does: a bond or friction there
        holds radial crack mouths shut (see ``docs/architecture.md``). Filled in
        here, so a written recipe says what was used."""
        if isinstance(data, dict) and data.get("wall_contact") is None and "contact" in data:
            contact = data["contact"]
            if isinstance(contact, BaseModel):
                contact = contact.model_dump()
            if isinstance(contact, dict):
                data = {**data, "wall_contact": {
                    **contact, "friction_angle_deg": 0.0, "cohesion_MPa": 0.0,
                    "tensile_strength_MPa": 0.0, "tensile_fracture_energy_J_per_m2": 0.0,
                    "shear_fracture_energy_J_per_m2": 0.0}}
        return data

    def wall_contact_properties(self) -> ContactProperties:
        """The SCDA-rock interface (never None after validation)."""
        assert self.wall_contact is not None
        return self.wall_contact


def _pair_names(codes: list[str] | tuple[str, ...]) -> list[str]:
    n = len(codes)
    return [f"{codes[i]}-{codes[j]}" for i in range(n) for j in range(i, n)]


# --------------------------------------------------------------------------- presets


def _preset_dir():
    return resources.files("grainfrac").joinpath("presets")


def _preset_data() -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    directory = _preset_dir()
    if not directory.is_dir():
        return out
    for entry in directory.iterdir():
        if entry.name.endswith(".toml") and entry.is_file():
            stem = entry.name[: -len(".toml")]
            try:
                out[stem] = tomllib.loads(entry.read_text(encoding="utf-8"))
            except tomllib.TOMLDecodeError as exc:
                raise ConfigError(f"presets/{entry.name}", f"invalid TOML: {exc}") from None
    return out


def preset_names(kind: Literal["rock", "scda"] = "rock") -> list[str]:
    """Names of the packaged presets, sorted.

    Parameters
    ----------
    kind : {"rock", "scda"}
        ``"rock"`` (default) lists :class:`RockRecipe` presets (for
        :func:`load_recipe`), ``"scda"`` lists :class:`ScdaRecipe` presets (for
        :func:`load_scda`).

    Returns
    -------
    list of str
    """
    key = "minerals" if kind == "rock" else "contact"
    return sorted(name for name, data in _preset_data().items() if key in data)


def _load(model: type, source: str | Path, kind: Literal["rock", "scda"], field: str):
    if isinstance(source, str):
        presets = preset_names(kind)
        if source in presets:
            return validate(model, _preset_data()[source], prefix=f"presets/{source}.toml")
        looks_like_path = source.endswith(".toml") or "/" in source or "\\" in source
        if not looks_like_path and not Path(source).is_file():
            raise ConfigError(field, f"unknown preset {source!r}; presets: {', '.join(presets)} "
                              "(or give the path of a .toml file)")
    return load_toml(model, Path(source))


def load_recipe(source: str | Path) -> RockRecipe:
    """Load a rock recipe from a preset name or a TOML file.

    Parameters
    ----------
    source : str or Path
        A preset name (see :func:`preset_names`, e.g. ``"strathbogie-granite"``)
        or the path of a TOML file with the :class:`RockRecipe` schema.

    Returns
    -------
    RockRecipe

    Raises
    ------
    ConfigError
        Unknown preset (the message lists the presets), missing file, invalid
        TOML or a value out of range (the field is named).
    """
    return _load(RockRecipe, source, "rock", "recipe")


def load_scda(source: str | Path = "scda") -> ScdaRecipe:
    """Load the SCDA material from a preset name (default ``"scda"``) or a TOML file.

    Parameters
    ----------
    source : str or Path
        Preset name (see ``preset_names("scda")``) or path of a TOML file with
        the :class:`ScdaRecipe` schema.

    Returns
    -------
    ScdaRecipe

    Raises
    ------
    ConfigError
        As :func:`load_recipe`.
    """
    return _load(ScdaRecipe, source, "scda", "scda")


# --------------------------------------------------------------------------- SI tables


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


# --------------------------------------------------------------------------- random draws


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


def homogeneous_recipe(
    mineral: str = "quartz",
    stiffness_factor: float = 100.0,
    unbreakable: bool = True,
    base: str = "strathbogie-granite",
) -> RockRecipe:
    """A one-mineral rock without scatter, for verification against continuum solutions.

    Parameters
    ----------
    mineral
        Mineral of every grain (its Table 2 properties are used).
    stiffness_factor
        Multiplier on the like-pair contact stiffnesses, so the contacts add
        negligible compliance to the grains.
    unbreakable
        Give the contacts strengths far above any stress a test applies.
    base
        Preset the mineral and contact properties are taken from.
    """
    source = load_recipe(base)
    chosen = source.minerals[source.mineral_index(mineral)]
    code = chosen.code
    contact = source.contact(f"{code}-{code}")
    strength = 1.0e9 if unbreakable else None  # MPa
    props = contact.model_dump()
    props["normal_stiffness_GPa_per_m"] *= stiffness_factor
    props["shear_stiffness_GPa_per_m"] *= stiffness_factor
    if strength is not None:
        props["cohesion_MPa"] = strength
        props["tensile_strength_MPa"] = strength
    return RockRecipe.model_validate({
        "name": f"homogeneous-{mineral}",
        "minerals": [{**chosen.model_dump(), "volume_percent": 100.0}],
        "contacts": {f"{code}-{code}": props},
        "weibull": {"enabled": False},
    })
