"""The fluid section of a scenario: fluid properties, hydraulic apertures and the
permeable sides of the specimen (defaults: water, paper Table 4).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from grainfrac.io.config import StrictModel
from grainfrac.physics.flow import FluidProperties
from grainfrac.units import GPA, MPA

__all__ = [
    "SPECIMEN_SIDES",
    "FluidSpec",
]


# Named sides of each specimen shape that can be made permeable (the borehole is the well).
SPECIMEN_SIDES: dict[str, tuple[str, ...]] = {
    "slab": ("left", "right", "top", "bottom"),
    "rectangle": ("left", "right", "top", "bottom"),
    "disk": ("perimeter",),
    "semi_disk": ("arc", "base"),
    "hollow_cylinder": ("lateral",),
}

# A 3D slab's sides by the 2D names (the slab plane is x-y; z+ and z- are its top and
# bottom faces, impermeable as in paper Fig. 9c).
SIDES_3D = {"left": "x-", "right": "x+", "bottom": "y-", "top": "y+"}


class FluidSpec(StrictModel):
    """Fluid, hydraulic apertures and fluid boundaries (defaults: water, paper Table 4).

    Hydraulic aperture ``a = clamp(a0 + opening, a_res, a_max)`` with
    ``a_res <= a0 < a_max``. ``permeable_sides`` are held at
    ``boundary_pressure_MPa`` (paper Fig. 9c: the slab edges); the borehole is
    the well. ``well_compressibility_per_GPa`` is the compressibility of the
    well's fluid volume, by default that of water (1 / 2 GPa). ``well_wall`` is how the
    well meets the grain boundaries ending on its wall (:data:`grainfrac.physics.flow.
    WELL_WALLS`); by default ``sealed``: an intact wall of tight boundaries that a wall
    contact opens to the well once it cracks (decision record 0017).
    """

    viscosity_Pa_s: float = Field(1.0e-3, gt=0, description="dynamic viscosity mu [Pa s]")
    bulk_modulus_GPa: float = Field(2.0, gt=0, description="fluid bulk modulus Kw [GPa]")
    initial_aperture_m: float = Field(2.0e-7, gt=0, description="a0 [m]")
    residual_aperture_m: float = Field(2.0e-7, gt=0, description="a_res [m]")
    maximum_aperture_m: float = Field(3.0e-5, gt=0, description="a_max [m]")
    broken_residual_aperture_m: float | None = Field(
        None, gt=0, description="lower bound of the aperture of broken and fissured grain "
        "boundaries [m]; default: residual_aperture_m (paper: one a_res for all)")
    closure_storage: bool = Field(
        False, description="the void of a grain boundary pressed past its residual "
        "aperture follows its faces as they part, from where they were when the fluid "
        "coupling began (the conductance keeps the aperture law); false: the paper's "
        "law, which holds that void at the residual aperture")
    permeable_sides: list[str] = Field(
        default_factory=lambda: list(SPECIMEN_SIDES["slab"]),
        description="specimen sides held at boundary_pressure_MPa",
    )
    boundary_pressure_MPa: float = Field(0.0, ge=0, description="pressure on permeable sides")
    well_compressibility_per_GPa: float = Field(
        0.5, gt=0, description="compressibility of the well fluid volume [1/GPa]"
    )
    well_wall: Literal["wet", "sealed", "flow_knots"] = Field(
        "sealed", description="how the well meets the grain boundaries that end on its wall: "
        "'wet' (wall contacts take the well pressure from the start), 'sealed' (pressure on "
        "the wall; a wall contact takes fluid once it cracks), 'flow_knots' (3DEC: fluid "
        "into the wall contacts only, no pressure on the wall)")

    @model_validator(mode="after")
    def _check(self) -> FluidSpec:
        a_res, a0, a_max = self.residual_aperture_m, self.initial_aperture_m, \
            self.maximum_aperture_m
        if a_res > a0:
            raise ValueError(
                f"residual_aperture_m: must be <= initial_aperture_m ({a0:g}) (got {a_res:g})"
            )
        broken = self.broken_residual_aperture_m
        if broken is not None and not a_res <= broken < a_max:
            raise ValueError(
                f"broken_residual_aperture_m: must be in [residual_aperture_m, "
                f"maximum_aperture_m) = [{a_res:g}, {a_max:g}) (got {broken:g})"
            )
        if a0 >= a_max:
            raise ValueError(
                f"initial_aperture_m: must be < maximum_aperture_m ({a_max:g}) (got {a0:g})"
            )
        seen: set[str] = set()
        for side in self.permeable_sides:
            if side in seen:
                raise ValueError(f"permeable_sides: {side!r} is listed twice")
            seen.add(side)
        return self

    def properties(self, rock_initial_aperture_m: float | None = None) -> FluidProperties:
        """The SI fluid properties for the flow solver.

        ``rock_initial_aperture_m`` (the rock recipe's calibrated a0) is used
        when this file does not set ``initial_aperture_m``; an unset residual
        aperture then follows it down if it is smaller.
        """
        a0, a_res = self.initial_aperture_m, self.residual_aperture_m
        unset = self.model_fields_set
        if rock_initial_aperture_m is not None and "initial_aperture_m" not in unset:
            a0 = rock_initial_aperture_m
            if "residual_aperture_m" not in unset:
                a_res = min(a_res, a0)
        return FluidProperties(
            viscosity=self.viscosity_Pa_s,
            bulk_modulus=self.bulk_modulus_GPa * GPA,
            initial_aperture=a0,
            residual_aperture=a_res,
            maximum_aperture=self.maximum_aperture_m,
            broken_residual_aperture=self.broken_residual_aperture_m,
            closure_storage=self.closure_storage,
        )

    def fixed_pressures(self, dimension: int = 2) -> dict[str, float]:
        """Side name -> fixed pressure (Pa), for ``build_flow_network(permeable_sides=...)``;
        in 3D the in-plane sides by the box's names (:data:`SIDES_3D`)."""
        names = SIDES_3D if dimension == 3 else {}
        return {names.get(side, side): self.boundary_pressure_MPa * MPA
                for side in self.permeable_sides}

    @property
    def well_compressibility(self) -> float:
        """Compressibility of the well fluid volume (1/Pa)."""
        return self.well_compressibility_per_GPa / GPA
