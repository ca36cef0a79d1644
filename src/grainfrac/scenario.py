"""Scenario files: specimen, in-situ stress, fluid and the sequence of stages of a run.

A scenario is what ``grainfrac run SCENARIO.toml`` executes: the specimen part
(the same ``seed``, ``rock``, ``specimen``, ``grains`` and ``fissures`` as a
specimen file, see :class:`grainfrac.assembly.SpecimenConfig`), the in-situ
stress (paper Table 6), the fluid (paper Table 4) and a list of stages:

``equilibrate``
    apply the far-field stresses and equilibrate (always the first stage);
``scda``
    charge the borehole with SCDA expanding at ``v = f exp(-b t)`` (paper
    Eq. 9, Table 5) until the expansive pressure reaches its peak or ``v``
    decays below ``min_velocity_fraction x f``;
``drill_out``
    remove the SCDA from the borehole and let the rock relax;
``inject``
    inject fluid at a constant rate into the well (XLOT: injection continues
    past breakdown) for ``duration_ms`` and/or until ``volume_ml`` is injected.

The paper's designs are ``[equilibrate, scda]`` (SCDA charging, Sect. 5.1),
``[equilibrate, inject]`` (HS, Sect. 5.2-5.6) and
``[equilibrate, scda, drill_out, inject]`` (the hybrid method, Sect. 6).

Units are the field's (MPa, mm, ml/min, ms); in-situ stresses are compressive
magnitudes as in the paper. Every problem is reported before any compute as a
one-line :class:`~grainfrac.errors.ConfigError` naming the field, e.g.
``config error at stages.1.kind: inject must come after drill_out ...``.

Example::

    scenario, recipe = load_scenario("examples/hybrid-case2-90mlmin.toml")
    assembly = build_assembly(scenario.specimen_config(), recipe)
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, model_validator

from grainfrac import materials
from grainfrac.assembly import FissureSpec, GrainSpec, SpecimenConfig
from grainfrac.errors import ConfigError
from grainfrac.geometry.specimens import SlabSpec, SpecimenShapeSpec
from grainfrac.io.config import StrictModel, read_toml, source_path, validate
from grainfrac.io.files import write_toml
from grainfrac.loading.insitu import STRESS_CASES
from grainfrac.physics.flow import FluidProperties
from grainfrac.units import GPA, ML, ML_PER_MIN, MPA

StressCase = Literal["case1", "case2", "case3", "case4"]

# Named sides of each specimen shape that can be made permeable (the borehole is the well).
SPECIMEN_SIDES: dict[str, tuple[str, ...]] = {
    "slab": ("left", "right", "top", "bottom"),
    "rectangle": ("left", "right", "top", "bottom"),
    "disk": ("perimeter",),
    "semi_disk": ("arc", "base"),
}
# Shapes the far-field stress of an ``equilibrate`` stage can act on (left/right/top/bottom).
_STRESSABLE_SHAPES = ("slab", "rectangle")

# Headline HS design: 90 ml/min on the default slab breaks down ~5 ms after injection
# starts (tests/test_flow.py, README figure). The hybrid's pressure does not fall at
# once: seed 0 peaks at 9.37 MPa 4.7 ms in, holds within 5 % of it (multiple peaks,
# paper Fig. 17d) until 9.2 ms, then falls gradually (7.74 MPa at 12 ms), so 12 ms
# covers build-up, breakdown and propagation of both. Pressurisation time scales
# with 1 / rate.
DEFAULT_RATE_ML_PER_MIN = 90.0
DEFAULT_INJECT_DURATION_MS = 12.0

# Limits checked before anything is built, so that a mistyped size fails at once
# instead of hanging or running out of memory (issue 42: ``zone_size_mm = 0.01``,
# ``duration_ms = 1e300``).
# Elements per zone area: measured 2.22 (default slab, 5562 elements at 2 mm zones)
# and 2.23 (the same slab at 0.5 mm zones, 89326 elements).
ELEMENTS_PER_ZONE_AREA = 2.25
# The assembly and mechanical model took 1.2-2.0 kB of memory per element (measured
# at those two sizes), so this is 6-10 GB before the run's own arrays.
MAX_ELEMENTS = 5_000_000
# 3D: tetrahedra per zone volume (zone_size_mm cubed), measured 8.6 (30 x 30 x 20 mm slab,
# 10 mm borehole, 2 mm zones, 17692 tets), 8.0 (the same at 1.5 mm, 38741 tets) and 7.8
# (40 x 40 x 20 mm, no borehole, 2 mm, 31223 tets); 9 bounds them.
TETS_PER_ZONE_VOLUME = 9.0
# 3D meshing is done grain by grain in Python (about 15000 tets a second here) and a
# tetrahedron carries more state than a triangle (4 nodes of 3 components): 2e6 tets
# are some minutes of meshing and a few GB before the run's own arrays.
MAX_ELEMENTS_3D = 2_000_000
# Simulated time of one stage: 10 s is 7e7 mechanical steps of the default slab
# (1.394e-7 s each); the paper's stages last 60 ms at most.
MAX_STAGE_MS = 10_000.0
# The borehole must be this many zones across: a 1 mm borehole at 2 mm zones could not
# be meshed and 0.5 mm crashed the SCDA plug's mesh; 2 mm (one zone) still meshed.
BOREHOLE_MIN_ZONES = 2.0


def default_inject_duration_ms(rate_ml_per_min: float) -> float:
    """Default injection duration (ms): 12 ms at 90 ml/min, scaled as 1 / rate.

    At 90 ml/min the default slab (case 2) breaks down about 4-5 ms after the
    start of injection; the well pressurises in proportion to the injected
    volume, so a lower rate needs proportionally longer (18 ml/min: 60 ms).
    This is a first guess that passes breakdown, not a calibrated duration.
    """
    if not rate_ml_per_min > 0:
        raise ConfigError("rate_ml_per_min", f"must be > 0 (got {rate_ml_per_min!r})")
    return DEFAULT_INJECT_DURATION_MS * DEFAULT_RATE_ML_PER_MIN / rate_ml_per_min


# --------------------------------------------------------------------------- in-situ stress


class InSituStress(StrictModel):
    """Far-field principal stresses in the slab plane, compressive magnitudes in MPa.

    Give either a ``case`` of paper Table 6 (default ``"case2"``: sigma_x 2.5,
    sigma_y 5 MPa) or both ``sigma_x_MPa`` and ``sigma_y_MPa``. After
    validation the values are always filled in (from the case when one is
    given). Giving a case together with values that differ from it is an
    error: nothing overrides anything silently.
    """

    case: StressCase | None = Field("case2", description="paper Table 6 stress case")
    sigma_x_MPa: float | None = Field(None, ge=0, description="compressive stress along x [MPa]")
    sigma_y_MPa: float | None = Field(None, ge=0, description="compressive stress along y [MPa]")

    @model_validator(mode="before")
    @classmethod
    def _values_mean_no_case(cls, data: Any) -> Any:
        # The default case applies only when no values are given.
        if isinstance(data, dict) and "case" not in data and (
            data.get("sigma_x_MPa") is not None or data.get("sigma_y_MPa") is not None
        ):
            data = {**data, "case": None}
        return data

    @model_validator(mode="after")
    def _resolve(self) -> InSituStress:
        given = {"sigma_x_MPa": self.sigma_x_MPa, "sigma_y_MPa": self.sigma_y_MPa}
        if self.case is None:
            missing = [k for k, v in given.items() if v is None]
            if missing:
                raise ValueError(
                    f"{missing[0]}: required without a case (give a case of paper Table 6, "
                    "case1..case4, or both sigma_x_MPa and sigma_y_MPa)"
                )
            return self
        sx, sy, _ = STRESS_CASES[self.case]
        table = {"sigma_x_MPa": sx, "sigma_y_MPa": sy}
        conflict = {k: v for k, v in given.items()
                     if v is not None and not math.isclose(v, table[k], rel_tol=1e-12)}
        if conflict:
            got = ", ".join(f"{k} = {v:g}" for k, v in conflict.items())
            raise ValueError(
                f"give either case or sigma_x_MPa and sigma_y_MPa, not both: {self.case} is "
                f"sigma_x_MPa = {sx:g}, sigma_y_MPa = {sy:g} (paper Table 6), got {got}"
            )
        for key, value in table.items():
            object.__setattr__(self, key, float(value))
        self.__pydantic_fields_set__.update(table)
        return self

    def resolved(self) -> tuple[float, float]:
        """``(sigma_x_MPa, sigma_y_MPa)``, compressive magnitudes."""
        assert self.sigma_x_MPa is not None and self.sigma_y_MPa is not None
        return self.sigma_x_MPa, self.sigma_y_MPa

    def resolved_Pa(self) -> tuple[float, float]:
        """``(sigma_x, sigma_y)`` in Pa, compressive magnitudes (for ``initialise_in_situ``)."""
        sx, sy = self.resolved()
        return sx * MPA, sy * MPA


# --------------------------------------------------------------------------- fluid


class FluidSpec(StrictModel):
    """Fluid, hydraulic apertures and fluid boundaries (defaults: water, paper Table 4).

    Hydraulic aperture ``a = clamp(a0 + opening, a_res, a_max)`` with
    ``a_res <= a0 < a_max``. ``permeable_sides`` are held at
    ``boundary_pressure_MPa`` (paper Fig. 9c: the slab edges); the borehole is
    the well. ``well_compressibility_per_GPa`` is the compressibility of the
    well's fluid volume, by default that of water (1 / 2 GPa).
    """

    viscosity_Pa_s: float = Field(1.0e-3, gt=0, description="dynamic viscosity mu [Pa s]")
    bulk_modulus_GPa: float = Field(2.0, gt=0, description="fluid bulk modulus Kw [GPa]")
    initial_aperture_m: float = Field(2.0e-7, gt=0, description="a0 [m]")
    residual_aperture_m: float = Field(2.0e-7, gt=0, description="a_res [m]")
    maximum_aperture_m: float = Field(3.0e-5, gt=0, description="a_max [m]")
    broken_residual_aperture_m: float | None = Field(
        None, gt=0, description="lower bound of the aperture of broken and fissured grain "
        "boundaries [m]; default: residual_aperture_m (paper: one a_res for all)")
    permeable_sides: list[str] = Field(
        default_factory=lambda: list(SPECIMEN_SIDES["slab"]),
        description="specimen sides held at boundary_pressure_MPa",
    )
    boundary_pressure_MPa: float = Field(0.0, ge=0, description="pressure on permeable sides")
    well_compressibility_per_GPa: float = Field(
        0.5, gt=0, description="compressibility of the well fluid volume [1/GPa]"
    )
    well_wall: Literal["wet", "sealed", "flow_knots"] = Field(
        "wet", description="how the well meets the grain boundaries that end on its wall: "
        "'wet' (wall contacts take the well pressure from the start), 'sealed' (pressure on "
        "the wall; a wall contact takes fluid once it cracks), 'flow_knots' (3DEC: fluid "
        "into the wall contacts only, no pressure on the wall)")

    @model_validator(mode="after")
    def _check(self) -> FluidSpec:
        a_res, a0, a_max = self.residual_aperture_m, self.initial_aperture_m, \
            self.maximum_aperture_m
        if a_res > a0:
            raise ValueError(
                f"residual_aperture_m: must be <= initial_aperture_m ({a0:g}) (got {a_res:g})"
            )
        broken = self.broken_residual_aperture_m
        if broken is not None and not a_res <= broken < a_max:
            raise ValueError(
                f"broken_residual_aperture_m: must be in [residual_aperture_m, "
                f"maximum_aperture_m) = [{a_res:g}, {a_max:g}) (got {broken:g})"
            )
        if a0 >= a_max:
            raise ValueError(
                f"initial_aperture_m: must be < maximum_aperture_m ({a_max:g}) (got {a0:g})"
            )
        seen: set[str] = set()
        for side in self.permeable_sides:
            if side in seen:
                raise ValueError(f"permeable_sides: {side!r} is listed twice")
            seen.add(side)
        return self

    def properties(self, rock_initial_aperture_m: float | None = None) -> FluidProperties:
        """The SI fluid properties for the flow solver.

        ``rock_initial_aperture_m`` (the rock recipe's calibrated a0) is used
        when this file does not set ``initial_aperture_m``; an unset residual
        aperture then follows it down if it is smaller.
        """
        a0, a_res = self.initial_aperture_m, self.residual_aperture_m
        unset = self.model_fields_set
        if rock_initial_aperture_m is not None and "initial_aperture_m" not in unset:
            a0 = rock_initial_aperture_m
            if "residual_aperture_m" not in unset:
                a_res = min(a_res, a0)
        return FluidProperties(
            viscosity=self.viscosity_Pa_s,
            bulk_modulus=self.bulk_modulus_GPa * GPA,
            initial_aperture=a0,
            residual_aperture=a_res,
            maximum_aperture=self.maximum_aperture_m,
            broken_residual_aperture=self.broken_residual_aperture_m,
        )

    def fixed_pressures(self) -> dict[str, float]:
        """Side name -> fixed pressure (Pa), for ``build_flow_network(permeable_sides=...)``."""
        return dict.fromkeys(self.permeable_sides, self.boundary_pressure_MPa * MPA)

    @property
    def well_compressibility(self) -> float:
        """Compressibility of the well fluid volume (1/Pa)."""
        return self.well_compressibility_per_GPa / GPA


# --------------------------------------------------------------------------- numerics


class NumericsSpec(StrictModel):
    """Knobs of the explicit mechanics that a converged answer must not hang on.

    ``local_damping`` is the Itasca local (non-viscous) damping coefficient of every
    stage; ``mass_scaling`` the fraction of the mass that mass scaling adds to keep
    the step at the grains' own (1: all of it, 0: real masses, a smaller step).
    """

    local_damping: float = Field(0.8, ge=0, lt=1, description="local damping coefficient")
    mass_scaling: float = Field(
        1.0, ge=0, le=1, description="fraction of the mass scaling's added mass kept "
        "(1: as designed, 0: real masses)")


# --------------------------------------------------------------------------- stages


class EquilibrateStage(StrictModel):
    """Apply the in-situ stress with bonds held elastic and equilibrate (paper Fig. 9b)."""

    kind: Literal["equilibrate"] = Field("equilibrate", description="selects this stage")
    unbalanced_ratio: float = Field(1e-5, gt=0, lt=1, description="target unbalanced-force ratio")
    max_steps: int = Field(300_000, gt=0, description="step limit")


class ScdaStage(StrictModel):
    """SCDA charging: the borehole expands at ``v = f exp(-b t)`` (paper Eq. 9, Sect. 4.1).

    Stops when the expansive pressure on the wall reaches ``peak_pressure_MPa``
    (paper: 45 MPa), when ``v < min_velocity_fraction x f`` or after
    ``max_duration_ms``. ``scda`` is the material (paper Table 5): a preset
    name, the path of a TOML file (relative to the scenario file), or inline.

    Units of f: the paper's f = 1 is in 3DEC's static-mode time, which is not
    physical time. grainfrac's time is physical (mass-scaled quasi-statics), so
    f is a rate, default 5 mm/s: the 45 MPa peak is reached after ~6 ms, a
    pressurisation rate like injection at 90 ml/min, slow enough to stay
    quasi-static and fast enough to run in seconds. b = 20 /s keeps the
    paper's decay; with this f it only matters when fractures stop the
    pressure short of the peak. When the peak ends the charging the result does
    not depend on f (tested: 5 and 20 mm/s give the same cracks). The summary's
    ``scda_stop_reason`` says which end came first: "peak pressure",
    "expansion decayed" or "time limit" (the expansion had not finished;
    measured, default slab, Case 1, seed 3: 267 cracks at the 60 ms limit, 276
    when run on to the decay at 347 ms, same radial fractures and extent).
    """

    kind: Literal["scda"] = Field("scda", description="selects this stage")
    peak_pressure_MPa: float = Field(45.0, gt=0, description="peak expansive pressure [MPa]")
    velocity_scale_mm_per_s: float = Field(5.0, gt=0, description="f of Eq. 9 [mm/s]")
    decay_rate_per_s: float = Field(20.0, gt=0, description="b of Eq. 9 [1/s]")
    min_velocity_fraction: float = Field(1e-3, gt=0, lt=1, description="stop when v < this x f")
    max_duration_ms: float = Field(60.0, gt=0, le=MAX_STAGE_MS, description="time limit [ms]")
    scda: str | materials.ScdaRecipe = Field("scda", description="SCDA material")

    def material(self, base_dir: Path | None = None) -> materials.ScdaRecipe:
        """The SCDA material: inline, a preset name, or a TOML path relative to ``base_dir``."""
        if isinstance(self.scda, materials.ScdaRecipe):
            return self.scda
        path = source_path(self.scda, base_dir)
        return materials.load_scda(path if path is not None else self.scda)

    def velocity(self, t: float) -> float:
        """Expansion velocity (m/s) at time ``t`` (s) since the start of charging (Eq. 9)."""
        return self.velocity_scale_mm_per_s * 1e-3 * math.exp(-self.decay_rate_per_s * t)

    @property
    def decay_time_s(self) -> float:
        """Time (s) at which ``v`` falls to ``min_velocity_fraction x f``."""
        return -math.log(self.min_velocity_fraction) / self.decay_rate_per_s


class DrillOutStage(StrictModel):
    """Remove the SCDA from the borehole (the well is empty again), then relax: at least
    ``relax_steps`` steps, and on until the unbalanced-force ratio is below
    ``unbalanced_ratio`` (or ``max_steps``).

    A fixed step count was not enough on the lab-calibrated 2D rock with 15 %
    fissures (seed 2): after 20,000 steps (2.7 ms) its 150 um SCDA fractures were
    still closing at 0.07 m/s (ratio 0.12) and took another 2.4 ms to shut, so
    the injection started into a collapsing rock.
    """

    kind: Literal["drill_out"] = Field("drill_out", description="selects this stage")
    relax_steps: int = Field(20_000, ge=0, description="mechanical steps after removal, at least")
    unbalanced_ratio: float = Field(1e-5, gt=0, lt=1, description="target unbalanced-force ratio")
    max_steps: int = Field(300_000, gt=0, description="step limit")

    @model_validator(mode="after")
    def _limits(self) -> DrillOutStage:
        if self.max_steps < self.relax_steps:
            raise ValueError(f"max_steps: must be >= relax_steps ({self.relax_steps}) "
                             f"(got {self.max_steps})")
        return self


class InjectStage(StrictModel):
    """Constant-rate injection into the well (XLOT: continues past breakdown).

    Ends after ``duration_ms`` or when ``volume_ml`` has been injected,
    whichever comes first (at least one is required), or earlier when
    ``stop_at_boundary`` and a crack made since injection started reaches the
    specimen's outer boundary (cracks of earlier stages do not count), or
    ``stop_after_breakdown_ms`` after breakdown (for studies of the breakdown
    pressure alone).
    """

    kind: Literal["inject"] = Field("inject", description="selects this stage")
    rate_ml_per_min: float = Field(gt=0, description="injection rate [ml/min]")
    duration_ms: float | None = Field(None, gt=0, le=MAX_STAGE_MS,
                                      description="injection time [ms]")
    volume_ml: float | None = Field(None, gt=0, description="injected volume [ml]")
    time_step_ms: float = Field(0.01, gt=0, description="fluid (coupling) time step [ms]")
    stop_at_boundary: bool = Field(
        True, description="stop when a crack made by the injection reaches the boundary")
    stop_after_breakdown_ms: float | None = Field(
        None, gt=0, le=MAX_STAGE_MS, description="stop this long after breakdown (the well "
        "pressure first 5 % below its peak) [ms]; default: run on")

    @model_validator(mode="after")
    def _ends(self) -> InjectStage:
        if self.duration_ms is None and self.volume_ml is None:
            raise ValueError(
                "duration_ms: give duration_ms or volume_ml (or both: the stage ends at "
                "whichever is reached first)"
            )
        if self.volume_ml is not None and self.volume_ml * ML / self.rate * 1e3 > MAX_STAGE_MS:
            raise ValueError(
                f"volume_ml: must take at most {MAX_STAGE_MS:g} ms at rate_ml_per_min = "
                f"{self.rate_ml_per_min:g}, i.e. <= {MAX_STAGE_MS * 1e-3 * self.rate / ML:g} "
                f"(got {self.volume_ml:g})")
        if self.time_step_ms >= self.planned_duration_s * 1e3:
            raise ValueError(
                f"time_step_ms: must be < the stage duration ({self.planned_duration_s * 1e3:g} "
                f"ms) (got {self.time_step_ms:g})"
            )
        return self

    @property
    def rate(self) -> float:
        """Injection rate (m3/s)."""
        return self.rate_ml_per_min * ML_PER_MIN

    @property
    def time_step(self) -> float:
        """Fluid time step (s)."""
        return self.time_step_ms * 1e-3

    @property
    def planned_duration_s(self) -> float:
        """Duration (s) if nothing stops the stage early: the first of time and volume limits."""
        limits = []
        if self.duration_ms is not None:
            limits.append(self.duration_ms * 1e-3)
        if self.volume_ml is not None:
            limits.append(self.volume_ml * ML / self.rate)
        return min(limits)


Stage = Annotated[
    EquilibrateStage | ScdaStage | DrillOutStage | InjectStage, Field(discriminator="kind")
]
STAGE_MODELS: dict[str, type[StrictModel]] = {
    "equilibrate": EquilibrateStage,
    "scda": ScdaStage,
    "drill_out": DrillOutStage,
    "inject": InjectStage,
}
STAGE_KINDS = tuple(STAGE_MODELS)
# Stages that act on the borehole.
BOREHOLE_STAGES = ("scda", "drill_out", "inject")


# --------------------------------------------------------------------------- output


# More steps than any stage's limit allows (MAX_STAGE_MS at the default slab's step).
MAX_CHECKPOINT_EVERY_STEPS = 10**9


class OutputSpec(StrictModel):
    """What a run writes besides histories and the crack catalogue."""

    snapshot_every_ms: float = Field(1.0, gt=0, description="ParaView snapshot interval [ms]")
    checkpoint_every_minutes: float = Field(5.0, gt=0, description="checkpoint interval [min]")
    checkpoint_every_steps: int | None = Field(
        None, ge=1, le=MAX_CHECKPOINT_EVERY_STEPS,
        description="also checkpoint every N mechanical steps (checked between chunks, "
                    "so at the first chunk end at or after N steps); unset: by wall clock "
                    f"and at stage ends only; 1 to {MAX_CHECKPOINT_EVERY_STEPS:.0e}")


# --------------------------------------------------------------------------- scenario


def _stage_entry_errors(index: int, stage: Any) -> list[str]:
    """The problems (``field: message`` lines) of one raw stage entry.

    Validating a raw entry against its own model gives ``stages.N.field``
    names; pydantic's tagged union would report ``stages.N.inject.field`` and,
    for a bad tag, an unhelpful message without the field.
    """
    allowed = ", ".join(STAGE_KINDS)
    if isinstance(stage, BaseModel):
        return []
    if not isinstance(stage, dict):
        return [f"stages.{index}: must be a table with a kind ({allowed}) (got {stage!r})"]
    kind = stage.get("kind")
    if kind is None:
        return [f"stages.{index}.kind: missing; allowed: {allowed}"]
    if kind not in STAGE_MODELS:
        close = difflib.get_close_matches(str(kind), STAGE_KINDS, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return [f"stages.{index}.kind: unknown stage {kind!r}{hint} (allowed: {allowed})"]
    try:
        validate(STAGE_MODELS[kind], stage, prefix=f"stages.{index}")
    except ConfigError as exc:
        return [f"{field}: {message}" for field, message in exc.problems]
    return []


def estimated_elements(config: SpecimenConfig) -> float | None:
    """Elements the mesh of ``config`` will have, estimated before building it: triangles
    of a 2D slab (:data:`ELEMENTS_PER_ZONE_AREA`), tetrahedra of a 3D slab or cube
    (:data:`TETS_PER_ZONE_VOLUME`); None for the other shapes (small lab specimens)."""
    spec, zone = config.specimen, config.grains.zone_size_mm
    if not isinstance(spec, SlabSpec):
        return None
    area = spec.width_mm * spec.height_mm - math.pi * spec.borehole_diameter_mm**2 / 4
    if config.dimension == 3:
        return TETS_PER_ZONE_VOLUME * area * spec.thickness_mm / zone**3
    return ELEMENTS_PER_ZONE_AREA * area / zone**2


def check_size(config: SpecimenConfig) -> SpecimenConfig:
    """Check what can be told of a slab's mesh (2D, or 3D slab or cube) before building it.

    Raises :class:`ConfigError` if the estimated element count
    (:func:`estimated_elements`) exceeds :data:`MAX_ELEMENTS` (2D triangles) or
    :data:`MAX_ELEMENTS_3D` (3D tetrahedra), or a borehole is less than
    :data:`BOREHOLE_MIN_ZONES` zones across (with a hint when the value looks like metres).
    """
    spec, zone = config.specimen, config.grains.zone_size_mm
    problems: list[tuple[str, str]] = []
    elements = estimated_elements(config)
    if isinstance(spec, SlabSpec) and elements is not None:
        three = config.dimension == 3
        limit, power = (MAX_ELEMENTS_3D, 3) if three else (MAX_ELEMENTS, 2)
        if elements > limit:
            needed = zone * (elements / limit) ** (1 / power)
            size = (f"{spec.width_mm:g} x {spec.height_mm:g} x {spec.thickness_mm:g} mm 3D"
                    if three else f"{spec.width_mm:g} x {spec.height_mm:g} mm")
            what = (f"about {elements:.3g} {'tetrahedra' if three else 'elements'} for a "
                    f"{size} specimen at zone_size_mm = {zone:g}, more than the "
                    f"{limit:.0e} allowed")
            if needed <= config.grains.max_edge_mm:
                problems.append(("grains.zone_size_mm", f"{what}; raise zone_size_mm to at "
                                 f"least {needed:.3g} or shrink the specimen"))
            else:  # no zone the grains allow would do: the specimen is the mistake
                sides = {"width_mm": spec.width_mm, "height_mm": spec.height_mm}
                if three:
                    sides["thickness_mm"] = spec.thickness_mm
                side = max(sides, key=sides.get)
                problems.append((f"specimen.{side}", f"{what}; shrink the specimen"))
        d = spec.borehole_diameter_mm
        if 0 < d < BOREHOLE_MIN_ZONES * zone:
            hint = " (a value in metres? the unit is mm)" if d < 0.1 else ""
            problems.append(("specimen.borehole_diameter_mm", (
                f"must be 0 (no borehole) or >= {BOREHOLE_MIN_ZONES:g} zones "
                f"({BOREHOLE_MIN_ZONES * zone:g} mm at zone_size_mm = {zone:g}){hint} "
                f"(got {d:g})")))
    if problems:
        raise ConfigError(*problems[0], problems[1:])
    return config


class Scenario(StrictModel):
    """A complete run: specimen, in-situ stress, fluid, stages and output.

    The specimen part (``seed``, ``rock``, ``specimen``, ``grains``,
    ``fissures``) has the schema and defaults of a specimen file.
    """

    name: str = Field("scenario", description="run name")
    seed: int = Field(0, ge=0, description="random seed of grains, minerals, Weibull draws")
    rock: str | materials.RockRecipe = Field("strathbogie-granite", description="rock recipe")
    specimen: SpecimenShapeSpec = Field(
        default_factory=SlabSpec, description="specimen: a slab or rectangle, chosen by `shape`")
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
        shape = self.specimen.shape
        if shape not in _STRESSABLE_SHAPES:
            raise ValueError(
                f"specimen.shape: a scenario needs a slab or rectangle (the in-situ stress acts "
                f"on its left, right, top and bottom sides) (got {shape!r})"
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
            if not isinstance(spec, SlabSpec):
                raise ValueError(
                    f"stages.{i}.kind: {stage.kind} needs a specimen with a borehole (a slab "
                    f"with borehole_diameter_mm > 0); the specimen is a {spec.shape}"
                )
            if spec.borehole_diameter_mm <= 0:
                raise ValueError(
                    f"specimen.borehole_diameter_mm: must be > 0 for the {stage.kind} stage "
                    f"(stages.{i}) (got {spec.borehole_diameter_mm:g})"
                )

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
            "seed": self.seed, "rock": self.rock, "specimen": self.specimen,
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


def _scda_material(stage: ScdaStage, index: int, base_dir: Path | None) -> materials.ScdaRecipe:
    try:
        return stage.material(base_dir)
    except ConfigError as exc:
        field = f"stages.{index}.scda"
        if exc.field not in ("scda", field):
            field = f"{field} ({exc.field})"
        raise ConfigError(field, exc.message) from None


# --------------------------------------------------------------------------- files


def load_scenario(path: str | Path) -> tuple[Scenario, materials.RockRecipe]:
    """Read and validate a scenario TOML file and resolve its rock recipe.

    The rock and SCDA materials given as paths are resolved relative to the
    file; SCDA paths are returned absolute so the scenario no longer depends on
    the file's directory. Every material is loaded here, so a bad one fails
    before any compute.
    """
    path = Path(path)
    base = path.parent
    scenario = validate(Scenario, read_toml(path))
    try:
        recipe = scenario.recipe(base)
    except ConfigError as exc:
        if exc.field == "rock" or exc.field.startswith("rock."):
            raise
        # A recipe file's own problem (missing, not UTF-8...): say which field named it.
        raise ConfigError("rock", f"{exc.field}: {exc.message}") from None
    stages = []
    for i, stage in enumerate(scenario.stages):
        if isinstance(stage, ScdaStage):
            _scda_material(stage, i, base)  # fails early on a bad material
            if isinstance(stage.scda, str):
                candidate = Path(stage.scda)
                if not candidate.is_absolute() and (base / candidate).is_file():
                    stage = stage.model_copy(update={"scda": str((base / candidate).resolve())})
        stages.append(stage)
    if stages != scenario.stages:
        scenario = scenario.model_copy(update={"stages": stages})
    return scenario, recipe


def _drop_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _drop_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list | tuple):
        return [_drop_none(v) for v in value]
    return value


def resolved_dict(
    scenario: Scenario, recipe: materials.RockRecipe, base_dir: Path | None = None
) -> dict[str, Any]:
    """The scenario with every default filled in, as plain data for ``config.toml``.

    The rock recipe and SCDA materials are written inline; the stress has both
    its case (if any) and its values. Keys whose value is None are left out
    (TOML has no null); loading the result gives the same scenario.
    """
    full = scenario.resolved(recipe, base_dir)
    return _drop_none(full.model_dump(mode="json"))


def write_resolved(
    path: str | Path, scenario: Scenario, recipe: materials.RockRecipe,
    base_dir: Path | None = None,
) -> Path:
    """Write the resolved scenario (``config.toml`` of a run directory), atomically."""
    return write_toml(path, resolved_dict(scenario, recipe, base_dir))


# --------------------------------------------------------------------------- presets


def _preset(
    name: str, stages: list[dict[str, Any]], stress_case: str, seed: int,
    fissures: FissureSpec | dict[str, Any] | None, **extra: Any,
) -> Scenario:
    data: dict[str, Any] = {"name": name, "seed": seed, "stress": {"case": stress_case},
                            "stages": stages, **extra}
    if fissures is not None:
        data["fissures"] = fissures
    return validate(Scenario, data)


def hs_only(
    rate_ml_per_min: float = DEFAULT_RATE_ML_PER_MIN,
    stress_case: str = "case2",
    duration_ms: float | None = None,
    *,
    seed: int = 0,
    fissures: FissureSpec | dict[str, Any] | None = None,
    name: str | None = None,
    **extra: Any,
) -> Scenario:
    """Hydraulic stimulation only: ``[equilibrate, inject]`` (paper Fig. 17c at 90 ml/min).

    ``duration_ms`` defaults to :func:`default_inject_duration_ms` (12 ms at
    90 ml/min on the default slab, where breakdown comes 4-5 ms after the start
    of injection). ``extra`` are further top-level scenario fields
    (``specimen``, ``grains``, ``fluid``, ``output``...).
    """
    duration = default_inject_duration_ms(rate_ml_per_min) if duration_ms is None else duration_ms
    return _preset(
        name or f"hs-only-{stress_case}-{rate_ml_per_min:g}mlmin",
        [{"kind": "equilibrate"},
         {"kind": "inject", "rate_ml_per_min": rate_ml_per_min, "duration_ms": duration}],
        stress_case, seed, fissures, **extra,
    )


def hybrid(
    rate_ml_per_min: float = DEFAULT_RATE_ML_PER_MIN,
    stress_case: str = "case2",
    duration_ms: float | None = None,
    *,
    peak_pressure_MPa: float = 45.0,
    seed: int = 0,
    fissures: FissureSpec | dict[str, Any] | None = None,
    name: str | None = None,
    **extra: Any,
) -> Scenario:
    """The hybrid method: ``[equilibrate, scda, drill_out, inject]`` (paper Fig. 17a, b, d).

    SCDA charging with the paper's parameters (peak 45 MPa, f = 1, b = 20),
    drill-out, then injection; ``duration_ms`` as in :func:`hs_only`.
    """
    duration = default_inject_duration_ms(rate_ml_per_min) if duration_ms is None else duration_ms
    return _preset(
        name or f"hybrid-{stress_case}-{rate_ml_per_min:g}mlmin",
        [{"kind": "equilibrate"},
         {"kind": "scda", "peak_pressure_MPa": peak_pressure_MPa},
         {"kind": "drill_out"},
         {"kind": "inject", "rate_ml_per_min": rate_ml_per_min, "duration_ms": duration}],
        stress_case, seed, fissures, **extra,
    )


__all__ = [
    "BOREHOLE_STAGES", "DEFAULT_INJECT_DURATION_MS", "DEFAULT_RATE_ML_PER_MIN",
    "SPECIMEN_SIDES", "STAGE_KINDS", "STAGE_MODELS", "DrillOutStage", "EquilibrateStage",
    "FluidSpec", "InSituStress", "InjectStage", "OutputSpec", "Scenario", "ScdaStage", "Stage",
    "check_size", "default_inject_duration_ms", "estimated_elements", "hs_only", "hybrid",
    "load_scenario", "resolved_dict", "write_resolved",
]
