"""In-situ stress initialisation (paper Table 6 cases).

The intact assembly is loaded to the far-field stresses with its bonds held
elastic (a suddenly applied load overshoots dynamically; the rock in situ did
not break on the way to its stress state), equilibrated, and only then are
bonds allowed to fail.
"""

from __future__ import annotations

from dataclasses import dataclass

from grainfrac.geometry.meshing import GrainMesh
from grainfrac.loading.boundary import far_field_stress_forces
from grainfrac.physics import static_equilibrium
from grainfrac.physics.solver import MechanicsSolver

# Paper Table 6, compressive magnitudes in MPa: (sigma_x, sigma_y, sigma_z).
STRESS_CASES = {
    "case1": (1.0, 1.0, 1.0),
    "case2": (2.5, 5.0, 1.0),
    "case3": (5.0, 5.0, 1.0),
    "case4": (1.0, 5.0, 1.0),
}


@dataclass(frozen=True)
class InSituResult:
    """Outcome of an in-situ stress initialisation."""

    steps: int
    unbalanced_force_ratio: float
    converged: bool


def initialise_in_situ(
    solver: MechanicsSolver,
    mesh: GrainMesh,
    sigma_x: float,
    sigma_y: float,
    sigma_z: float = 0.0,
    *,
    ratio: float = 1e-5,
    max_steps: int = 200_000,
    method: str = "explicit",
) -> InSituResult:
    """Apply compressive far-field stresses (Pa) to a rectangle's sides (a 3D box's six
    faces, ``sigma_z`` on top and bottom) and equilibrate.

    The tractions are added to ``solver.loads.external`` and stay applied.
    ``method = "static"`` solves the bonded assembly's equilibrium first
    (:func:`grainfrac.physics.static_equilibrium.settle`) and steps only if that leaves
    the ratio above ``ratio``. Returns the steps taken and the final unbalanced-force
    ratio.
    """
    static_equilibrium.check_method(method)  # before the loads change
    solver.loads.external += far_field_stress_forces(mesh, sigma_x, sigma_y, sigma_z)
    start = solver.step_count
    solver.allow_failure = False
    try:
        achieved = static_equilibrium.equilibrate(solver, ratio, max_steps, method)
    finally:
        solver.allow_failure = True
    return InSituResult(solver.step_count - start, achieved, achieved < ratio)
