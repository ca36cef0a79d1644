"""Fracture geometry of 3D stimulation runs (issue 43; paper Sect. 5, Fig. 19).

A 3D run records its cracks as failed sub-contacts: points on the grain faces
(``mesh.contact_x``), each standing for a patch of its face (``contact_area``,
a third of every face triangle around the point). From a 3D assembly and the
cracked sub-contact ids (with their failure modes) this module gives:

* radial fractures on a plane normal to the well (the top face, the
  mid-height plane): the cracks within one zone size of the plane, projected
  to (x, y), counted the 2D way (:func:`grainfrac.analysis.fractures.radial_fractures`);
* the fracture extent: the largest distance from the borehole axis reached by
  a crack connected (in 3D) to the well;
* the tortuosity of the main fracture on the top face, the 2D way
  (:func:`grainfrac.analysis.fractures.fracture_tortuosity`);
* the fracture surface area (sum of the cracked sub-contact areas), split
  into tensile and shear, and their ratio;
* cross-sections: the traces that the cracked patches leave on planes
  z = const (by default at 1/8, 3/8, 5/8 and 7/8 of the height, as the four
  sections of paper Fig. 19c).

The borehole axis is the z axis through (0, 0) (:mod:`grainfrac.geometry.solids3d`).
SI units throughout (m, m2).

A sub-contact's patch is its tributary region on the face: in each face
triangle around its point, the quadrilateral from the point to the two edge
midpoints and the triangle's centroid. These quadrilaterals have exactly a
third of the triangle's area, so the patches of a face tile it and their
areas are the mesh's ``contact_area``: the surface drawn and cut is the
surface counted.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from grainfrac.analysis.fractures import (
    CONNECT_FACTOR,
    RadialFractures,
    _components,
    _edges,
    _mode_codes,
    crack_counts,
    fracture_tortuosity,
    radial_fractures,
)
from grainfrac.assembly import GrainAssembly
from grainfrac.geometry.meshing3d import GrainMesh3D
from grainfrac.physics.kernels import SHEAR, TENSILE

__all__ = [
    "SECTION_FRACTIONS",
    "CrossSection",
    "PlaneFractures",
    "contact_patches",
    "corner_quads",
    "cracked_contacts",
    "cross_sections",
    "fracture_area",
    "fracture_extent3d",
    "fracture_summary3d",
    "fracture_tortuosity3d",
    "grain_boundary_section",
    "plane_band",
    "patch_triangles",
    "plane_height",
    "polygon_areas",
    "radial_fractures3d",
    "section_segments",
]

#: Heights of the default cross-sections, as fractions of the specimen height
#: (four sections along the well, paper Fig. 19c).
SECTION_FRACTIONS = (0.125, 0.375, 0.625, 0.875)


# --------------------------------------------------------------------------- inputs


def _mesh3d(assembly: GrainAssembly | GrainMesh3D) -> GrainMesh3D:
    mesh = assembly if isinstance(assembly, GrainMesh3D) else getattr(assembly, "mesh", None)
    if not isinstance(mesh, GrainMesh3D):
        raise ValueError("assembly: a 3D assembly (GrainMesh3D mesh) is needed, got "
                         f"{type(mesh if mesh is not None else assembly).__name__}")
    return mesh


def _contact_ids(mesh: GrainMesh3D, contact) -> np.ndarray:
    """Validated sub-contact ids: integers, in range, each once."""
    c = np.asarray(contact)
    if c.ndim != 1:
        raise ValueError(f"contact: a 1-D array of sub-contact ids is needed (got shape {c.shape})")
    if c.size == 0:
        return np.empty(0, dtype=np.int64)
    if c.dtype.kind not in "iu":
        raise ValueError(f"contact: sub-contact ids must be integers (got dtype {c.dtype})")
    c = c.astype(np.int64)
    n = mesh.n_contacts
    bad = (c < 0) | (c >= n)
    if np.any(bad):
        raise ValueError(f"contact: sub-contact id {int(c[bad][0])} out of range "
                         f"(0 ... {n - 1})")
    # A sub-contact fails once; listing it twice would count its area twice.
    ids, counts = np.unique(c, return_counts=True)
    if np.any(counts > 1):
        raise ValueError(f"contact: sub-contact {int(ids[counts > 1][0])} is listed "
                         f"{int(counts[counts > 1][0])} times")
    return c


def cracked_contacts(assembly: GrainAssembly | GrainMesh3D, contact,
                     mode=None) -> tuple[GrainMesh3D, np.ndarray, np.ndarray | None]:
    """Check a 3D crack set: the mesh, the sub-contact ids and the mode codes.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly (or its mesh).
    contact : array_like of int
        (n,) cracked sub-contact ids, each at most once.
    mode : array_like, optional
        (n,) failure mode per crack: ``kernels.TENSILE`` / ``kernels.SHEAR``
        codes or the names ``"tensile"`` / ``"shear"``.

    Returns
    -------
    (GrainMesh3D, np.ndarray, np.ndarray or None)
        The mesh, the ids (int64) and the mode codes (int64; ``None`` without ``mode``).

    Raises
    ------
    ValueError
        A 2D assembly, ids that are not integers, out of range or repeated,
        or modes that are unknown or do not match the ids in number; the
        message names the argument.
    """
    mesh = _mesh3d(assembly)
    ids = _contact_ids(mesh, contact)
    if mode is None:
        return mesh, ids, None
    try:
        codes = _mode_codes(mode)
    except ValueError as exc:
        raise ValueError(f"mode: {exc}") from None
    if codes.size != ids.size:
        raise ValueError(f"mode: {codes.size} modes for {ids.size} cracks in contact")
    return mesh, ids, codes


def plane_height(assembly: GrainAssembly | GrainMesh3D, plane: str | float) -> float:
    """Height z (m) of a plane normal to the well.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    plane : {"top", "mid", "bottom"} or float
        ``"top"`` is the top face (``solid.hi[2]``), ``"mid"`` the mid-height
        plane, ``"bottom"`` the bottom face; a number is a height in m, inside
        the specimen.

    Returns
    -------
    float
    """
    solid = _mesh3d(assembly).grains.solid
    lo, hi = float(solid.lo[2]), float(solid.hi[2])
    if isinstance(plane, str):
        heights = {"top": hi, "mid": 0.5 * (lo + hi), "bottom": lo}
        if plane not in heights:
            raise ValueError(f"plane: {plane!r} is not one of 'top', 'mid', 'bottom' or a "
                             "height in m")
        return heights[plane]
    z = float(plane)
    if not lo <= z <= hi:
        raise ValueError(f"plane: z = {z:g} m is outside the specimen ({lo:g} ... {hi:g} m)")
    return z


def plane_band(assembly: GrainAssembly | GrainMesh3D, contact, z: float, *,
               half_width: float | None = None) -> np.ndarray:
    """Cracks near a plane z = const: indices into ``contact`` of those within ``half_width``.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    z : float
        Height of the plane (m).
    half_width : float, optional
        Largest distance (m) of a crack from the plane; default one zone size,
        the spacing of the sub-contacts, so that a fracture crossing the plane
        leaves about one crack per zone along its trace.

    Returns
    -------
    np.ndarray
        Ascending indices into ``contact``.
    """
    mesh, ids, _ = cracked_contacts(assembly, contact)
    w = mesh.zone_size if half_width is None else float(half_width)
    if not w > 0:
        raise ValueError(f"half_width must be > 0 (got {w})")
    return np.flatnonzero(np.abs(mesh.contact_x[ids, 2] - float(z)) <= w)


def _well(mesh: GrainMesh3D, what: str) -> float:
    if not mesh.has_borehole:
        raise ValueError(f"{what} is measured around the borehole, and this specimen has none")
    return float(mesh.borehole_radius)


def _connect(mesh: GrainMesh3D, connect_distance: float | None) -> float:
    d = CONNECT_FACTOR * mesh.zone_size if connect_distance is None else float(connect_distance)
    if not d > 0:
        raise ValueError(f"connect_distance must be > 0 (got {d})")
    return d


# --------------------------------------------------------------------------- radial fractures


@dataclass(frozen=True)
class PlaneFractures:
    """Radial fractures counted on one plane normal to the well.

    Attributes
    ----------
    z : float
        Height of the plane (m).
    members : np.ndarray
        Indices into the crack list of the cracks within the band around the
        plane; the per-crack arrays of ``radial`` follow this order.
    radial : RadialFractures
        The 2D count on the projected cracks.
    """

    z: float
    members: np.ndarray
    radial: RadialFractures

    @property
    def count(self) -> int:
        """Number of radial fractures crossing the counting circle."""
        return self.radial.count


def radial_fractures3d(assembly: GrainAssembly | GrainMesh3D, contact, plane: str | float = "top",
                       *, connect_distance: float | None = None, radius: float | None = None,
                       angle_bin_deg: float = 10.0,
                       half_width: float | None = None) -> PlaneFractures:
    """Count the radial fractures on a plane normal to the well (the 2D way).

    The cracks within ``half_width`` (default one zone size) of the plane are
    projected to (x, y) and passed to
    :func:`grainfrac.analysis.fractures.radial_fractures` with the well at
    (0, 0) and the borehole radius: clusters of cracks within
    ``connect_distance`` of each other, connected to the well, are counted
    where they cross the circle of ``radius``.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly with a borehole.
    contact : array_like of int
        Cracked sub-contact ids.
    plane : {"top", "mid", "bottom"} or float, optional
        The plane (see :func:`plane_height`); default the top face.
    connect_distance : float, optional
        Connection distance (m); default ``CONNECT_FACTOR * zone_size``.
    radius : float, optional
        Counting circle (m); default twice the borehole radius.
    angle_bin_deg : float, optional
        Smallest angular gap (degrees) between two fractures.
    half_width : float, optional
        Band around the plane (m); default one zone size.

    Returns
    -------
    PlaneFractures
    """
    mesh, ids, _ = cracked_contacts(assembly, contact)
    well_radius = _well(mesh, "the number of radial fractures")
    d = _connect(mesh, connect_distance)
    z = plane_height(mesh, plane)
    members = plane_band(mesh, ids, z, half_width=half_width)
    xy = mesh.contact_x[ids[members], :2]
    radial = radial_fractures(xy[:, 0], xy[:, 1], (0.0, 0.0), well_radius=well_radius,
                              connect_distance=d, radius=radius, angle_bin_deg=angle_bin_deg)
    return PlaneFractures(z=z, members=members, radial=radial)


def fracture_extent3d(assembly: GrainAssembly | GrainMesh3D, contact, *,
                      connect_distance: float | None = None,
                      well_connected: bool = True) -> float | None:
    """Largest distance (m) of a crack from the borehole axis.

    As in 2D, only cracks connected to the well count by default: cracks
    within ``connect_distance`` of each other (in 3D) form clusters, and a
    cluster is connected to the well when one of its cracks lies within
    ``borehole_radius + connect_distance`` of the axis.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly (with a borehole when ``well_connected``).
    contact : array_like of int
        Cracked sub-contact ids.
    connect_distance : float, optional
        Connection distance (m); default ``CONNECT_FACTOR * zone_size``.
    well_connected : bool, optional
        False: the largest distance of any crack, connected or not.

    Returns
    -------
    float or None
        ``None`` when no crack counts.
    """
    mesh, ids, _ = cracked_contacts(assembly, contact)
    x = mesh.contact_x[ids]
    r = np.hypot(x[:, 0], x[:, 1])
    if not well_connected:
        return float(r.max()) if r.size else None
    well_radius = _well(mesh, "the well-connected fracture extent")
    d = _connect(mesh, connect_distance)
    labels = _components(len(x), _edges(x, d))
    connected = np.isin(labels, labels[r <= well_radius + d])
    return float(r[connected].max()) if np.any(connected) else None


def fracture_tortuosity3d(assembly: GrainAssembly | GrainMesh3D, contact,
                          plane: str | float = "top", *,
                          connect_distance: float | None = None,
                          half_width: float | None = None) -> float | None:
    """Tortuosity of the main fracture on a plane normal to the well (the 2D way).

    The cracks within ``half_width`` of the plane, projected to (x, y), go to
    :func:`grainfrac.analysis.fractures.fracture_tortuosity` with the well at
    (0, 0): geodesic length through consecutive cracks of the main fracture
    (through the well for a diametrical one) over the straight distance
    between its ends.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly with a borehole.
    contact : array_like of int
        Cracked sub-contact ids.
    plane : {"top", "mid", "bottom"} or float, optional
        Default the top face, where the paper measures it.
    connect_distance, half_width : float, optional
        As for :func:`radial_fractures3d`.

    Returns
    -------
    float or None
        ``None`` when there is no fracture with two distinct ends.
    """
    mesh, ids, _ = cracked_contacts(assembly, contact)
    well_radius = _well(mesh, "the tortuosity")
    d = _connect(mesh, connect_distance)
    members = plane_band(mesh, ids, plane_height(mesh, plane), half_width=half_width)
    xy = mesh.contact_x[ids[members], :2]
    return fracture_tortuosity(xy[:, 0], xy[:, 1], connect_distance=d, center=(0.0, 0.0),
                               well_radius=well_radius)


# --------------------------------------------------------------------------- area


def fracture_area(assembly: GrainAssembly | GrainMesh3D, contact,
                  mode) -> dict[str, float | None]:
    """Fracture surface area: the summed areas of the cracked sub-contacts, by mode.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).

    Returns
    -------
    dict
        ``fracture_area_m2``, ``tensile_area_m2``, ``shear_area_m2`` and
        ``tensile_shear_area_ratio`` (``None`` without shear cracks). The area
        is one side of each cracked grain boundary.
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    area = mesh.contact_area[ids]
    t = float(area[codes == TENSILE].sum())
    s = float(area[codes == SHEAR].sum())
    return {
        "fracture_area_m2": float(area.sum()),
        "tensile_area_m2": t,
        "shear_area_m2": s,
        "tensile_shear_area_ratio": (t / s) if s > 0 else None,
    }


