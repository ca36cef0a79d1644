"""The numerics section of a scenario: damping and mass scaling of the explicit
mechanics.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from grainfrac.io.config import StrictModel

__all__ = [
    "NumericsSpec",
]


class NumericsSpec(StrictModel):
    """Knobs of the explicit mechanics and of its coupling to the fluid that a converged
    answer must not hang on.

    ``local_damping`` is the Itasca local (non-viscous) damping coefficient of every
    stage; ``mass_scaling`` the fraction of the mass that mass scaling adds to keep
    the step at the grains' own (1: all of it, 0: real masses, a smaller step);
    ``backend`` where the explicit step runs: ``"cpu"`` (numba, the reference) or
    ``"cuda"`` (an NVIDIA GPU; the same results to round-off). ``grainfrac --backend``
    (or ``$GRAINFRAC_BACKEND``) overrides it. ``fixed_stress_iterations``: how often a
    fluid step's mechanics may be redone until the pressures solved from the voids it
    realised are those it ran at (0: the plain staggered step, one mechanics pass per
    fluid step). Iterated, the fluid's energy books close where the plain step makes
    energy as the voids lag a jump of the well pressure, at two (3D penny) to six (2D
    demo) times the wall time.
    """

    local_damping: float = Field(0.8, ge=0, lt=1, description="local damping coefficient")
    mass_scaling: float = Field(
        1.0, ge=0, le=1, description="fraction of the mass scaling's added mass kept "
        "(1: as designed, 0: real masses)")
    backend: Literal["cpu", "cuda"] = Field(
        "cpu", description="where the explicit step runs: cpu (numba) or cuda (NVIDIA GPU)")
    fixed_stress_iterations: int = Field(
        0, ge=0, le=50, description="times a fluid step's mechanics may be redone at the "
        "pressures solved from the voids it realised (0: the plain staggered step)")
