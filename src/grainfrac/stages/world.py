"""What the stages act on: the assembly, its mechanics and, once injected, its fluid.

Stages replace parts of the world as a run goes on: SCDA charging swaps the
rock's solver for one with the plug in the borehole, drilling out swaps it
back, the first injection couples the fluid to the mechanics.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.physics import scda
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.physics.model import MechanicalModel
from grainfrac.physics.solver import MechanicsSolver

ROCK = "rock"
SCDA = "scda"


@dataclass
class World:
    """The assembly and the solvers a run's stages share.

    ``model_kind`` is ``"rock"`` or ``"scda"`` (plug in the borehole);
    ``injection_start_time`` (s) is when the fluid was first injected;
    ``mass_scaling`` and ``fixed_stress_iterations`` are the run's
    (:class:`grainfrac.scenario.NumericsSpec`).
    """

    assembly: GrainAssembly
    solver: MechanicsSolver
    rock_model: MechanicalModel = field(init=False)
    coupled: HydroMechanicalSolver | None = None
    model_kind: str = ROCK
    injection_start_time: float | None = None
    scda_fill: scda.ScdaFill | None = None
    scda_model: MechanicalModel | None = None
    mass_scaling: float = 1.0  # fraction of the added mass kept (the plug's model too)
    fixed_stress_iterations: int = 0  # of the fluid coupling (HydroMechanicalSolver)

    def __post_init__(self) -> None:
        self.rock_model = self.solver.model

    @property
    def n_rock_contacts(self) -> int:
        return self.assembly.mesh.n_contacts

    @property
    def n_rock_elements(self) -> int:
        return self.assembly.mesh.n_elements

    def rock_cracks(self) -> np.ndarray:
        """Mask over the crack record: cracks in the rock (not in an SCDA plug)."""
        c = np.asarray(self.solver.cracks.contact, dtype=np.int64)
        return c < self.n_rock_contacts

    def expansive_pressure(self) -> float:
        """The SCDA's pressure on the borehole wall (Pa); 0 without a plug."""
        if self.model_kind != SCDA:
            return 0.0
        return scda.expansive_pressure(self.solver, self.n_rock_contacts, self.scda_fill.n_wall)

    def well_pressure(self) -> float:
        """The fluid pressure in the well (Pa); 0 before injection."""
        return self.coupled.well_pressure if self.coupled is not None else 0.0
