"""SCDA charging: the plug in the borehole expands at ``v = f exp(-b t)`` (paper Eq. 9).

Stops at the peak expansive pressure, when the expansion has decayed, or at
the time limit (:class:`grainfrac.scenario.ScdaStage`). The same in 2D and 3D:
:func:`grainfrac.physics.scda.scda_fill` meshes triangular or tetrahedral blocks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from grainfrac.materials import ScdaRecipe
from grainfrac.physics import scda
from grainfrac.scenario import ScdaStage
from grainfrac.stages.world import SCDA, World

SCDA_CHUNK = 500  # mechanical steps per chunk


@dataclass
class ScdaChargeState:
    """``peak_pressure`` (Pa) so far; ``stop_reason`` once the charging has ended."""

    start_time: float = 0.0
    chunks: int = 0
    peak_pressure: float = 0.0
    stop_reason: str | None = None
    fraction: float = 0.0


@dataclass
class ScdaCharge:
    """Charge the borehole with the SCDA of ``material`` as ``spec`` says."""

    spec: ScdaStage
    material: ScdaRecipe
    kind: str = "scda"
    periodic_snapshots: bool = True
    state: ScdaChargeState = field(default_factory=ScdaChargeState)

    def build_plug(self, world: World) -> None:
        """The plug's mesh and the rock-plus-plug model, made once per world."""
        if world.scda_fill is None:
            world.scda_fill = scda.scda_fill(world.assembly, self.material)
            world.scda_model = scda.build_scda_model(world.assembly, world.scda_fill,
                                                     mass_scaling=world.mass_scaling,
                                                     rock=world.rock_model)

    def begin(self, world: World) -> None:
        self.state.start_time = world.solver.time
        self.build_plug(world)
        if world.model_kind != SCDA:
            world.solver = scda.insert_scda(world.solver, world.scda_model, world.scda_fill)
            world.model_kind = SCDA

    def advance(self, world: World) -> None:
        st, spec, solver = self.state, self.spec, world.solver
        plug = scda.plug_elements(solver, world.n_rock_elements)
        elapsed = solver.time - st.start_time
        scda.set_expansion_velocity(solver, plug, spec.velocity(elapsed), world.scda_fill.radius)
        solver.cycle(SCDA_CHUNK)
        st.chunks += 1
        p = world.expansive_pressure()
        st.peak_pressure = max(st.peak_pressure, p)
        elapsed = solver.time - st.start_time
        limit = spec.max_duration_ms * 1e-3
        if p >= spec.peak_pressure_MPa * 1e6:
            st.stop_reason = "peak pressure"
        elif spec.velocity(elapsed) < spec.min_velocity_fraction * spec.velocity(0.0):
            st.stop_reason = "expansion decayed"
        elif elapsed >= limit:
            # Neither of the paper's ends: the result depends on the time limit.
            st.stop_reason = "time limit"
        st.fraction = min(1.0, max(p / (spec.peak_pressure_MPa * 1e6), elapsed / limit))
        if st.stop_reason is not None:
            solver.eigenstrain_rate[:] = 0.0

    def finished(self) -> bool:
        return self.state.stop_reason is not None

    def fraction(self) -> float:
        return self.state.fraction
