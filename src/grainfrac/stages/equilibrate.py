"""Equilibrate: load the intact rock with bonds held elastic and let it settle.

The in-situ stress of a scenario (paper Fig. 9b), and the loading of the
elastic verification cases (a far field for Kirsch, a borehole pressure for
Lame, both for the KGD confinement).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from grainfrac.loading.boundary import normal_pressure_forces
from grainfrac.loading.insitu import initialise_in_situ
from grainfrac.stages.world import World

log = logging.getLogger(__name__)


@dataclass
class EquilibrateState:
    """``unbalanced_force_ratio`` reached after ``steps``; ``converged`` if below the target."""

    start_time: float = 0.0
    done: bool = False
    steps: int = 0
    unbalanced_force_ratio: float | None = None
    converged: bool | None = None


@dataclass
class Equilibrate:
    """Replace the external loads by the far field ``sigma_x``, ``sigma_y`` on the
    rectangle's sides and ``wall_pressure`` on the borehole wall (Pa, compressive
    magnitudes), then step to an unbalanced-force ratio below ``ratio`` (or
    ``max_steps``). One chunk: the whole equilibration."""

    sigma_x: float
    sigma_y: float
    ratio: float
    max_steps: int
    wall_pressure: float = 0.0
    kind: str = "equilibrate"
    periodic_snapshots: bool = False
    state: EquilibrateState = field(default_factory=EquilibrateState)

    def begin(self, world: World) -> None:
        self.state.start_time = world.solver.time

    def advance(self, world: World) -> None:
        loads = world.solver.loads
        loads.external[:] = 0.0
        if self.wall_pressure:
            loads.external += normal_pressure_forces(world.assembly.mesh, "borehole",
                                                     self.wall_pressure)
        result = initialise_in_situ(world.solver, world.assembly.mesh, self.sigma_x,
                                    self.sigma_y, ratio=self.ratio, max_steps=self.max_steps)
        self.state.steps = result.steps
        self.state.unbalanced_force_ratio = result.unbalanced_force_ratio
        self.state.converged = result.converged
        self.state.done = True
        warning = self.unsettled_warning()
        if warning:
            log.warning(warning)

    def unsettled_warning(self) -> str | None:
        """Why the equilibrium reached is not to be trusted: the step limit came first
        (the unbalanced-force ratio is above its target). None once converged."""
        st = self.state
        if not st.done or st.converged or st.unbalanced_force_ratio is None:
            return None
        return (f"equilibrate: the in-situ stress had not settled after max_steps = "
                f"{self.max_steps} (unbalanced-force ratio {st.unbalanced_force_ratio:.3g}, "
                f"target {self.ratio:g}), so what followed started from a moving rock; "
                "raise max_steps")

    def finished(self) -> bool:
        return self.state.done

    def fraction(self) -> float:
        return 1.0
