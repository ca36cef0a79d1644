"""The stage schemas of a scenario (``equilibrate``, ``scda``, ``drill_out``,
``inject``), their tagged union and the default injection design.

The stage *objects* that run them live in :mod:`grainfrac.stages`.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, model_validator

from grainfrac import materials
from grainfrac.errors import ConfigError
from grainfrac.io.config import StrictModel, source_path, validate
from grainfrac.units import ML, ML_PER_MIN

__all__ = [
    "BOREHOLE_STAGES",
    "DEFAULT_INJECT_DURATION_MS",
    "DEFAULT_RATE_ML_PER_MIN",
    "MAX_STAGE_MS",
    "STAGE_KINDS",
    "STAGE_MODELS",
    "DrillOutStage",
    "EquilibrateStage",
    "InjectStage",
    "ScdaStage",
    "Stage",
    "default_inject_duration_ms",
]


# Headline HS design: 90 ml/min on the default slab breaks down ~5 ms after injection
# starts (tests/test_flow.py, README figure). The hybrid's pressure does not fall at
# once: seed 0 peaks at 9.37 MPa 4.7 ms in, holds within 5 % of it (multiple peaks,
# paper Fig. 17d) until 9.2 ms, then falls gradually (7.74 MPa at 12 ms), so 12 ms
# covers build-up, breakdown and propagation of both. Pressurisation time scales
# with 1 / rate.
DEFAULT_RATE_ML_PER_MIN = 90.0
DEFAULT_INJECT_DURATION_MS = 12.0


# Simulated time of one stage: 10 s is 7e7 mechanical steps of the default slab
# (1.394e-7 s each); the paper's stages last 60 ms at most.
MAX_STAGE_MS = 10_000.0


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


class EquilibrateStage(StrictModel):
    """Apply the in-situ stress with bonds held elastic and equilibrate (paper Fig. 9b).

    ``method = "static"`` solves the equilibrium of the bonded assembly in one sparse
    solve and steps only while the unbalanced-force ratio is above its target
    (unbonded fissures that open or slip): the same equilibrium, without the tens of
    thousands of explicit steps of dynamic relaxation (``"explicit"``, the default,
    which every documented result used).
    """

    kind: Literal["equilibrate"] = Field("equilibrate", description="selects this stage")
    unbalanced_ratio: float = Field(1e-5, gt=0, lt=1, description="target unbalanced-force ratio")
    max_steps: int = Field(300_000, gt=0, description="step limit")
    method: Literal["explicit", "static"] = Field(
        "explicit", description="explicit steps alone, or a static solve first")


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
    max_time_step_ms: float | None = Field(
        None, gt=0, le=MAX_STAGE_MS,
        description="longest fluid step [ms] while the injection is quiet (no new crack, no "
        "halved step, the well pressure moving < 0.5 % a step): the step doubles up to it and "
        "drops back to time_step_ms at once; default: every step is time_step_ms")
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
        if self.max_time_step_ms is not None and self.max_time_step_ms < self.time_step_ms:
            raise ValueError(
                f"max_time_step_ms: must be >= time_step_ms ({self.time_step_ms:g}) "
                f"(got {self.max_time_step_ms:g})")
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
    def max_time_step(self) -> float:
        """Longest fluid step (s) of a quiet injection (``time_step`` if it does not grow)."""
        return (self.max_time_step_ms if self.max_time_step_ms is not None
                else self.time_step_ms) * 1e-3

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
