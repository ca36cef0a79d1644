"""The calibration targets file (``grainfrac calibrate TARGETS.toml``): the
laboratory targets, the factors and the quantity each one is paired with, the
realisations and the search budget.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import Field, field_validator, model_validator

from grainfrac import materials
from grainfrac.assembly import GrainSpec
from grainfrac.io.config import StrictModel, read_toml, source_path, validate
from grainfrac.labtests.config import LAB_GRAINS

__all__ = [
    "FACTORS",
    "MEASURED",
    "PAIRING",
    "REPORTED",
    "STRENGTHS",
    "TEST_OF",
    "FactorName",
    "TargetName",
    "CalibrationConfig",
    "Targets",
    "load_calibration_config",
]


FACTORS = ("stiffness", "shear_ratio", "grain_poisson_ratio", "strength", "tensile_strength",
           "cohesion", "friction", "fracture_energy", "shear_fracture_energy",
           "grain_tensile_strength", "grain_cohesion", "strength_scale")
# Target quantity, the lab test that measures it, and the sign of d log(target) / d log(factor).
PAIRING = {
    "stiffness": ("youngs_modulus_GPa", "ucs", +1.0),
    "shear_ratio": ("poisson_ratio", "ucs", -1.0),
    "grain_poisson_ratio": ("poisson_ratio", "ucs", +1.0),
    "strength": ("bts_MPa", "bts", +1.0),
    "tensile_strength": ("bts_MPa", "bts", +1.0),
    "cohesion": ("ucs_MPa", "ucs", +1.0),
    "friction": ("ucs_MPa", "ucs", +1.0),
    "fracture_energy": ("kic_MPa_sqrt_m", "nscb", +1.0),
    "shear_fracture_energy": ("ucs_MPa", "ucs", +1.0),
    "grain_tensile_strength": ("kic_MPa_sqrt_m", "nscb", +1.0),
    "grain_cohesion": ("ucs_MPa", "ucs", +1.0),
    "strength_scale": ("ucs_MPa", "ucs", +1.0),
}
FactorName = Literal["stiffness", "shear_ratio", "grain_poisson_ratio", "strength",
                     "tensile_strength", "cohesion", "friction", "fracture_energy",
                     "shear_fracture_energy", "grain_tensile_strength", "grain_cohesion",
                     "strength_scale"]
TargetName = Literal["ucs_MPa", "bts_MPa", "kic_MPa_sqrt_m", "youngs_modulus_GPa",
                     "poisson_ratio"]
# The lab test that measures each calibrated target.
TEST_OF = {"ucs_MPa": "ucs", "youngs_modulus_GPa": "ucs", "poisson_ratio": "ucs",
           "bts_MPa": "bts", "kic_MPa_sqrt_m": "nscb"}
REPORTED = ("ucs_MPa", "bts_MPa", "kic_MPa_sqrt_m", "youngs_modulus_GPa", "poisson_ratio",
            "permeability_m2")
MEASURED = tuple(k for k in REPORTED if k != "permeability_m2")  # by the platen tests
STRENGTHS = ("ucs_MPa", "bts_MPa", "kic_MPa_sqrt_m")


class Targets(StrictModel):
    """Laboratory values to reproduce (defaults: paper Table 3 and Sect. 3.2)."""

    ucs_MPa: float = Field(120.94, gt=0, description="uniaxial compressive strength [MPa]")
    bts_MPa: float = Field(6.38, gt=0, description="Brazilian tensile strength [MPa]")
    kic_MPa_sqrt_m: float = Field(
        1.35, gt=0, description="fracture toughness K_IC from the NSCB test [MPa m^0.5]")
    youngs_modulus_GPa: float = Field(17.13, gt=0, description="Young's modulus E [GPa]")
    poisson_ratio: float = Field(0.24, gt=0, lt=0.5, description="Poisson's ratio nu [-]")
    permeability_m2: float = Field(
        1.0e-19, gt=0, description="intact permeability, constant-head test [m2]")


class CalibrationConfig(StrictModel):
    """``grainfrac calibrate TARGETS.toml``: what to match, from where, how hard to try."""

    name: str = Field("calibrated-rock", description="name of the calibrated recipe")
    rock: str | materials.RockRecipe = Field("strathbogie-granite", description="start recipe")
    targets: Targets = Field(default_factory=Targets, description="laboratory values to match")
    seeds: list[int] = Field(default_factory=lambda: [0, 1, 2], min_length=1,
                             description="grain realisations averaged per evaluation")
    validation_seeds: list[int] = Field(
        default_factory=list,
        description="held-out realisations on which the calibrated recipe is measured too "
                    "(none by default); they must differ from seeds")
    grains: GrainSpec = Field(default_factory=lambda: GrainSpec(**LAB_GRAINS),
                              description="grain size and mesh of the lab specimens")
    dimension: Literal[2, 3] = Field(
        2, description="2: plane-strain sections of the lab specimens; 3: the Table 3 "
                       "specimens as solids (minutes per test and realisation)")
    tolerance: float = Field(0.02, gt=0, lt=0.5,
                             description="stop when every calibrated mean is this close")
    max_evaluations: int = Field(
        16, ge=1, le=200, description="root-finder evaluations at most")
    factors: list[FactorName] | dict[FactorName, TargetName] = Field(
        default_factory=lambda: ["stiffness", "tensile_strength", "cohesion"], min_length=1,
        description="factors to solve for, each with its default target (list) or the "
                    "target given (table); the others keep their start value")
    start: dict[FactorName, float] = Field(
        default_factory=dict, description="starting value of each factor (default 1)")
    workers: int | None = Field(None, ge=1, le=64, description="processes (default: cores)")
    shear_to_tensile_fracture_energy: float = Field(
        10.0, ge=0, le=1000,
        description="G_II / G_I when fracture_energy starts from a brittle recipe")

    @field_validator("factors", mode="before")
    @classmethod
    def _known_targets(cls, factors: Any) -> Any:
        if isinstance(factors, dict):
            for factor, target in factors.items():
                if target not in TEST_OF:
                    raise ValueError(f"factors.{factor} = {target!r}: the target must be one of "
                                     + ", ".join(TEST_OF))
        return factors

    @field_validator("factors")
    @classmethod
    def _unique(cls, factors: list[str] | dict[str, str]) -> list[str] | dict[str, str]:
        if isinstance(factors, list) and len(set(factors)) != len(factors):
            raise ValueError("each factor may be listed once")
        solver_of: dict[str, str] = {}
        for factor, target in _pairs(factors).items():
            if target in solver_of:
                raise ValueError(f"{solver_of[target]} and {factor} both solve for {target}: "
                                 "keep one")
            solver_of[target] = factor
        return factors

    @field_validator("seeds", "validation_seeds")
    @classmethod
    def _distinct(cls, seeds: list[int]) -> list[int]:
        if any(seed < 0 for seed in seeds):
            raise ValueError(f"seeds must be >= 0 (got {seeds})")
        if len(set(seeds)) != len(seeds):
            raise ValueError(f"each seed may be listed once (got {seeds})")
        return seeds

    @model_validator(mode="after")
    def _held_out(self) -> CalibrationConfig:
        shared = sorted(set(self.seeds) & set(self.validation_seeds))
        if shared:
            raise ValueError(f"validation_seeds: must differ from seeds (both hold {shared})")
        return self

    @field_validator("start")
    @classmethod
    def _positive(cls, start: dict[str, float]) -> dict[str, float]:
        for factor, value in start.items():
            if not (0.0 < value < 1e3):
                raise ValueError(f"start.{factor} = {value} must be in (0, 1000)")
        return start

    def pairing(self) -> dict[str, str]:
        """Factor -> target it is solved for, in the module's factor order."""
        pairs = _pairs(self.factors)
        return {name: pairs[name] for name in FACTORS if name in pairs}

    def recipe(self, base_dir: Path | None = None) -> materials.RockRecipe:
        if isinstance(self.rock, materials.RockRecipe):
            return self.rock
        path = source_path(self.rock, base_dir)
        return materials.load_recipe(path if path is not None else self.rock)


def _pairs(factors: list[str] | dict[str, str]) -> dict[str, str]:
    if isinstance(factors, dict):
        return dict(factors)
    return {factor: PAIRING[factor][0] for factor in factors}


def load_calibration_config(path: str | Path) -> tuple[CalibrationConfig, materials.RockRecipe]:
    """Read a TARGETS.toml file and its starting recipe (one-line error on bad input)."""
    path = Path(path)
    config = validate(CalibrationConfig, read_toml(path))
    return config, config.recipe(path.parent)
