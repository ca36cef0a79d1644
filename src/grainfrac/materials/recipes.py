"""Rock recipe schemas: minerals, grain-contact properties, Weibull spread, SCDA.

A recipe is written in the units of the paper's tables (GPa, GPa/m, MPa,
degrees, volume percent). Contact properties are keyed by pair names built from
:data:`MINERAL_CODES` (``"M-F"``); mixed pairs default to the arithmetic mean of
the two like pairs (paper Table 2).
"""

from __future__ import annotations

import math
from typing import Any, Literal

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
from grainfrac.io.config import StrictModel

__all__ = [
    "MINERAL_CODES",
    "ContactProperties",
    "HydraulicSpec",
    "IntragranularSpec",
    "Mineral",
    "RockRecipe",
    "ScdaRecipe",
    "WeibullSpec",
]


MINERAL_CODES: dict[str, str] = {"mica": "M", "feldspar": "F", "quartz": "Q"}
"""Known minerals and the one-letter codes used in pair names (``"M-F"``)."""

_CODE_TO_MINERAL = {code: name for name, code in MINERAL_CODES.items()}


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