# --------------------------------------------------------------------------- patches


def _triangles_of_faces(mesh: GrainMesh3D, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t, 3) point ids of the triangles of ``faces`` and (t,) the face of each."""
    if faces.size == 0:
        return np.empty((0, 3), dtype=np.int64), np.empty(0, dtype=np.int64)
    tris = [mesh.face_triangles[f] for f in faces]
    face = np.repeat(faces, [len(t) for t in tris])
    return np.concatenate(tris).astype(np.int64), face


def patch_triangles(assembly: GrainAssembly | GrainMesh3D,
                    contact) -> tuple[np.ndarray, np.ndarray]:
    """The face triangles that hold the patches of some sub-contacts.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Sub-contact ids.

    Returns
    -------
    triangles : np.ndarray
        (t, 3, 3) corners (m) of every triangle of the faces of the listed
        sub-contacts that has one of them as a corner.
    owner : np.ndarray
        (t, 3) index into ``contact`` of the sub-contact at each corner, -1
        where that corner's sub-contact is not listed.
    """
    mesh, ids, _ = cracked_contacts(assembly, contact)
    if ids.size == 0:
        return np.empty((0, 3, 3)), np.empty((0, 3), dtype=np.int64)
    tri, tri_face = _triangles_of_faces(mesh, np.unique(mesh.contact_face[ids]))
    # Every point of an interface face carries one sub-contact of that face:
    # find it by the (face, point) key.
    n_points = len(mesh.points)
    key = mesh.contact_face.astype(np.int64) * n_points + mesh.contact_point
    order = np.argsort(key)
    corner_key = tri_face[:, None] * n_points + tri
    corner_contact = order[np.searchsorted(key, corner_key, sorter=order)]
    position = np.full(mesh.n_contacts, -1, dtype=np.int64)
    position[ids] = np.arange(ids.size)
    owner = position[corner_contact]
    touched = np.any(owner >= 0, axis=1)
    return mesh.points[tri[touched]], owner[touched]


def corner_quads(triangles: np.ndarray, corner: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The third of a triangle that belongs to one corner, as a quadrilateral.

    Parameters
    ----------
    triangles : np.ndarray
        (t, 3, 3) triangle corners (m).
    corner, k : np.ndarray
        (q,) triangle index and corner (0, 1, 2) of each quadrilateral.

    Returns
    -------
    np.ndarray
        (q, 4, 3): the corner, the midpoint of the edge to the next corner, the
        centroid, the midpoint of the edge to the previous corner (convex, in
        the triangle's orientation, area a third of the triangle's).
    """
    p = triangles[corner]
    here = p[np.arange(len(k)), k]
    nxt = p[np.arange(len(k)), (k + 1) % 3]
    prv = p[np.arange(len(k)), (k + 2) % 3]
    return np.stack((here, 0.5 * (here + nxt), p.mean(axis=1), 0.5 * (here + prv)), axis=1)


