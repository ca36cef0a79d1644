"""3D specimen solids in metres: a box, optionally with a faceted borehole along z.

A solid is what the 3D tessellation fills. Every boundary surface is flat: the
box faces, and the borehole wall faceted at the zone size (prism of ``n``
facets whose vertices lie on the nominal circle, as in 2D). Side names
(``x-``, ``x+``, ``y-``, ``y+``, ``z-``, ``z+``, ``borehole``) name node sets
and fluid boundaries; ``z-``/``z+`` are the top and bottom of a slab.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grainfrac.errors import GeometryError
from grainfrac.units import MM

BOX_SIDES = ("x-", "x+", "y-", "y+", "z-", "z+")
BOREHOLE = "borehole"


@dataclass(frozen=True)
class Solid:
    """A box ``[lo, hi]`` minus an optional prism around the z axis through (0, 0).

    Attributes
    ----------
    kind : str
        Specimen shape name (``slab``, ``cube``).
    lo, hi : np.ndarray
        (3,) box corners (m).
    borehole_radius : float
        Nominal radius (m): the facet vertices lie on this circle; 0 for none.
    borehole_facets : int
        Number of wall facets (0 for none).
    """

    kind: str
    lo: np.ndarray
    hi: np.ndarray
    borehole_radius: float = 0.0
    borehole_facets: int = 0

    @property
    def extent(self) -> np.ndarray:
        return self.hi - self.lo

    @property
    def has_borehole(self) -> bool:
        return self.borehole_radius > 0

    @property
    def apothem(self) -> float:
        """Distance from the axis to the facet planes (m)."""
        return self.borehole_radius * math.cos(math.pi / self.borehole_facets)

    @property
    def borehole_area(self) -> float:
        """Cross-section of the faceted borehole (m2)."""
        if not self.has_borehole:
            return 0.0
        n = self.borehole_facets
        return 0.5 * n * self.borehole_radius ** 2 * math.sin(2 * math.pi / n)

    @property
    def volume(self) -> float:
        """Exact volume of the faceted solid (m3)."""
        e = self.extent
        return float(e[0] * e[1] * e[2] - self.borehole_area * e[2])

    @property
    def sides(self) -> tuple[str, ...]:
        return BOX_SIDES + ((BOREHOLE,) if self.has_borehole else ())

    def facet_normals(self) -> np.ndarray:
        """(n, 3) unit normals of the facet planes, pointing from the axis into the rock."""
        phi = (np.arange(self.borehole_facets) + 0.5) * 2 * math.pi / self.borehole_facets
        return np.column_stack((np.cos(phi), np.sin(phi), np.zeros_like(phi)))

    def inside(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """True for points at least ``margin`` inside the solid (rough for the prism corners)."""
        ok = np.all((x >= self.lo + margin) & (x <= self.hi - margin), axis=1)
        if self.has_borehole:
            ok &= np.max(x @ self.facet_normals().T, axis=1) >= self.apothem + margin
        return ok


def box_solid(kind: str, width_mm: float, height_mm: float, thickness_mm: float,
              borehole_diameter_mm: float, zone_size: float) -> Solid:
    """A box centred on the z axis (x, y) from z = 0 to the thickness, with a borehole.

    The borehole has one facet per zone size of circumference, at least 12.
    """
    w, h, t = width_mm * MM, height_mm * MM, thickness_mm * MM
    radius = 0.5 * borehole_diameter_mm * MM
    if radius > 0 and radius >= 0.5 * min(w, h):
        raise GeometryError("the borehole does not fit in the box")
    facets = max(12, math.ceil(2 * math.pi * radius / zone_size)) if radius > 0 else 0
    return Solid(kind, np.array([-w / 2, -h / 2, 0.0]), np.array([w / 2, h / 2, t]),
                 radius, facets)
