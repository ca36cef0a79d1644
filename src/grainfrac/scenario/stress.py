"""The in-situ stress of a scenario: a case of paper Table 6 or both far-field values
(compressive magnitudes, MPa), and the specimen shapes it can act on.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import Field, model_validator

from grainfrac.io.config import StrictModel
from grainfrac.loading.insitu import STRESS_CASES
from grainfrac.units import MPA

__all__ = [
    "InSituStress",
    "StressCase",
]


StressCase = Literal["case1", "case2", "case3", "case4"]


# Shapes the far-field stress of an ``equilibrate`` stage can act on (left/right/top/bottom;
# a hollow cylinder's lateral surface takes sigma_x = sigma_y as a confining pressure).
_STRESSABLE_SHAPES = ("slab", "rectangle", "hollow_cylinder")


class InSituStress(StrictModel):
    """Far-field principal stresses in the slab plane, compressive magnitudes in MPa.

    Give either a ``case`` of paper Table 6 (default ``"case2"``: sigma_x 2.5,
    sigma_y 5 MPa) or both ``sigma_x_MPa`` and ``sigma_y_MPa``. After
    validation the values are always filled in (from the case when one is
    given). Giving a case together with values that differ from it is an
    error: nothing overrides anything silently.
    """

    case: StressCase | None = Field("case2", description="paper Table 6 stress case")
    sigma_x_MPa: float | None = Field(None, ge=0, description="compressive stress along x [MPa]")
    sigma_y_MPa: float | None = Field(None, ge=0, description="compressive stress along y [MPa]")
    sigma_z_MPa: float | None = Field(
        None, ge=0, description="compressive stress along z (the borehole axis) [MPa]; acts "
        "in 3D only; from the case when one is given, required in 3D otherwise")

    @model_validator(mode="before")
    @classmethod
    def _values_mean_no_case(cls, data: Any) -> Any:
        # The default case applies only when no values are given.
        if isinstance(data, dict) and "case" not in data and (
            data.get("sigma_x_MPa") is not None or data.get("sigma_y_MPa") is not None
        ):
            data = {**data, "case": None}
        return data

    @model_validator(mode="after")
    def _resolve(self) -> InSituStress:
        given = {"sigma_x_MPa": self.sigma_x_MPa, "sigma_y_MPa": self.sigma_y_MPa}
        if self.case is None:
            missing = [k for k, v in given.items() if v is None]
            if missing:
                raise ValueError(
                    f"{missing[0]}: required without a case (give a case of paper Table 6, "
                    "case1..case4, or both sigma_x_MPa and sigma_y_MPa)"
                )
            return self
        sx, sy, sz = STRESS_CASES[self.case]
        table = {"sigma_x_MPa": sx, "sigma_y_MPa": sy, "sigma_z_MPa": sz}
        given["sigma_z_MPa"] = self.sigma_z_MPa
        conflict = {k: v for k, v in given.items()
                     if v is not None and not math.isclose(v, table[k], rel_tol=1e-12)}
        if conflict:
            got = ", ".join(f"{k} = {v:g}" for k, v in conflict.items())
            raise ValueError(
                f"give either case or sigma_x_MPa and sigma_y_MPa, not both: {self.case} is "
                f"sigma_x_MPa = {sx:g}, sigma_y_MPa = {sy:g}, sigma_z_MPa = {sz:g} "
                f"(paper Table 6), got {got}"
            )
        for key, value in table.items():
            object.__setattr__(self, key, float(value))
        self.__pydantic_fields_set__.update(table)
        return self

    def resolved(self) -> tuple[float, float]:
        """``(sigma_x_MPa, sigma_y_MPa)``, compressive magnitudes."""
        assert self.sigma_x_MPa is not None and self.sigma_y_MPa is not None
        return self.sigma_x_MPa, self.sigma_y_MPa

    @property
    def sigma_z_Pa(self) -> float:
        """The stress along the borehole axis (Pa, compressive; 3D), 0 where not given."""
        return (self.sigma_z_MPa or 0.0) * MPA

    def resolved_Pa(self) -> tuple[float, float]:
        """``(sigma_x, sigma_y)`` in Pa, compressive magnitudes (for ``initialise_in_situ``)."""
        sx, sy = self.resolved()
        return sx * MPA, sy * MPA