def contact_patches(assembly: GrainAssembly | GrainMesh3D,
                    contact) -> tuple[np.ndarray, np.ndarray]:
    """The face patch of each sub-contact, as quadrilaterals.

    A sub-contact sits on a point of a grain face; its patch is, in every
    triangle of that face with the point as a corner, the quadrilateral
    (point, midpoint of one edge from it, triangle centroid, midpoint of the
    other edge from it). Each is a third of its triangle, so a patch's area
    is the sub-contact's ``contact_area`` and the patches of a face tile it.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Sub-contact ids.

    Returns
    -------
    quads : np.ndarray
        (q, 4, 3) corners of the quadrilaterals (m), convex and planar.
    owner : np.ndarray
        (q,) index into ``contact`` of the sub-contact each belongs to.
    """
    triangles, owner = patch_triangles(assembly, contact)
    t_idx, k = np.nonzero(owner >= 0)
    return corner_quads(triangles, t_idx, k), owner[t_idx, k]


def polygon_areas(polygons: np.ndarray) -> np.ndarray:
    """Areas of planar polygons.

    Parameters
    ----------
    polygons : np.ndarray
        (n, k, 3) corners (m), in order round each polygon; a repeated corner
        (a triangle padded to a quadrilateral) adds nothing.

    Returns
    -------
    np.ndarray
        (n,) areas (m2): half the norm of the summed fan cross products (the
        vector area), exact for any simple planar polygon.
    """
    p = np.asarray(polygons, dtype=float)
    a = p[:, 1:-1] - p[:, :1]
    b = p[:, 2:] - p[:, :1]
    return 0.5 * np.linalg.norm(np.cross(a, b).sum(axis=1), axis=1)


