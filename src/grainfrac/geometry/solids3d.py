"""3D specimen solids in metres: prisms along z with flat, faceted and cut sides.

Every solid here is a prism along z (a cross-section in x, y from ``lo[2]`` to
``hi[2]``), which is what the tessellation fills. Its boundary is made of:

- **flat sides**, planes normal to a coordinate axis (the box faces, the ends of
  a cylinder, the NSCB base). The tessellation mirrors every seed across them,
  so they are exact Voronoi faces.
- **facets**: the lateral surface of a cylinder or the NSCB arc, a regular
  polygon whose vertices lie on the nominal circle with one facet per zone of
  circumference or less (as the 2D outlines and the borehole). Each facet is a
  half-space that clips the cells; a cylinder is therefore a convex polyhedron
  given by half-spaces.
- the **borehole**: a faceted prism along z removed from the solid (ring seeds
  mirrored across its facets, see :mod:`grainfrac.geometry.tessellation3d`).
- **parts**: a solid that is not convex (the NSCB notch) is the union of convex
  parts, and a cut solid (the penny block) is split along a plane. Each part is
  a list of half-spaces; those on the specimen surface name a side, the others
  are internal cut planes. Cells are clipped to each part they overlap: pieces of
  one cell in two parts share the cut face.

Side names (``x-`` ... ``z+``, ``lateral``, ``base``, ``arc``, ``notch``,
``borehole``) name node sets and fluid boundaries. Named **lines** along z on
the surface (the Brazilian loading lines, the NSCB supports and loading point)
give extra node sets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from grainfrac.errors import GeometryError
from grainfrac.units import MM

BOX_SIDES = ("x-", "x+", "y-", "y+", "z-", "z+")
BOREHOLE = "borehole"
LATERAL = "lateral"
NOTCH = "notch"


@dataclass(frozen=True)
class FlatSide:
    """A specimen side on the plane ``x[axis] = value``.

    ``inward`` is +1 when the rock lies at ``x[axis] >= value`` (a lower side),
    -1 when it lies below.
    """

    name: str
    axis: int
    value: float
    inward: int


@dataclass(frozen=True)
class Part:
    """A convex part of a solid: the half-spaces ``n . x <= d`` (unit ``n``).

    Attributes
    ----------
    planes : np.ndarray
        (m, 4) rows ``(n, d)``.
    side : tuple[str, ...]
        The specimen side each plane lies on, ``""`` for an internal cut plane.
    across : tuple[int, ...]
        For an internal plane, the part on its other side; -1 for a side.
    """

    planes: np.ndarray
    side: tuple[str, ...]
    across: tuple[int, ...]


def _box_flat(lo: np.ndarray, hi: np.ndarray) -> tuple[FlatSide, ...]:
    return tuple(FlatSide(f"{'xyz'[k]}{'-+'[s]}", k, float((lo, hi)[s][k]), 1 - 2 * s)
                 for k in range(3) for s in range(2))


@dataclass(frozen=True)
class Solid:
    """A prism along z: a box (default) or a faceted cylinder, with optional borehole,
    cut-out notch and cut plane.

    Attributes
    ----------
    kind : str
        Specimen name (``slab``, ``penny``, ``cylinder``, ``disk``, ``semi_disk``,
        ``hollow_cylinder``).
    lo, hi : np.ndarray
        (3,) corners of the bounding box (m).
    borehole_radius : float
        Nominal radius (m): the facet vertices lie on this circle; 0 for none.
    borehole_facets : int
        Number of wall facets (0 for none).
    flat : tuple[FlatSide, ...] | None
        The flat sides; None for the six faces of the bounding box.
    facets : np.ndarray
        (k, 4) half-spaces ``(n, d)``, ``n . x <= d``, of the faceted lateral
        surface (named ``facet_side``); empty for a box.
    facet_side : str
        Side name of the facets.
    section_area : float | None
        Net cross-section (m2); None for a box (its width x height less the borehole).
    parts : tuple[Part, ...]
        Convex parts; empty when the solid is one convex part.
    split_grains : bool
        True when pieces of one cell in different parts are different grains (a
        plane of grain faces, the penny block); else they are one grain.
    cut_z : float | None
        Height of the penny block's cut plane (m).
    disc_radius : float
        Nominal radius of the pre-cut disc on the cut plane (m); 0 for none.
    disc_facets : int
        Facets of the disc polygon, a regular polygon of the circle's area
        (:attr:`disc_vertex_radius`).
    notch : np.ndarray | None
        (k, 3) half-planes ``(n_x, n_y, d)`` whose intersection is the notch slot
        removed from the section (for the ``notch`` node set).
    lines : dict[str, tuple[float, float]]
        Named lines along z on the surface, by their (x, y) (m).
    """

    kind: str
    lo: np.ndarray
    hi: np.ndarray
    borehole_radius: float = 0.0
    borehole_facets: int = 0
    flat: tuple[FlatSide, ...] | None = None
    facets: np.ndarray = field(default_factory=lambda: np.empty((0, 4)))
    facet_side: str = LATERAL
    section_area: float | None = None
    parts: tuple[Part, ...] = ()
    split_grains: bool = False
    cut_z: float | None = None
    disc_radius: float = 0.0
    disc_facets: int = 0
    notch: np.ndarray | None = None
    lines: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def extent(self) -> np.ndarray:
        return self.hi - self.lo

    @property
    def flat_sides(self) -> tuple[FlatSide, ...]:
        return _box_flat(self.lo, self.hi) if self.flat is None else self.flat

    @property
    def has_borehole(self) -> bool:
        return self.borehole_radius > 0

    @property
    def apothem(self) -> float:
        """Distance from the axis to the borehole's facet planes (m)."""
        return self.borehole_radius * math.cos(math.pi / self.borehole_facets)

    @property
    def borehole_area(self) -> float:
        """Cross-section of the faceted borehole (m2)."""
        if not self.has_borehole:
            return 0.0
        return regular_polygon_area(self.borehole_radius, self.borehole_facets)

    @property
    def area(self) -> float:
        """Net cross-section of the faceted solid (m2)."""
        if self.section_area is not None:
            return self.section_area - self.borehole_area
        e = self.extent
        return float(e[0] * e[1]) - self.borehole_area

    @property
    def volume(self) -> float:
        """Exact volume of the faceted solid (m3)."""
        if self.section_area is None:
            e = self.extent
            return float(e[0] * e[1] * e[2] - self.borehole_area * e[2])
        return self.area * float(self.extent[2])

    @property
    def disc_vertex_radius(self) -> float:
        """Circumradius of the disc polygon (m): its area is that of the nominal circle,
        so a crack of the disc's area has the nominal radius (for n = 16 the vertices lie
        1.3 % outside the circle, the facet midpoints 1.3 % inside)."""
        if not self.disc_facets:
            return 0.0
        n = self.disc_facets
        return self.disc_radius * math.sqrt(2 * math.pi / (n * math.sin(2 * math.pi / n)))

    @property
    def disc_area(self) -> float:
        """Area of the faceted pre-cut disc (m2), pi x disc_radius^2; 0 without one."""
        if not self.disc_facets:
            return 0.0
        return regular_polygon_area(self.disc_vertex_radius, self.disc_facets)

    @property
    def sides(self) -> tuple[str, ...]:
        """Side names; a face on the surface is labelled ``-1 - k`` for ``sides[k]``."""
        names = [f.name for f in self.flat_sides]
        if len(self.facets):
            names.append(self.facet_side)
        for part in self.parts:
            names.extend(s for s in part.side if s and s not in names)
        if self.has_borehole:
            names.append(BOREHOLE)
        return tuple(names)

    @property
    def permeable_sides(self) -> tuple[str, ...]:
        """The sides around the z axis (all but the ends and the borehole): the
        fixed-pressure boundary of a slab (paper Fig. 9c) and its analogue."""
        return tuple(s for s in self.sides if s not in ("z-", "z+", BOREHOLE))

    def facet_normals(self) -> np.ndarray:
        """(n, 3) unit normals of the borehole's facet planes, from the axis into the rock."""
        return polygon_normals(self.borehole_facets)

    def clip_halfspaces(self) -> np.ndarray:
        """The facets as Qhull half-spaces: rows ``(n, -d)`` with ``n . x - d <= 0``."""
        return np.column_stack((self.facets[:, :3], -self.facets[:, 3]))

    def inside(self, x: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """True for points at least ``margin`` inside the solid (rough at the corners)."""
        ok = np.ones(len(x), dtype=bool)
        for f in self.flat_sides:
            ok &= f.inward * (x[:, f.axis] - f.value) >= margin
        if len(self.facets):
            ok &= np.max(x @ self.facets[:, :3].T - self.facets[:, 3], axis=1) <= -margin
        if self.has_borehole:
            ok &= np.max(x @ self.facet_normals().T, axis=1) >= self.apothem + margin
        if self.notch is not None:
            ok &= self.notch_distance(x) >= margin
        return ok

    def notch_distance(self, x: np.ndarray) -> np.ndarray:
        """Distance (m) of points outside the notch slot to its nearest wall plane
        (negative inside the slot)."""
        n = self.notch
        return np.max(x[:, :2] @ n[:, :2].T - n[:, 2], axis=1)

    def on_sides(self, x: np.ndarray, tol: float = 1e-9) -> dict[str, np.ndarray]:
        """Which points (of the solid) lie on each side, within ``tol`` (m)."""
        out: dict[str, np.ndarray] = {}
        for f in self.flat_sides:
            out[f.name] = np.abs(x[:, f.axis] - f.value) < tol
        if len(self.facets):
            out[self.facet_side] = np.min(
                np.abs(x @ self.facets[:, :3].T - self.facets[:, 3]), axis=1) < tol
        if self.notch is not None:
            out[NOTCH] = np.abs(self.notch_distance(x)) < tol
        if self.has_borehole:
            d = x @ self.facet_normals().T
            out[BOREHOLE] = (np.abs(d.max(axis=1) - self.apothem) < tol) & (
                np.abs(x[:, 2] - 0.5 * (self.lo[2] + self.hi[2])) <= 0.5 * self.extent[2] + tol)
        return out


def regular_polygon_area(radius: float, n: int) -> float:
    """Area of a regular ``n``-gon with its vertices on a circle of ``radius`` (m2)."""
    return 0.5 * n * radius ** 2 * math.sin(2 * math.pi / n)


def polygon_normals(n: int) -> np.ndarray:
    """(n, 3) unit facet normals of a regular ``n``-gon with a vertex on +x (angles
    ``(k + 1/2) 2 pi / n``), pointing away from its centre."""
    phi = (np.arange(n) + 0.5) * 2 * math.pi / n
    return np.column_stack((np.cos(phi), np.sin(phi), np.zeros_like(phi)))


def facet_count(radius: float, zone_size: float, multiple: int = 1) -> int:
    """Facets of a circle: one per zone of circumference or less, at least 12, rounded up
    to a multiple of ``multiple`` (4 puts vertices on the +-x and +-y axes)."""
    n = max(12, math.ceil(2 * math.pi * radius / zone_size))
    return multiple * math.ceil(n / multiple)


def box_solid(kind: str, width_mm: float, height_mm: float, thickness_mm: float,
              borehole_diameter_mm: float, zone_size: float) -> Solid:
    """A box centred on the z axis (x, y) from z = 0 to the thickness, with a borehole.

    The borehole has one facet per zone size of circumference, at least 12.
    """
    w, h, t = width_mm * MM, height_mm * MM, thickness_mm * MM
    radius = 0.5 * borehole_diameter_mm * MM
    if radius > 0 and radius >= 0.5 * min(w, h):
        raise GeometryError("the borehole does not fit in the box")
    facets = facet_count(radius, zone_size) if radius > 0 else 0
    return Solid(kind, np.array([-w / 2, -h / 2, 0.0]), np.array([w / 2, h / 2, t]),
                 radius, facets)


def penny_solid(size_mm: float, disc_diameter_mm: float, zone_size: float) -> Solid:
    """The penny-shaped crack block (paper Fig. 8): a cube centred on the z axis from
    z = 0 to ``size``, cut at mid-height into a lower and an upper part.

    Every cell crossing the mid-plane is split there into two grains, so the
    plane is made of grain faces; a faceted disc of ``disc_diameter`` centred on
    the axis is made of whole grain faces (see the tessellation).
    """
    s = size_mm * MM
    radius = 0.5 * disc_diameter_mm * MM
    if not 0 < radius < 0.25 * s:
        raise GeometryError(f"the disc ({disc_diameter_mm:g} mm) must be narrower than half "
                            f"the block ({size_mm:g} mm)")
    zc = 0.5 * s
    lower = Part(np.array([[0.0, 0.0, 1.0, zc]]), ("",), (1,))
    upper = Part(np.array([[0.0, 0.0, -1.0, -zc]]), ("",), (0,))
    return Solid("penny", np.array([-s / 2, -s / 2, 0.0]), np.array([s / 2, s / 2, s]),
                 parts=(lower, upper), split_grains=True, cut_z=zc, disc_radius=radius,
                 disc_facets=facet_count(radius, zone_size))


def _circle_facets(radius: float, n: int, first: int, count: int) -> np.ndarray:
    """Half-spaces of facets ``first .. first + count - 1`` of a regular n-gon on the axis."""
    normals = polygon_normals(n)[first:first + count]
    return np.column_stack((normals, np.full(count, radius * math.cos(math.pi / n))))


def cylinder_solid(kind: str, diameter_mm: float, length_mm: float, zone_size: float,
                   lines: dict[str, tuple[float, float]] | None = None,
                   borehole_diameter_mm: float = 0.0) -> Solid:
    """A faceted cylinder on the z axis from z = 0 to ``length`` (UCS, permeability,
    Brazilian disc; with a borehole along the axis, the hollow cylinder of the lab HS
    test). Facets: a multiple of 4, so that the polygon has vertices at +-x and +-y (the
    Brazilian loading lines); the borehole's as in :func:`box_solid`."""
    r, length = 0.5 * diameter_mm * MM, length_mm * MM
    n = facet_count(r, zone_size, multiple=4)
    lo, hi = np.array([-r, -r, 0.0]), np.array([r, r, length])
    flat = (FlatSide("z-", 2, 0.0, 1), FlatSide("z+", 2, length, -1))
    hole = 0.5 * borehole_diameter_mm * MM
    if hole >= 0.5 * r:
        raise GeometryError("the borehole must be narrower than half the cylinder")
    return Solid(kind, lo, hi, borehole_radius=hole,
                 borehole_facets=facet_count(hole, zone_size) if hole > 0 else 0, flat=flat,
                 facets=_circle_facets(r, n, 0, n), section_area=regular_polygon_area(r, n),
                 lines=dict(lines or {}))


def semi_disk_solid(diameter_mm: float, thickness_mm: float, notch_length_mm: float,
                    notch_width_mm: float, support_span_mm: float, zone_size: float) -> Solid:
    """The NSCB specimen: a half disc (flat base on y = 0, arc above) from z = 0 to the
    thickness, with a slot of ``notch_width`` rising ``notch_length`` from the base centre.

    The slot makes the section non-convex. It is split into three convex parts by
    planes at 45 degrees rising from the notch tip's corners (left of the slot,
    above its tip, right of it): cut planes along the slot walls would be coplanar
    with them, and a piece's flat hull face must be one face for the mesher. A cell
    crossing a 45-degree plane is cut there into pieces of one grain (two grains if
    its pieces do not touch, e.g. on both sides of the slot).
    """
    r, t = 0.5 * diameter_mm * MM, thickness_mm * MM
    a, half_w = notch_length_mm * MM, 0.5 * notch_width_mm * MM
    n = facet_count(r, zone_size, multiple=4)  # of the full circle; half of them on the arc
    lo, hi = np.array([-r, 0.0, 0.0]), np.array([r, r, t])
    flat = (FlatSide("base", 1, 0.0, 1), FlatSide("z-", 2, 0.0, 1), FlatSide("z+", 2, t, -1))
    area = 0.5 * regular_polygon_area(r, n)
    parts: tuple[Part, ...] = ()
    notch = None
    if a > 0:
        area -= 2 * half_w * a
        q = 1 / math.sqrt(2)
        c = (a - half_w) * q  # the 45-degree planes pass through the tip corners
        left = Part(np.array([[1.0, 0, 0, -half_w], [q, q, 0, c]]), (NOTCH, ""), (-1, 1))
        middle = Part(np.array([[0, -1.0, 0, -a], [-q, -q, 0, -c], [q, -q, 0, -c]]),
                      (NOTCH, "", ""), (-1, 0, 2))
        right = Part(np.array([[-1.0, 0, 0, -half_w], [-q, q, 0, c]]), (NOTCH, ""), (-1, 1))
        parts = (left, middle, right)
        notch = np.array([[1.0, 0.0, half_w], [-1.0, 0.0, half_w], [0.0, 1.0, a]])
    s = 0.5 * support_span_mm * MM
    lines = {"support_x-": (-s, 0.0), "support_x+": (s, 0.0), "load_y+": (0.0, r)}
    return Solid("semi_disk", lo, hi, flat=flat, facets=_circle_facets(r, n, 0, n // 2),
                 facet_side="arc", section_area=area, parts=parts, notch=notch, lines=lines)


def specimen_solid(spec, zone_size: float, wall_zone_size: float | None = None) -> Solid:
    """The 3D solid of a specimen schema (millimetres in, metres out).

    A slab's borehole is faceted at ``wall_zone_size`` when given (zones refined at
    the wall), else at ``zone_size``.

    ``slab``: box with a borehole along z; ``penny``: the cut cube; ``rectangle``:
    the cylinder it is the section of (diameter = width, axis along z, length =
    height); ``disk``: Brazilian disc (axis along z, length = thickness);
    ``semi_disk``: NSCB half disc (axis along z, base on y = 0); ``hollow_cylinder``:
    the cylinder with a borehole along its axis (z).
    """
    shape = spec.shape
    if shape == "slab":
        return box_solid("slab", spec.width_mm, spec.height_mm, spec.thickness_mm,
                         spec.borehole_diameter_mm, wall_zone_size or zone_size)
    if shape == "penny":
        return penny_solid(spec.size_mm, spec.disc_diameter_mm, zone_size)
    if shape == "rectangle":
        return cylinder_solid("cylinder", spec.width_mm, spec.height_mm, zone_size)
    if shape == "disk":
        r = 0.5 * spec.diameter_mm * MM
        return cylinder_solid("disk", spec.diameter_mm, spec.thickness_mm, zone_size,
                              {"load_y-": (0.0, -r), "load_y+": (0.0, r)})
    if shape == "hollow_cylinder":
        return cylinder_solid("hollow_cylinder", spec.diameter_mm, spec.height_mm, zone_size,
                              borehole_diameter_mm=spec.borehole_diameter_mm)
    if shape == "semi_disk":
        return semi_disk_solid(spec.diameter_mm, spec.thickness_mm, spec.notch_length_mm,
                               spec.notch_width_mm, spec.support_span_mm, zone_size)
    raise GeometryError(f"no 3D solid for the shape {shape!r}")
