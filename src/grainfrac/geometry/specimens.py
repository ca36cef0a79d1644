"""Specimen outlines in 2D (plane strain), in metres.

Each specimen is a polygon (possibly with a borehole) plus named sides. Sides
name the node sets and boundary faces that loading acts on: the outer sides of
a slab, the borehole wall, the platen-facing edges of a UCS rectangle, the
notch of an NSCB semi-disk.

The schemas take millimetres like the lab sheets; :func:`outline` converts once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
import shapely
from pydantic import Field, model_validator

from grainfrac.io.config import StrictModel
from grainfrac.units import MM


class SlabSpec(StrictModel):
    """Square/rectangular slab with a central borehole (paper Fig. 9; sizes not stated there)."""

    shape: Literal["slab"] = Field("slab", description="selects this shape")
    width_mm: float = Field(100.0, gt=0, description="extent along x [mm]")
    height_mm: float = Field(100.0, gt=0, description="extent along y [mm]")
    thickness_mm: float = Field(
        10.0, gt=0, description="out-of-plane thickness of the plane-strain slab [mm]")
    borehole_diameter_mm: float = Field(
        10.0, ge=0, description="central borehole [mm]; 0: none; < half the smallest side")

    @model_validator(mode="after")
    def _borehole_fits(self) -> SlabSpec:
        limit = min(self.width_mm, self.height_mm) / 2
        if self.borehole_diameter_mm >= limit:
            raise ValueError(
                f"borehole_diameter_mm: must be < half the smallest side ({limit:g} mm), "
                f"got {self.borehole_diameter_mm:g}"
            )
        return self


class DiskSpec(StrictModel):
    """Brazilian (BTS) disk, section of a cylinder (paper Table 3: D 38 mm, T 19 mm)."""

    shape: Literal["disk"] = Field("disk", description="selects this shape")
    diameter_mm: float = Field(38.0, gt=0, description="disk diameter D [mm]")
    thickness_mm: float = Field(19.0, gt=0, description="disk thickness T [mm]")


class SemiDiskSpec(StrictModel):
    """Notched semi-circular bend (NSCB) specimen (paper Table 3: D 50, T 20, A 8.33, S 40 mm)."""

    shape: Literal["semi_disk"] = Field("semi_disk", description="selects this shape")
    diameter_mm: float = Field(50.0, gt=0, description="diameter D of the full disk [mm]")
    thickness_mm: float = Field(20.0, gt=0, description="thickness T [mm]")
    notch_length_mm: float = Field(
        8.33, ge=0, description="notch length A [mm]; < 0.8 x radius")
    notch_width_mm: float = Field(1.0, gt=0, description="notch width [mm]; < radius / 4")
    support_span_mm: float = Field(
        40.0, gt=0, description="distance S between the two supports [mm]; < diameter_mm")

    @model_validator(mode="after")
    def _notch_fits(self) -> SemiDiskSpec:
        radius = self.diameter_mm / 2
        if self.notch_length_mm >= 0.8 * radius:
            raise ValueError(
                f"notch_length_mm: must be < 0.8 x radius ({0.8 * radius:g} mm), "
                f"got {self.notch_length_mm:g}"
            )
        if self.notch_width_mm >= 0.25 * radius:
            raise ValueError(
                f"notch_width_mm: must be < radius / 4 ({0.25 * radius:g} mm), "
                f"got {self.notch_width_mm:g}"
            )
        if self.support_span_mm >= self.diameter_mm:
            raise ValueError(
                f"support_span_mm: must be < diameter_mm ({self.diameter_mm:g}), "
                f"got {self.support_span_mm:g}"
            )
        return self


class RectangleSpec(StrictModel):
    """UCS specimen section (paper Table 3: D 22.5 mm, H 45 mm)."""

    shape: Literal["rectangle"] = Field("rectangle", description="selects this shape")
    width_mm: float = Field(22.5, gt=0, description="width (the cylinder's diameter D) [mm]")
    height_mm: float = Field(45.0, gt=0, description="height H, the loaded direction [mm]")
    thickness_mm: float = Field(22.5, gt=0, description="out-of-plane thickness [mm]")


class PennySpec(StrictModel):
    """Penny-shaped crack block (paper Fig. 8), 3D only: a cube whose mid-plane is made of
    grain faces, with a pre-cut disc centred on the vertical axis at mid-height."""

    shape: Literal["penny"] = Field("penny", description="selects this shape")
    size_mm: float = Field(60.0, gt=0, description="edge of the cube [mm]")
    disc_diameter_mm: float = Field(
        10.0, gt=0, description="diameter of the pre-cut disc [mm]; < size_mm / 2")

    @model_validator(mode="after")
    def _disc_fits(self) -> PennySpec:
        if self.disc_diameter_mm >= 0.5 * self.size_mm:
            raise ValueError(
                f"disc_diameter_mm: must be < half of size_mm ({0.5 * self.size_mm:g} mm), "
                f"got {self.disc_diameter_mm:g}"
            )
        return self


class HollowCylinderSpec(StrictModel):
    """The laboratory hydraulic stimulation specimen (paper Sect. 2.3 and 5.2, Fig. 4), 3D
    only: a cylinder with a central hole along its axis (z) through its whole height."""

    shape: Literal["hollow_cylinder"] = Field("hollow_cylinder", description="selects this shape")
    diameter_mm: float = Field(22.5, gt=0, description="outer diameter [mm]")
    height_mm: float = Field(45.0, gt=0, description="height along the axis [mm]")
    borehole_diameter_mm: float = Field(
        3.0, gt=0, description="central hole [mm]; < half the diameter")

    @model_validator(mode="after")
    def _hole_fits(self) -> HollowCylinderSpec:
        if self.borehole_diameter_mm >= 0.5 * self.diameter_mm:
            raise ValueError(
                f"borehole_diameter_mm: must be < half the diameter ({0.5 * self.diameter_mm:g}"
                f" mm), got {self.borehole_diameter_mm:g}")
        return self


SpecimenShapeSpec = Annotated[
    SlabSpec | DiskSpec | SemiDiskSpec | RectangleSpec | PennySpec | HollowCylinderSpec,
    Field(discriminator="shape"),
]

#: Shapes each dimension builds. In 3D a slab is a box with a borehole along z
#: through its thickness (the paper's 100 mm cube is the slab 100 x 100 x 100);
#: ``rectangle`` is the cylinder it is the section of (UCS and permeability:
#: diameter = width, length = height), ``disk`` and ``semi_disk`` are the
#: Brazilian and NSCB specimens with their axes along z; ``penny`` and
#: ``hollow_cylinder`` are 3D only.
SHAPES_2D = ("slab", "disk", "semi_disk", "rectangle")
SHAPES_3D = ("slab", "penny", "rectangle", "disk", "semi_disk", "hollow_cylinder")
#: The paper does not state the slab's thickness; 3D slabs default to this (mm).
SLAB_THICKNESS_3D_MM = 20.0


@dataclass(frozen=True)
class Outline:
    """A specimen outline in metres.

    Attributes
    ----------
    kind : str
        ``slab``, ``disk``, ``semi_disk`` or ``rectangle``.
    polygon : shapely.Polygon
        The solid region (holes for boreholes); arcs are fine polygons whose
        vertices lie exactly on the circle.
    sides : dict[str, shapely.LineString]
        Named parts of the boundary, used to classify boundary vertices.
    corners : np.ndarray
        (k, 2) outline vertices that must never move (sharp corners).
    thickness : float
        Out-of-plane thickness (m), used for forces and flow rates.
    borehole_center, borehole_radius
        Centre (m) and radius (m) of the borehole; radius 0 when there is none.
    """

    kind: str
    polygon: shapely.Polygon
    sides: dict[str, shapely.LineString]
    corners: np.ndarray
    thickness: float
    borehole_center: tuple[float, float] = (0.0, 0.0)
    borehole_radius: float = 0.0

    @property
    def area(self) -> float:
        return float(self.polygon.area)

    def side_of_points(self, xy: np.ndarray, tol: float) -> dict[str, np.ndarray]:
        """Boolean masks telling which points lie on each side (within ``tol``)."""
        pts = shapely.points(xy)
        return {name: shapely.distance(line, pts) <= tol for name, line in self.sides.items()}


def arc_points(
    center: tuple[float, float], radius: float, theta0: float, theta1: float, n: int
) -> np.ndarray:
    """``n + 1`` points on a circular arc from ``theta0`` to ``theta1`` (inclusive)."""
    theta = np.linspace(theta0, theta1, n + 1)
    return np.column_stack(
        (center[0] + radius * np.cos(theta), center[1] + radius * np.sin(theta))
    )


def arc_segments(radius: float, sweep: float, zone_size: float, minimum: int) -> int:
    """Number of chords for an arc: about half a zone each, never fewer than ``minimum``."""
    return max(minimum, math.ceil(radius * sweep / (0.5 * zone_size)))


def outline(spec: SlabSpec | DiskSpec | SemiDiskSpec | RectangleSpec, zone_size: float) -> Outline:
    """Build the outline of a specimen in metres.

    Parameters
    ----------
    spec
        Specimen schema in millimetres.
    zone_size
        Target element edge length (m); sets the chord length of arcs.
    """
    thickness = spec.thickness_mm * MM
    if isinstance(spec, SlabSpec | RectangleSpec):
        w, h = spec.width_mm * MM, spec.height_mm * MM
        corners = np.array([[-w / 2, -h / 2], [w / 2, -h / 2], [w / 2, h / 2], [-w / 2, h / 2]])
        sides = {
            "bottom": shapely.LineString([corners[0], corners[1]]),
            "right": shapely.LineString([corners[1], corners[2]]),
            "top": shapely.LineString([corners[2], corners[3]]),
            "left": shapely.LineString([corners[3], corners[0]]),
        }
        holes = []
        radius = 0.0
        if isinstance(spec, SlabSpec) and spec.borehole_diameter_mm > 0:
            radius = spec.borehole_diameter_mm * MM / 2
            n = arc_segments(radius, 2 * math.pi, zone_size, minimum=32)
            ring = arc_points((0.0, 0.0), radius, 0.0, 2 * math.pi, n)[:-1]
            holes.append(ring[::-1])
            sides["borehole"] = shapely.LinearRing(ring)
        polygon = shapely.Polygon(corners, holes)
        return Outline(spec.shape, polygon, sides, corners, thickness, (0.0, 0.0), radius)

    if isinstance(spec, DiskSpec):
        radius = spec.diameter_mm * MM / 2
        n = arc_segments(radius, 2 * math.pi, zone_size, minimum=64)
        ring = arc_points((0.0, 0.0), radius, 0.0, 2 * math.pi, n)[:-1]
        polygon = shapely.Polygon(ring)
        sides = {"perimeter": shapely.LinearRing(ring)}
        return Outline(spec.shape, polygon, sides, np.empty((0, 2)), thickness)

    # Semi-disk: flat base on y = 0, notch rising from the base centre.
    radius = spec.diameter_mm * MM / 2
    a = spec.notch_length_mm * MM
    half_w = spec.notch_width_mm * MM / 2
    n = arc_segments(radius, math.pi, zone_size, minimum=48)
    arc = arc_points((0.0, 0.0), radius, 0.0, math.pi, n)
    if a > 0:
        notch = np.array([[-half_w, 0.0], [-half_w, a], [half_w, a], [half_w, 0.0]])
    else:
        notch = np.empty((0, 2))
    ring = np.vstack((arc, notch))
    polygon = shapely.Polygon(ring)
    sides = {
        "arc": shapely.LineString(arc),
        "base": shapely.MultiLineString(
            [[(-radius, 0.0), (-half_w, 0.0)], [(half_w, 0.0), (radius, 0.0)]]
            if a > 0
            else [[(-radius, 0.0), (radius, 0.0)]]
        ),
    }
    corners = [arc[0], arc[-1]]
    if a > 0:
        sides["notch"] = shapely.LineString(notch)
        corners.extend(notch)
    return Outline(spec.shape, polygon, sides, np.array(corners), thickness)