# --------------------------------------------------------------------------- sections


def section_segments(polygons, z: float) -> tuple[np.ndarray, np.ndarray]:
    """Cut convex planar polygons with the plane z = const.

    Parameters
    ----------
    polygons : array_like
        (n, k, 3) corners of convex planar polygons, in order round each (m).
    z : float
        Height of the plane (m).

    Returns
    -------
    segments : np.ndarray
        (s, 2, 2) (x, y) ends of the traces (m); polygons that only touch
        the plane at a point, or lie in it, leave none.
    polygon : np.ndarray
        (s,) index of the polygon each trace comes from.
    """
    p = np.asarray(polygons, dtype=float)
    if p.ndim != 3 or p.shape[2] != 3 or (p.size and p.shape[1] < 3):
        raise ValueError(f"polygons must be (n, k >= 3, 3), got shape {p.shape}")
    if len(p) == 0:
        return np.empty((0, 2, 2)), np.empty(0, dtype=np.int64)
    s = p[:, :, 2] - float(z)
    # Corners on the plane count as above it, so a convex polygon crossing the
    # plane has exactly two edges that change side (one per trace end).
    above = s >= 0
    s_next = np.roll(s, -1, axis=1)
    change = above != np.roll(above, -1, axis=1)
    row, edge = np.nonzero(change)  # row-major: a polygon's crossings are consecutive
    t = s[row, edge] / (s[row, edge] - s_next[row, edge])
    a = p[row, edge, :2]
    b = np.roll(p, -1, axis=1)[row, edge, :2]
    cut = a + t[:, None] * (b - a)
    counts = np.bincount(row, minlength=len(p))
    # Rounding can give a nearly flat polygon in the plane more than two
    # crossings; its trace is not defined to better than rounding, so drop it.
    keep = np.repeat(counts == 2, counts)
    cut, row = cut[keep].reshape(-1, 2, 2), row[keep][::2]
    length = np.hypot(*(cut[:, 1] - cut[:, 0]).T)
    nonzero = length > 0
    return cut[nonzero], row[nonzero]


