"""Staggered, fully coupled hydro-mechanics.

Each fluid step: apertures from the current contact openings -> implicit
pressure solve over ``dt`` -> pressures applied to both faces of every
sub-contact and to the borehole wall -> the mechanics advances over the same
``dt`` (as many explicit steps as it takes). The fluid's own stability limit
never restricts ``dt``; accuracy does, so ``dt`` is a parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.io.snapshots import contact_opening
from grainfrac.loading.boundary import normal_pressure_forces
from grainfrac.physics import flow
from grainfrac.physics.solver import MechanicsSolver


@dataclass
class CoupledHistory:
    """One row per fluid step."""

    time: list[float] = field(default_factory=list)
    well_pressure: list[float] = field(default_factory=list)
    injected_volume: list[float] = field(default_factory=list)
    n_cracks: list[int] = field(default_factory=list)


class HydroMechanicalSolver:
    """Couple a :class:`MechanicsSolver` with the grain-boundary flow network.

    Parameters
    ----------
    assembly
        The assembly both solvers were built from.
    mechanics
        Mechanics solver (its current ``loads.external`` is kept as the base load).
    network
        Flow network (permeable sides, well).
    fluid
        Fluid and aperture parameters.
    """

    def __init__(self, assembly: GrainAssembly, mechanics: MechanicsSolver,
                 network: flow.FlowNetwork, fluid: flow.FluidProperties):
        self.assembly = assembly
        self.mechanics = mechanics
        self.network = network
        self.fluid = fluid
        self.base_external = mechanics.loads.external.copy()
        self.well_unit_forces = (
            normal_pressure_forces(assembly.mesh, "borehole", 1.0)
            if network.well_unknown >= 0 else None
        )
        self.state = flow.initial_state(network, self.aperture(), fluid)
        # Opening stiffness of a crack whose spring no longer closes it: the softest
        # grain's stiffness over a crack length. The fixed-stress split is stable
        # only if this does not overstate the stiffness (measured: 5 mm ran away
        # once cracks grew, and the stiffest grain over 18 mm tripled the crack
        # count at a 0.1 ms step), so take the longest length fractures reach,
        # half the specimen's smaller side.
        span = np.ptp(assembly.mesh.node_xy, axis=0).min()
        self.open_stiffness = float(np.min(mechanics.model.lam + 2 * mechanics.model.mu)) / (
            0.5 * span)
        self.history = CoupledHistory()
        self._apply_pressure()

    def aperture(self) -> np.ndarray:
        return flow.hydraulic_aperture(contact_opening(self.assembly, self.mechanics.u),
                                       self.fluid)

    @property
    def well_pressure(self) -> float:
        w = self.network.well_unknown
        return float(self.state.pressure[w]) if w >= 0 else 0.0

    def _apply_pressure(self) -> None:
        self.mechanics.contact_pressure[:] = self.state.pressure[self.network.contact_unknown]
        external = self.base_external.copy()
        if self.well_unit_forces is not None:
            external += self.well_pressure * self.well_unit_forces
        self.mechanics.loads.external[:] = external

    def pore_compliance(self) -> np.ndarray:
        """Opening compliance at fixed total stress per unknown (m3/Pa): sum A / k.

        A closed or bonded sub-contact opens by dp / kn under a pressure change;
        an open crack by about dp / k_open, with the grains' stiffness.
        """
        m = self.mechanics
        is_open = ~m.bonded & (m.sigma_n <= 0.0)
        k = np.where(is_open, self.open_stiffness, m.model.normal_stiffness)
        return np.bincount(self.network.contact_unknown, weights=m.model.contact_area / k,
                           minlength=self.network.n_unknowns)

    def advance(self, dt: float, injection_rate: float = 0.0) -> None:
        """One coupled step of ``dt`` seconds with ``injection_rate`` (m3/s) into the well."""
        flow.implicit_step(self.network, self.state, self.aperture(), dt, self.fluid,
                           injection_rate, compliance=self.pore_compliance())
        self._apply_pressure()
        self.mechanics.cycle(max(1, math.ceil(dt / self.mechanics.model.dt)))
        h = self.history
        h.time.append(self.mechanics.time)
        h.well_pressure.append(self.well_pressure)
        h.injected_volume.append(self.state.injected)
        h.n_cracks.append(len(self.mechanics.cracks.contact))
