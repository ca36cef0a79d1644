"""The sweep file's schema (``SWEEP.toml``): :class:`SweepConfig` with its
parameter axes (:class:`AxisSpec`) or explicit points (:class:`PointSpec`), and the
summary quantities a sweep can name.
"""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from grainfrac.io.config import StrictModel

__all__ = [
    "GROUPED_QUANTITIES",
    "SCALAR_QUANTITIES",
    "SCALAR_QUANTITIES_3D",
    "AxisSpec",
    "PointSpec",
    "SweepConfig",
]


# summary.json keys (docs/outputs.md), in table order.
SCALAR_QUANTITIES = (
    "breakdown_pressure_MPa", "breakdown_time_s", "peak_well_pressure_MPa",
    "peak_expansive_pressure_MPa", "injected_volume_ml", "n_grains", "n_elements",
    "n_contacts", "n_cracks", "n_tensile_cracks", "n_shear_cracks", "tensile_shear_ratio",
    "n_radial_fractures", "fracture_extent_mm", "tortuosity", "energy_tensile_J",
    "energy_shear_J", "energy_friction_J", "in_situ_unbalanced_force_ratio",
)
# summary.json keys of 3D runs only: valid quantities, tabled when a run has them.
SCALAR_QUANTITIES_3D = (
    "n_radial_fractures_top", "n_radial_fractures_mid", "tortuosity_top", "fracture_area_m2",
    "tensile_area_m2", "shear_area_m2",
)
# Dict-valued summary keys whose numeric entries become "<key>.<entry>" quantities.
GROUPED_QUANTITIES = ("contact_fraction_total", "contact_fraction_failed", "energy_balance_J")


_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


def _flatten_set(values: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"stress": {"case": "case1"}}`` and ``{"stress.case": "case1"}`` alike -> dotted paths."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out.update(_flatten_set(value, path + "."))
        else:
            out[path] = value
    return out


class AxisSpec(StrictModel):
    """One varied parameter: a dotted scenario path and its values."""

    path: str = Field(min_length=1, description="dotted path into the scenario, e.g. stress.case")
    values: list[Any] = Field(min_length=1, description="values, in order")
    labels: list[str] | None = Field(
        None, description="names of the values in point ids (empty: left out of the id)")

    @model_validator(mode="after")
    def _labels(self) -> AxisSpec:
        if self.labels is not None and len(self.labels) != len(self.values):
            raise ValueError(f"labels: need one per value ({len(self.values)}) "
                             f"(got {len(self.labels)})")
        return self


class PointSpec(StrictModel):
    """One explicit sweep point: an id, optionally its own base, and the paths it sets."""

    id: str | None = Field(None, description="point id (directory name)")
    base: str | dict[str, Any] | None = Field(None, description="scenario file or table")
    set: dict[str, Any] = Field(default_factory=dict, description="dotted path -> value")

    @field_validator("set")
    @classmethod
    def _dotted(cls, value: dict[str, Any]) -> dict[str, Any]:
        return _flatten_set(value)


def _known_quantity(name: str) -> bool:
    if name in SCALAR_QUANTITIES or name in SCALAR_QUANTITIES_3D:
        return True
    group, _, entry = name.partition(".")
    return group in GROUPED_QUANTITIES and bool(entry)


class SweepConfig(StrictModel):
    """``SWEEP.toml``: a base scenario, the points and the realisations per point."""

    name: str = Field("sweep", description="sweep name")
    base: str | dict[str, Any] = Field(description="scenario file (relative to the sweep "
                                       "file) or an inline scenario table")
    set: dict[str, Any] = Field(default_factory=dict,
                                description="dotted path -> value, applied at every point")
    parameters: list[AxisSpec] = Field(default_factory=list, description="varied parameters")
    combine: Literal["grid", "zip"] = Field("grid", description="grid or zip of parameters")
    points: list[PointSpec] = Field(default_factory=list, description="explicit points")
    realisations: int | None = Field(None, ge=1, le=100_000,
                                     description="realisations per point (default 1)")
    seeds: list[int] | None = Field(None, min_length=1, description="explicit seeds")
    quantities: list[str] | None = Field(
        None, min_length=1, description="summary values to aggregate (default: all)")
    retries: int = Field(2, ge=0, le=100, description="Dask retries of a failing task")

    @field_validator("set")
    @classmethod
    def _dotted(cls, value: dict[str, Any]) -> dict[str, Any]:
        return _flatten_set(value)

    @model_validator(mode="after")
    def _check(self) -> SweepConfig:
        if self.parameters and self.points:
            raise ValueError("points: give parameters or points, not both")
        paths = [axis.path for axis in self.parameters]
        for i, path in enumerate(paths):
            if path in paths[:i]:
                raise ValueError(f"parameters.{i}.path: {path!r} is varied twice")
            if path in self.set:
                raise ValueError(f"parameters.{i}.path: {path!r} is also fixed in set")
        if self.combine == "zip":
            n = len(self.parameters[0].values) if self.parameters else 0
            for i, axis in enumerate(self.parameters):
                if len(axis.values) != n:
                    raise ValueError(f"parameters.{i}.values: combine = \"zip\" needs as many "
                                     f"values as parameters.0 ({n}) (got {len(axis.values)})")
        ids = [p.id for p in self.points if p.id is not None]
        for i, point in enumerate(self.points):
            if point.id is not None and not _ID.match(point.id):
                raise ValueError(f"points.{i}.id: letters, digits, '.', '_' and '-' only, "
                                 f"starting with a letter or digit (got {point.id!r})")
            if point.id is not None and ids.count(point.id) > 1:
                raise ValueError(f"points.{i}.id: {point.id!r} is used twice")
        if self.seeds is not None:
            for i, seed in enumerate(self.seeds):
                if seed < 0:
                    raise ValueError(f"seeds.{i}: must be >= 0 (got {seed})")
                if seed in self.seeds[:i]:
                    raise ValueError(f"seeds.{i}: seed {seed} is listed twice")
            if self.realisations is not None and self.realisations != len(self.seeds):
                raise ValueError(f"realisations: {self.realisations} does not match the "
                                 f"{len(self.seeds)} listed seeds (give one of them)")
        for i, name in enumerate(self.quantities or []):
            if not _known_quantity(name):
                raise ValueError(
                    f"quantities.{i}: unknown quantity {name!r}; known: "
                    + ", ".join(SCALAR_QUANTITIES + SCALAR_QUANTITIES_3D)
                    + ", or <group>.<entry> of " + ", ".join(GROUPED_QUANTITIES))
        return self

    @property
    def n_realisations(self) -> int:
        return len(self.seeds) if self.seeds is not None else (self.realisations or 1)
