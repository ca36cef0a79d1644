"""Drill-out: remove the SCDA plug, then relax the rock until it settles."""

from __future__ import annotations

from dataclasses import dataclass, field

from grainfrac.physics import scda
from grainfrac.scenario import DrillOutStage
from grainfrac.stages.world import ROCK, SCDA, World

RELAX_CHUNK = 500  # mechanical steps per chunk


@dataclass
class DrillOutState:
    """``unbalanced_force_ratio`` when the relaxation ended."""

    start_time: float = 0.0
    chunks: int = 0
    steps: int = 0
    done: bool = False
    unbalanced_force_ratio: float | None = None


@dataclass
class DrillOut:
    """At least ``spec.relax_steps`` steps, on to ``spec.unbalanced_ratio`` or
    ``spec.max_steps``."""

    spec: DrillOutStage
    kind: str = "drill_out"
    periodic_snapshots: bool = False
    state: DrillOutState = field(default_factory=DrillOutState)

    def begin(self, world: World) -> None:
        self.state.start_time = world.solver.time
        if world.model_kind == SCDA:
            world.solver = scda.drill_out(world.solver, world.rock_model)
            world.model_kind = ROCK

    def advance(self, world: World) -> None:
        st, spec = self.state, self.spec
        steps = min(st.chunks * RELAX_CHUNK, spec.max_steps)
        if steps < spec.max_steps:
            world.solver.cycle(min(RELAX_CHUNK, spec.max_steps - steps))
            st.chunks += 1
            steps = min(st.chunks * RELAX_CHUNK, spec.max_steps)
        st.steps = steps
        ratio = world.solver.unbalanced_force_ratio()
        st.done = steps >= spec.max_steps or (steps >= spec.relax_steps
                                              and ratio < spec.unbalanced_ratio)
        if st.done:
            st.unbalanced_force_ratio = ratio

    def finished(self) -> bool:
        return self.state.done

    def fraction(self) -> float:
        return min(1.0, self.state.steps / max(self.spec.relax_steps, 1))