@dataclass(frozen=True)
class CrossSection:
    """The traces of the cracks on one plane z = const.

    Attributes
    ----------
    z : float
        Height of the plane (m).
    fraction : float
        ``(z - bottom) / height``.
    segments : np.ndarray
        (k, 2, 2) (x, y) ends of the trace pieces (m), one per cut patch quadrilateral.
    contact : np.ndarray
        (k,) the cracked sub-contact of each piece.
    mode : np.ndarray
        (k,) its failure mode code.
    """

    z: float
    fraction: float
    segments: np.ndarray
    contact: np.ndarray
    mode: np.ndarray

    @property
    def n_cracks(self) -> int:
        """Number of cracked sub-contacts the plane cuts."""
        return int(np.unique(self.contact).size)

    def trace_length(self, mode: int | None = None) -> float:
        """Total length (m) of the traces, or of those of one mode code."""
        seg = self.segments if mode is None else self.segments[self.mode == mode]
        return float(np.hypot(*(seg[:, 1] - seg[:, 0]).T).sum())


def _fractions(fractions: Sequence[float]) -> np.ndarray:
    f = np.asarray(fractions, dtype=float).ravel()
    if f.size == 0 or not np.all((f >= 0) & (f <= 1)):
        raise ValueError(f"fractions: heights as fractions of the specimen height in [0, 1] "
                         f"are needed (got {list(f)})")
    return f


