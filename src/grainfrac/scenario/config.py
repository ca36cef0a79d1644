"""The :class:`Scenario` itself: specimen, in-situ stress, fluid, stages, numerics
and output, and the checks across them (stage order, borehole, sides, sizes).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, model_validator

from grainfrac import materials
from grainfrac.assembly import FissureSpec, GrainSpec, SpecimenConfig, with_3d_slab_thickness
from grainfrac.errors import ConfigError
from grainfrac.geometry.specimens import HollowCylinderSpec, SlabSpec, SpecimenShapeSpec
from grainfrac.io.config import StrictModel, validate
from grainfrac.scenario.fluid import SPECIMEN_SIDES, FluidSpec
from grainfrac.scenario.numerics import NumericsSpec
from grainfrac.scenario.output import OutputSpec
from grainfrac.scenario.sizes import check_size
from grainfrac.scenario.stages import BOREHOLE_STAGES, ScdaStage, Stage, _stage_entry_errors
from grainfrac.scenario.stress import _STRESSABLE_SHAPES, InSituStress

__all__ = [
    "Scenario",
]


class Scenario(StrictModel):
    """A complete run: specimen, in-situ stress, fluid, stages and output.

    The specimen part (``seed``, ``rock``, ``specimen``, ``grains``,
    ``fissures``) has the schema and defaults of a specimen file.
    """

    name: str = Field("scenario", description="run name")
    seed: int = Field(0, ge=0, description="random seed of grains, minerals, Weibull draws")
    dimension: Literal[2, 3] = Field(
        2, description="2: plane-strain slice (triangles); 3: polyhedral grains (tetrahedra), "
        "the slab a box with the borehole along z through its thickness")
    rock: str | materials.RockRecipe = Field("strathbogie-granite", description="rock recipe")
    specimen: SpecimenShapeSpec = Field(
        default_factory=SlabSpec,
        description="specimen: a slab, rectangle or hollow cylinder, chosen by `shape`")
    grains: GrainSpec = Field(default_factory=GrainSpec, description="grain size and mesh")
    fissures: FissureSpec = Field(default_factory=FissureSpec,
                                  description="pre-existing unbonded grain boundaries")
    stress: InSituStress = Field(default_factory=InSituStress,
                                 description="far-field in-situ stress (paper Table 6)")
    fluid: FluidSpec = Field(default_factory=FluidSpec,
                             description="fluid, apertures and permeable sides")
    stages: list[Stage] = Field(min_length=1, description="stages, run in order")
    numerics: NumericsSpec = Field(default_factory=NumericsSpec,
                                   description="damping and mass scaling")
    output: OutputSpec = Field(default_factory=OutputSpec,
                               description="snapshot and checkpoint intervals")

    @model_validator(mode="before")
    @classmethod
    def _check_stage_entries(cls, data: Any) -> Any:
        data = with_3d_slab_thickness(data)
        data = _shape_permeable_sides(data)
        if isinstance(data, dict) and isinstance(data.get("stages"), list):
            # Every stage's problems at once, one line each.
            problems = [line for index, stage in enumerate(data["stages"])
                        for line in _stage_entry_errors(index, stage)]
            if problems:
                raise ValueError("\n".join(problems))
        return data

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        try:
            check_size(self.specimen_config())
        except ConfigError as exc:
            raise ValueError("\n".join(f"{f}: {m}" for f, m in exc.problems)) from None
        self._check_borehole()
        self._check_order()
        if self.dimension == 3:
            self._check_3d()
        shape = self.specimen.shape
        if shape not in _STRESSABLE_SHAPES:
            raise ValueError(
                f"specimen.shape: a scenario needs a slab, rectangle or hollow cylinder (the "
                f"in-situ stress acts on its sides) (got {shape!r})"
            )
        sides = SPECIMEN_SIDES[shape]
        for side in self.fluid.permeable_sides:
            if side not in sides:
                raise ValueError(
                    f"fluid.permeable_sides: unknown side {side!r}; sides of a {shape}: "
                    + ", ".join(sides)
                )
        return self

    def _check_borehole(self) -> None:
        spec = self.specimen
        for i, stage in enumerate(self.stages):
            if stage.kind not in BOREHOLE_STAGES:
                continue
            if not isinstance(spec, SlabSpec | HollowCylinderSpec):
                raise ValueError(
                    f"stages.{i}.kind: {stage.kind} needs a specimen with a borehole (a slab "
                    f"with borehole_diameter_mm > 0 or a hollow cylinder); the specimen is a "
                    f"{spec.shape}"
                )
            if spec.borehole_diameter_mm <= 0:
                raise ValueError(
                    f"specimen.borehole_diameter_mm: must be > 0 for the {stage.kind} stage "
                    f"(stages.{i}) (got {spec.borehole_diameter_mm:g})"
                )

    def _check_3d(self) -> None:
        """What a 3D scenario must say."""
        stress = self.stress
        if stress.case is None and stress.sigma_z_MPa is None:
            raise ValueError("stress.sigma_z_MPa: required in 3D without a case (the stress "
                             "along the borehole axis; paper Table 6: 1 MPa in every case)")
        if self.specimen.shape == "hollow_cylinder" and not math.isclose(
                stress.sigma_x_MPa, stress.sigma_y_MPa, rel_tol=1e-12, abs_tol=1e-12):
            raise ValueError(
                f"stress.sigma_y_MPa: a hollow cylinder's lateral surface takes one confining "
                f"pressure, so sigma_y_MPa must equal sigma_x_MPa ({stress.sigma_x_MPa:g}), "
                f"got {stress.sigma_y_MPa:g}")

    def _check_order(self) -> None:
        scda_at: int | None = None
        drilled_at: int | None = None
        injected_at: int | None = None
        for i, stage in enumerate(self.stages):
            kind = stage.kind
            where = f"stages.{i}.kind: "
            if i == 0 and kind != "equilibrate":
                raise ValueError(
                    where + f"{kind} must come after equilibrate (the first stage must be "
                    "equilibrate: in-situ stress before any stimulation)"
                )
            if kind == "equilibrate" and i > 0:
                raise ValueError(
                    where + "equilibrate must be the first stage only (the in-situ stress is "
                    "applied once, before any stimulation)"
                )
            if kind == "scda":
                if scda_at is not None:
                    raise ValueError(where + f"only one scda stage is allowed "
                                     f"(stages.{scda_at} is scda)")
                if injected_at is not None:
                    raise ValueError(where + f"scda must come before any inject stage "
                                     f"(stages.{injected_at} injects)")
                scda_at = i
            elif kind == "drill_out":
                if scda_at is None:
                    raise ValueError(where + "drill_out must come after an scda stage "
                                     "(there is no SCDA to drill out)")
                if drilled_at is not None:
                    raise ValueError(where + f"the SCDA was drilled out already "
                                     f"(stages.{drilled_at})")
                drilled_at = i
            elif kind == "inject":
                if scda_at is not None and drilled_at is None:
                    raise ValueError(
                        where + f"inject must come after drill_out (the SCDA of "
                        f"stages.{scda_at} still fills the borehole)"
                    )
                injected_at = i

    # -- views ---------------------------------------------------------------------------

    @property
    def stage_kinds(self) -> tuple[str, ...]:
        return tuple(stage.kind for stage in self.stages)

    def specimen_config(self) -> SpecimenConfig:
        """The geometry and material part, for :func:`grainfrac.assembly.build_assembly`."""
        return validate(SpecimenConfig, {
            "seed": self.seed, "dimension": self.dimension, "rock": self.rock,
            "specimen": self.specimen,
            "grains": self.grains, "fissures": self.fissures,
        })

    def recipe(self, base_dir: Path | None = None) -> materials.RockRecipe:
        """The rock recipe: inline, a preset name, or a TOML path relative to ``base_dir``."""
        return self.specimen_config().recipe(base_dir)

    def with_seed(self, seed: int) -> Scenario:
        """The same scenario with another seed (``grainfrac run --seed N``)."""
        return validate(Scenario, {**dict(self), "seed": seed})

    def resolved(self, recipe: materials.RockRecipe, base_dir: Path | None = None) -> Scenario:
        """The same scenario with the rock and every SCDA material written inline."""
        stages = []
        for i, stage in enumerate(self.stages):
            if isinstance(stage, ScdaStage):
                stage = stage.model_copy(update={"scda": _scda_material(stage, i, base_dir)})
            stages.append(stage)
        # The apertures in use: the rock's calibrated a0 unless the fluid section sets one.
        props = self.fluid.properties(recipe.hydraulic.initial_aperture_m)
        fluid = self.fluid.model_copy(update={"initial_aperture_m": props.initial_aperture,
                                              "residual_aperture_m": props.residual_aperture})
        return validate(Scenario, {**dict(self), "rock": recipe, "stages": stages,
                                   "fluid": fluid})


def _shape_permeable_sides(data: Any) -> Any:
    """The fluid boundary defaults to every named side of the specimen's shape
    (:data:`SPECIMEN_SIDES`: a slab's four sides, a hollow cylinder's lateral surface); a
    list given in the file is kept as it is."""
    if isinstance(data, dict):
        spec = data.get("specimen", {})
        fluid = data.get("fluid", {})
        shape = spec.get("shape", "slab") if isinstance(spec, dict) else None
        if shape in SPECIMEN_SIDES and isinstance(fluid, dict) \
                and "permeable_sides" not in fluid:
            data = {**data, "fluid": {**fluid, "permeable_sides": list(SPECIMEN_SIDES[shape])}}
    return data


def _scda_material(stage: ScdaStage, index: int, base_dir: Path | None) -> materials.ScdaRecipe:
    try:
        return stage.material(base_dir)
    except ConfigError as exc:
        field = f"stages.{index}.scda"
        if exc.field not in ("scda", field):
            field = f"{field} ({exc.field})"
        raise ConfigError(field, exc.message) from None
