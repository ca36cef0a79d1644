"""Injection: fluid into the well at a constant rate, one fluid step per chunk."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grainfrac.physics import flow
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.scenario import FluidSpec, InjectStage
from grainfrac.stages.world import World

# A crack this close to an outer side (in zone sizes) means a fracture reached it.
BOUNDARY_REACH_ZONES = 1.5
# Breakdown: the well pressure falls this fraction below its peak (the drop that
# grainfrac.analysis.breakdown calls sustained; tests/test_well_wall.py keeps them equal).
BREAKDOWN_DROP_FRACTION = 0.05
# A fluid step may grow (InjectStage.max_time_step_ms) only while the well pressure
# moves less than this fraction of itself a step (at least the floor, Pa): about the
# default 0.01 ms step's own increments on the paper's slab (0.04 MPa at 90 ml/min,
# 0.4-1 % of the pressure before breakdown). At 2 % the grains answered each
# increment dynamically and the breakdown moved by up to 1.1 % (record 0021).
GROWTH_WELL_FRACTION = 0.005
GROWTH_WELL_FLOOR = 0.02e6


def couple_fluid(world: World, fluid: FluidSpec) -> HydroMechanicalSolver:
    """The grain-boundary flow network with a well, coupled to the world's mechanics."""
    assembly = world.assembly
    network = flow.build_flow_network(
        assembly.mesh, permeable_sides=fluid.fixed_pressures(assembly.dimension), well=True,
        well_compressibility=fluid.well_compressibility,
        sealed=assembly.contact_intragranular, wall=fluid.well_wall,
    )
    a0 = assembly.recipe.hydraulic.initial_aperture_m
    return HydroMechanicalSolver(assembly, world.solver, network, fluid.properties(a0),
                                 fixed_stress_iterations=world.fixed_stress_iterations)


def fracture_at_boundary(world: World) -> bool:
    """Whether a crack made since injection started lies within reach of an outer
    side (not the borehole wall).

    Cracks of earlier stages do not count: after SCDA charging in a weak rock a
    radial crack can already reach the boundary, and the injection that is to
    extend the fractures would otherwise end at its first step.
    """
    since = world.injection_start_time
    rock = world.rock_cracks() & (np.asarray(world.solver.cracks.time) >= since)
    if not rock.any():
        return False
    mesh = world.assembly.mesh
    contacts = np.asarray(world.solver.cracks.contact, dtype=np.int64)[rock]
    reach = BOUNDARY_REACH_ZONES * mesh.zone_size
    if mesh.dimension == 3:
        # The slab's in-plane sides: its top and bottom faces are within reach of
        # every crack of a thin slab.
        solid, x = mesh.grains.solid, mesh.contact_x[contacts, :2]
        return bool((np.minimum(x - solid.lo[:2], solid.hi[:2] - x) <= reach).any())
    near = mesh.grains.outline.side_of_points(mesh.contact_xy[contacts], reach)
    return any(mask.any() for side, mask in near.items() if side != "borehole")


def next_time_step(step: float, spec: InjectStage, quiet: bool) -> float:
    """The fluid step after one of ``step`` seconds: twice as long (at most
    ``spec.max_time_step``) after a quiet step, ``spec.time_step`` after any other.

    Quiet: no new crack, no halved step, the well pressure moved less than
    ``GROWTH_WELL_FRACTION`` of itself. The mechanics takes the same explicit steps
    either way; a longer fluid step holds the pressures for longer between solves,
    which the smooth pressurisation before breakdown allows (measured in
    ``benchmarks/fluid_step_growth.py``).
    """
    return min(2.0 * step, spec.max_time_step) if quiet else spec.time_step


@dataclass
class InjectState:
    start_time: float = 0.0
    chunks: int = 0
    done: bool = False  # stop_reason is not None; kept so that older checkpoints resume
    fraction: float = 0.0
    peak_well_pressure: float = 0.0  # Pa
    breakdown_after: float = -1.0  # s from the stage start; -1 before breakdown
    stop_reason: str | None = None  # once the stage has ended
    time_step: float = 0.0  # s, the next fluid step (0: the stage's time_step)


@dataclass
class Inject:
    """Inject as ``spec`` says; the first injection couples ``fluid`` to the mechanics."""

    spec: InjectStage
    fluid: FluidSpec
    kind: str = "inject"
    periodic_snapshots: bool = True
    state: InjectState = field(default_factory=InjectState)

    def begin(self, world: World) -> None:
        self.state.start_time = world.solver.time
        if world.coupled is None:
            world.coupled = couple_fluid(world, self.fluid)
            if world.injection_start_time is None:
                world.injection_start_time = world.solver.time

    def advance(self, world: World) -> None:
        st, spec = self.state, self.spec
        planned = spec.planned_duration_s
        # The last step only as long as the time left (the coupling rounds it up to
        # whole mechanical steps): the stage ends within one mechanical step of its
        # duration or volume, not up to a fluid step beyond it.
        left = planned - (world.solver.time - st.start_time)
        if spec.max_time_step_ms is None:
            world.coupled.advance(min(spec.time_step, left), spec.rate)
        else:
            self._advance_growing(world, min(st.time_step or spec.time_step, left))
        st.chunks += 1
        elapsed = world.solver.time - st.start_time
        if elapsed >= planned - 1e-12:
            st.stop_reason = "planned duration"
        if spec.stop_at_boundary and fracture_at_boundary(world):
            st.stop_reason = "fracture reached the specimen's boundary"
        if spec.stop_after_breakdown_ms is not None:
            p = world.coupled.well_pressure
            if st.breakdown_after < 0.0:
                st.peak_well_pressure = max(st.peak_well_pressure, p)
                if p < (1.0 - BREAKDOWN_DROP_FRACTION) * st.peak_well_pressure:
                    st.breakdown_after = elapsed
            elif elapsed >= st.breakdown_after + spec.stop_after_breakdown_ms * 1e-3:
                st.stop_reason = f"{spec.stop_after_breakdown_ms:g} ms after breakdown"
        st.done = st.stop_reason is not None
        st.fraction = min(1.0, elapsed / planned)

    def _advance_growing(self, world: World, step: float) -> None:
        """One fluid step of ``step`` seconds; set the next one (:func:`next_time_step`).
        A grown step in which a crack starts is done again in halves down to the
        stage's own step (the halves count as rejected: the step drops back)."""
        spec, coupled = self.spec, world.coupled
        cracks, rejected, pressure = (len(world.solver.cracks.contact), coupled.rejected_steps,
                                      coupled.well_pressure)
        coupled.advance(step, spec.rate, crack_free_above=spec.time_step)
        p = coupled.well_pressure
        self.state.time_step = next_time_step(step, spec, quiet=(
            len(world.solver.cracks.contact) == cracks and coupled.rejected_steps == rejected
            and abs(p - pressure) <= max(GROWTH_WELL_FRACTION * abs(p), GROWTH_WELL_FLOOR)))

    def finished(self) -> bool:
        return self.state.done

    def fraction(self) -> float:
        return self.state.fraction
