"""Equilibrate: load the intact rock with bonds held elastic and let it settle.

The in-situ stress of a scenario (paper Fig. 9b), and the loading of the
elastic verification cases (a far field for Kirsch, a borehole pressure for
Lame, both for the KGD confinement).

The stage steps exactly as :meth:`MechanicsSolver.equilibrate` (the ratio checked
every :data:`CHECK_EVERY` steps, stopping at the first check below the target or at
``max_steps``), but in chunks of :data:`CHECKS_PER_CHUNK` checks: a run can record,
checkpoint and stop on a signal inside a long equilibration, and a resumed one
retraces the same steps.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from grainfrac.loading.boundary import far_field_stress_forces, normal_pressure_forces
from grainfrac.physics import static_equilibrium
from grainfrac.stages.world import World

log = logging.getLogger(__name__)
# Steps between two unbalanced-force checks (as MechanicsSolver.equilibrate's default).
CHECK_EVERY = 200
# Checks per chunk: 2000 steps, a few seconds of the default slab.
CHECKS_PER_CHUNK = 10


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
    rectangle's sides (and ``sigma_z`` on a 3D box's top and bottom) and
    ``wall_pressure`` on the borehole wall (Pa, compressive magnitudes), then step to
    an unbalanced-force ratio below ``ratio`` (or ``max_steps``), bonds held elastic
    meanwhile. One chunk: :data:`CHECKS_PER_CHUNK` checks of the ratio.

    ``method``: ``"explicit"`` relaxes from the unloaded state by the explicit steps
    alone; ``"static"`` first solves the equilibrium of the bonded assembly
    (:func:`grainfrac.physics.static_equilibrium.settle`) and steps only if that
    leaves the ratio above its target (unbonded fissures that open or slip)."""

    sigma_x: float
    sigma_y: float
    ratio: float
    max_steps: int
    wall_pressure: float = 0.0
    sigma_z: float = 0.0
    method: str = "explicit"
    kind: str = "equilibrate"
    periodic_snapshots: bool = False
    state: EquilibrateState = field(default_factory=EquilibrateState)

    def __post_init__(self) -> None:
        static_equilibrium.check_method(self.method)

    def begin(self, world: World) -> None:
        self.state.start_time = world.solver.time
        loads = world.solver.loads
        loads.external[:] = 0.0
        if self.wall_pressure:
            loads.external += normal_pressure_forces(world.assembly.mesh, "borehole",
                                                     self.wall_pressure)
        loads.external += far_field_stress_forces(world.assembly.mesh, self.sigma_x,
                                                  self.sigma_y, self.sigma_z)
        world.solver.allow_failure = False  # until the stage ends (saved in a checkpoint)
        if self.method == "static":
            ratio = static_equilibrium.settle(world.solver)
            self.state.unbalanced_force_ratio = ratio
            log.info("equilibrate: static solve, unbalanced-force ratio %.3g", ratio)

    def advance(self, world: World) -> None:
        st, solver = self.state, world.solver
        # A static solve may have settled it already.
        settled = st.unbalanced_force_ratio is not None and st.unbalanced_force_ratio < self.ratio
        for _ in range(0 if settled else CHECKS_PER_CHUNK):
            if st.steps >= self.max_steps:
                break
            solver.cycle(CHECK_EVERY)
            st.steps += CHECK_EVERY
            st.unbalanced_force_ratio = solver.unbalanced_force_ratio()
            if st.unbalanced_force_ratio < self.ratio:
                break
        ratio = st.unbalanced_force_ratio
        converged = ratio is not None and ratio < self.ratio
        if converged or st.steps >= self.max_steps:
            if ratio is None:
                st.unbalanced_force_ratio = float(np.inf)
            st.converged = bool(converged)
            st.done = True
            solver.allow_failure = True
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
        """Steps taken over ``max_steps`` (1 once settled): an upper bound of what is left."""
        if self.state.done:
            return 1.0
        return min(1.0, self.state.steps / self.max_steps)