def cross_sections(assembly: GrainAssembly | GrainMesh3D, contact, mode,
                   fractions: Sequence[float] = SECTION_FRACTIONS) -> list[CrossSection]:
    """The cracks cut by planes z = const along the well, as 2D traces.

    Each cracked sub-contact's patch (:func:`contact_patches`) is cut by each
    plane; a fracture surface leaves a polyline of trace pieces.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).
    fractions : sequence of float, optional
        Plane heights as fractions of the specimen height from its bottom;
        default 1/8, 3/8, 5/8, 7/8 (:data:`SECTION_FRACTIONS`).

    Returns
    -------
    list of CrossSection
        In the order of ``fractions``.
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    f = _fractions(fractions)
    solid = mesh.grains.solid
    lo, height = float(solid.lo[2]), float(solid.extent[2])
    quads, owner = contact_patches(mesh, ids)
    # Only the quadrilaterals reaching a plane need cutting.
    zmin, zmax = quads[:, :, 2].min(axis=1), quads[:, :, 2].max(axis=1)
    out = []
    for fi in f:
        z = lo + fi * height
        near = np.flatnonzero((zmin <= z) & (zmax >= z))
        seg, which = section_segments(quads[near], z)
        own = owner[near[which]]
        out.append(CrossSection(z=z, fraction=float(fi), segments=seg, contact=ids[own],
                                mode=codes[own]))
    return out


def grain_boundary_section(assembly: GrainAssembly | GrainMesh3D, z: float) -> np.ndarray:
    """The grain boundaries cut by a plane z = const.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    z : float
        Height of the plane (m).

    Returns
    -------
    np.ndarray
        (k, 2, 2) (x, y) ends of the cut pieces (m), one per face triangle:
        the interface faces (between two different grains), not the
        specimen's outer faces, the borehole wall or the faces between pieces
        of one grain.
    """
    mesh = _mesh3d(assembly)
    faces = np.flatnonzero(mesh.face_interface >= 0)
    tri, _ = _triangles_of_faces(mesh, faces)
    p = mesh.points[tri]
    zmin, zmax = p[:, :, 2].min(axis=1), p[:, :, 2].max(axis=1)
    seg, _ = section_segments(p[(zmin <= z) & (zmax >= z)], z)
    return seg


# --------------------------------------------------------------------------- summary


def fracture_summary3d(assembly: GrainAssembly | GrainMesh3D, contact, mode, *,
                       connect_distance: float | None = None,
                       radius: float | None = None) -> dict[str, int | float | None]:
    """The paper's fracture quantities of a 3D crack set.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly with a borehole.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).
    connect_distance, radius : float, optional
        As for :func:`radial_fractures3d`.

    Returns
    -------
    dict
        ``n_cracks``, ``n_tensile_cracks``, ``n_shear_cracks``,
        ``tensile_shear_ratio`` (by count), ``n_radial_fractures_top``,
        ``n_radial_fractures_mid``, ``fracture_extent_mm``, ``tortuosity_top``,
        ``fracture_area_m2``, ``tensile_area_m2``, ``shear_area_m2`` and
        ``tensile_shear_area_ratio``.
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    out: dict[str, int | float | None] = dict(crack_counts(codes))
    for plane in ("top", "mid"):
        out[f"n_radial_fractures_{plane}"] = radial_fractures3d(
            mesh, ids, plane, connect_distance=connect_distance, radius=radius).count
    extent = fracture_extent3d(mesh, ids, connect_distance=connect_distance)
    out["fracture_extent_mm"] = None if extent is None else extent * 1e3
    out["tortuosity_top"] = fracture_tortuosity3d(mesh, ids, "top",
                                                  connect_distance=connect_distance)
    out.update(fracture_area(mesh, ids, codes))
    return out
