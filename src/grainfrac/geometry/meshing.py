"""Grain meshing, sub-contacts and the flow network on grain boundaries.

Every graph segment of the :class:`~grainfrac.geometry.tessellation.GrainMap` is
cut once into pieces no longer than the zone size, so the two grains on either
side see the same boundary points. Each grain is triangulated on its own
(Delaunay of its boundary points and a hexagonal lattice of interior points,
kept inside the grain); nodes are therefore duplicated along grain boundaries.

A boundary point shared by two grains gives one *sub-contact* per grain
boundary it lies on: the pair of coincident nodes, a tributary length (half of
each adjacent piece) times the thickness as its area, and the unit normal of
the boundary from the first grain to the second (3DEC's sub-contacts on
deformable blocks).

Fluid flows along grain boundaries only. *Fluid nodes* are the distinct
boundary points that lie on at least one grain boundary; *pipes* are the
pieces between consecutive points along a grain boundary. A fluid node at a
triple junction joins the pipes of all three boundaries.

Triangulation uses scipy's Qhull (BSD) and shapely/GEOS (BSD/LGPL) only; no
mesher with a non-commercial or copyleft licence is needed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import shapely
from scipy.spatial import Delaunay

from grainfrac.errors import GeometryError
from grainfrac.geometry.mesh import Mesh, contact_frame, simplex_measure
from grainfrac.geometry.tessellation import GrainMap

# Interior lattice points closer than this fraction of the zone size to the
# grain boundary are dropped, so the lattice never encroaches on boundary pieces.
_INTERIOR_CLEARANCE = 0.55


@dataclass(frozen=True)
class BoundaryFaces:
    """Element edges on one named side of the specimen.

    Attributes
    ----------
    nodes : np.ndarray
        (k, 2) node ids, in the owning grain's counter-clockwise order.
    normal : np.ndarray
        (k, 2) outward unit normals.
    length : np.ndarray
        (k,) edge lengths (m).
    """

    nodes: np.ndarray
    normal: np.ndarray
    length: np.ndarray


@dataclass(frozen=True)
class GrainMesh:
    """A meshed grain assembly: geometry only, no material properties.

    Node, element, sub-contact and fluid arrays are flat (structure of arrays),
    SI units. Grain boundaries ("interfaces") are the faces between two grains;
    sub-contacts discretise them.
    """

    grains: GrainMap
    thickness: float
    zone_size: float
    # nodes and elements
    node_xy: np.ndarray  # (n, 2)
    node_grain: np.ndarray  # (n,)
    element_nodes: np.ndarray  # (m, 3) counter-clockwise
    element_grain: np.ndarray  # (m,)
    # grain boundaries
    interface_grains: np.ndarray  # (f, 2) lower grain id first
    interface_length: np.ndarray  # (f,)
    # sub-contacts
    contact_nodes: np.ndarray  # (c, 2) node of interface_grains[:, 0], then [:, 1]
    contact_area: np.ndarray  # (c,) tributary length x thickness
    contact_normal: np.ndarray  # (c, 2) unit, from first grain to second
    contact_tangent: np.ndarray  # (c, 2) normal rotated +90 degrees
    contact_interface: np.ndarray  # (c,)
    contact_xy: np.ndarray  # (c, 2)
    contact_fluid_node: np.ndarray  # (c,)
    # flow network
    fluid_node_xy: np.ndarray  # (p, 2)
    pipe_nodes: np.ndarray  # (q, 2) fluid node ids
    pipe_length: np.ndarray  # (q,)
    pipe_width: np.ndarray  # (q,) out-of-plane width = thickness
    pipe_contacts: np.ndarray  # (q, 2) sub-contacts at the two ends (for apertures)
    pipe_interface: np.ndarray  # (q,)
    # boundaries
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    boundary_faces: dict[str, BoundaryFaces] = field(default_factory=dict)
    fluid_node_sets: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def wall_zone_size(self) -> float:
        """Zone size at the borehole wall (m); 2D meshes use one zone size throughout."""
        return self.zone_size

    @property
    def n_nodes(self) -> int:
        return len(self.node_xy)

    @property
    def n_elements(self) -> int:
        return len(self.element_nodes)

    @property
    def n_contacts(self) -> int:
        return len(self.contact_nodes)

    @property
    def n_interfaces(self) -> int:
        return len(self.interface_grains)

    dimension: ClassVar[int] = 2

    # The interface shared with the 3D GrainMesh3D.
    @property
    def node_x(self) -> np.ndarray:
        return self.node_xy

    @property
    def contact_x(self) -> np.ndarray:
        return self.contact_xy

    @property
    def fluid_node_x(self) -> np.ndarray:
        return self.fluid_node_xy

    @property
    def has_borehole(self) -> bool:
        return "borehole" in self.boundary_faces

    @property
    def borehole_radius(self) -> float:
        return self.grains.outline.borehole_radius

    @property
    def borehole_center(self) -> tuple[float, float]:
        return self.grains.outline.borehole_center

    @property
    def borehole_length(self) -> float:
        """The slab thickness: the borehole runs through the plane-strain slice (m)."""
        return self.thickness if self.has_borehole else 0.0

    def element_areas(self) -> np.ndarray:
        """Signed element areas (m2); positive for counter-clockwise elements."""
        return simplex_measure(self.node_xy, self.element_nodes)

    def record(self) -> Mesh:
        """The dimension-generic :class:`~grainfrac.geometry.mesh.Mesh` of this mesh."""
        return Mesh(
            x=self.node_xy,
            cells=self.element_nodes,
            cell_grain=self.element_grain,
            cell_measure=self.element_areas() * self.thickness,
            contact_nodes=self.contact_nodes,
            contact_area=self.contact_area,
            contact_frame=contact_frame(self.contact_normal),
            thickness=self.thickness,
        )

    def element_min_angles(self) -> np.ndarray:
        """Smallest interior angle of each element (degrees)."""
        p = self.node_xy[self.element_nodes]
        angles = []
        for i in range(3):
            u = p[:, (i + 1) % 3] - p[:, i]
            v = p[:, (i + 2) % 3] - p[:, i]
            cos = np.sum(u * v, axis=1) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
            angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
        return np.min(angles, axis=0)


def mesh_grains(grains: GrainMap, zone_size: float) -> GrainMesh:
    """Mesh every grain into triangles and build sub-contacts and the flow network.

    Parameters
    ----------
    grains
        The grain tessellation.
    zone_size
        Target element edge length (m).
    """
    outline = grains.outline
    owners = grains.segments()
    cp_xy, seg_points = _cut_segments(grains.vertices, owners, zone_size)

    # Triangulate each grain; nodes are numbered grain by grain.
    node_xy, node_grain, node_cp, tris, tri_grain = [], [], [], [], []
    node_of: dict[tuple[int, int], int] = {}
    offset = 0
    for g, ring in enumerate(grains.rings):
        ring_cps = _ring_points(ring, seg_points)
        pts, triangles = _triangulate_grain(cp_xy[ring_cps], zone_size)
        n_ring = len(ring_cps)
        for k, cp in enumerate(ring_cps.tolist()):
            node_of[(g, cp)] = offset + k
        node_xy.append(pts)
        node_grain.append(np.full(len(pts), g))
        node_cp.append(np.concatenate((ring_cps, np.full(len(pts) - n_ring, -1))))
        tris.append(triangles + offset)
        tri_grain.append(np.full(len(triangles), g))
        offset += len(pts)
    node_xy = np.vstack(node_xy)
    node_grain = np.concatenate(node_grain)
    node_cp = np.concatenate(node_cp)
    element_nodes = np.vstack(tris).astype(np.int64)
    element_grain = np.concatenate(tri_grain)

    # Grain boundaries and their sub-contacts.
    internal = sorted(k for k, g in owners.items() if len(g) == 2)
    pair_to_interface: dict[tuple[int, int], int] = {}
    c_nodes, c_len, c_normal, c_iface, c_cp = [], [], [], [], []
    p_cps, p_len, p_iface, p_contacts = [], [], [], []
    for key in internal:
        ga, gb = sorted(owners[key])
        iface = pair_to_interface.setdefault((ga, gb), len(pair_to_interface))
        cps = _points_along(key, ga, grains.rings[ga], seg_points)
        xy = cp_xy[cps]
        piece = np.hypot(*np.diff(xy, axis=0).T)
        tangent_dir = (xy[-1] - xy[0]) / np.hypot(*(xy[-1] - xy[0]))
        # Grain ga runs counter-clockwise along cps, so its outward normal (towards gb)
        # is the direction rotated by -90 degrees.
        normal = np.array([tangent_dir[1], -tangent_dir[0]])
        trib = np.zeros(len(cps))
        trib[:-1] += 0.5 * piece
        trib[1:] += 0.5 * piece
        first = len(c_cp)
        for k, cp in enumerate(cps.tolist()):
            c_nodes.append((node_of[(ga, cp)], node_of[(gb, cp)]))
            c_len.append(trib[k])
            c_normal.append(normal)
            c_iface.append(iface)
            c_cp.append(cp)
        for k in range(len(cps) - 1):
            p_cps.append((cps[k], cps[k + 1]))
            p_len.append(piece[k])
            p_iface.append(iface)
            p_contacts.append((first + k, first + k + 1))
    if not c_cp:
        raise GeometryError("the specimen holds a single grain: no grain boundaries to mesh")

    c_cp = np.array(c_cp)
    fluid_cps, contact_fluid_node = np.unique(c_cp, return_inverse=True)
    fluid_of_cp = np.full(len(cp_xy), -1)
    fluid_of_cp[fluid_cps] = np.arange(len(fluid_cps))
    contact_normal = np.array(c_normal)
    interface_grains = np.array(sorted(pair_to_interface, key=pair_to_interface.get))
    contact_interface = np.array(c_iface)
    contact_length = np.array(c_len)
    interface_length = np.bincount(contact_interface, weights=contact_length)

    node_sets, faces, fluid_sets = _boundary_sets(
        grains, owners, seg_points, cp_xy, node_of, node_xy, fluid_of_cp
    )

    return GrainMesh(
        grains=grains,
        thickness=outline.thickness,
        zone_size=zone_size,
        node_xy=node_xy,
        node_grain=node_grain,
        element_nodes=element_nodes,
        element_grain=element_grain,
        interface_grains=interface_grains,
        interface_length=interface_length,
        contact_nodes=np.array(c_nodes, dtype=np.int64),
        contact_area=contact_length * outline.thickness,
        contact_normal=contact_normal,
        contact_tangent=np.column_stack((-contact_normal[:, 1], contact_normal[:, 0])),
        contact_interface=contact_interface,
        contact_xy=cp_xy[c_cp],
        contact_fluid_node=contact_fluid_node,
        fluid_node_xy=cp_xy[fluid_cps],
        pipe_nodes=fluid_of_cp[np.array(p_cps)],
        pipe_length=np.array(p_len),
        pipe_width=np.full(len(p_len), outline.thickness),
        pipe_contacts=np.array(p_contacts, dtype=np.int64),
        pipe_interface=np.array(p_iface),
        node_sets=node_sets,
        boundary_faces=faces,
        fluid_node_sets=fluid_sets,
    )


def _cut_segments(
    vertices: np.ndarray, owners: dict[tuple[int, int], list[int]], zone_size: float
) -> tuple[np.ndarray, dict[tuple[int, int], np.ndarray]]:
    """Cut each segment into equal pieces <= zone size; return points and per-segment ids."""
    points = [vertices]
    seg_points: dict[tuple[int, int], np.ndarray] = {}
    next_id = len(vertices)
    for u, v in sorted(owners):
        a, b = vertices[u], vertices[v]
        n = max(1, math.ceil(np.hypot(*(b - a)) / zone_size - 1e-9))
        t = np.arange(1, n)[:, None] / n
        points.append(a + t * (b - a))
        inner = np.arange(next_id, next_id + n - 1)
        next_id += n - 1
        seg_points[(u, v)] = np.concatenate(([u], inner, [v]))
    return np.vstack(points), seg_points


def _oriented(key_from: int, key_to: int, seg_points) -> np.ndarray:
    if key_from < key_to:
        return seg_points[(key_from, key_to)]
    return seg_points[(key_to, key_from)][::-1]


def _ring_points(ring: np.ndarray, seg_points) -> np.ndarray:
    nxt = np.roll(ring, -1)
    parts = [_oriented(u, v, seg_points)[:-1] for u, v in zip(ring.tolist(), nxt.tolist(),
                                                              strict=True)]
    return np.concatenate(parts)


def _points_along(key: tuple[int, int], grain: int, ring: np.ndarray, seg_points) -> np.ndarray:
    """Boundary points of segment ``key`` in the direction ``grain`` runs along it."""
    u, v = key
    pos = np.flatnonzero(ring == u)[0]
    forward = ring[(pos + 1) % len(ring)] == v
    return _oriented(u, v, seg_points) if forward else _oriented(v, u, seg_points)


def hex_lattice(bounds: tuple[float, float, float, float], spacing: float) -> np.ndarray:
    """Points of the hexagonal lattice of ``spacing`` that cover ``bounds``
    (xmin, ymin, xmax, ymax), with a margin of one spacing in x.

    Grain interiors are meshed on it, and so is the SCDA plug
    (:func:`grainfrac.physics.scda.scda_fill`)."""
    xmin, ymin, xmax, ymax = bounds
    dy = spacing * math.sqrt(3.0) / 2
    # Anchored to the global origin so neighbouring grains see one lattice.
    j0, j1 = math.floor(ymin / dy), math.ceil(ymax / dy)
    i0, i1 = math.floor(xmin / spacing) - 1, math.ceil(xmax / spacing) + 1
    jj, ii = np.mgrid[j0 : j1 + 1, i0 : i1 + 1]
    x = (ii + 0.5 * (jj % 2)) * spacing
    y = jj * dy
    return np.column_stack((x.ravel(), y.ravel()))


def _triangulate_grain(ring_xy: np.ndarray, zone_size: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of one grain: boundary points first, interior lattice points after."""
    polygon = shapely.Polygon(ring_xy)
    lattice = hex_lattice(polygon.bounds, zone_size)
    inside = shapely.contains_xy(polygon, lattice[:, 0], lattice[:, 1])
    lattice = lattice[inside]
    if len(lattice):
        clear = shapely.distance(polygon.exterior, shapely.points(lattice))
        lattice = lattice[clear > _INTERIOR_CLEARANCE * zone_size]
    pts = np.vstack((ring_xy, lattice))
    tri = Delaunay(pts).simplices
    cent = pts[tri].mean(axis=1)
    tri = tri[shapely.contains_xy(polygon, cent[:, 0], cent[:, 1])]
    tri = _counter_clockwise(pts, tri)
    if not _covers(pts, tri, polygon, len(ring_xy)):
        # Non-convex grain whose boundary Delaunay missed: fall back to a
        # constrained triangulation of the boundary points alone.
        pts = ring_xy
        tri = _constrained(ring_xy, polygon)
        if not _covers(pts, tri, polygon, len(ring_xy)):
            raise GeometryError("could not triangulate a grain conformingly")
    return pts, tri


def _counter_clockwise(pts: np.ndarray, tri: np.ndarray) -> np.ndarray:
    p = pts[tri]
    area = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
            - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    tri = tri.copy()
    flip = area < 0
    tri[flip] = tri[flip][:, [0, 2, 1]]
    return tri[np.abs(area) > 1e-12 * polygon_scale(pts) ** 2]


def polygon_scale(pts: np.ndarray) -> float:
    span = pts.max(axis=0) - pts.min(axis=0)
    return float(max(span.max(), 1e-30))


def _covers(pts, tri, polygon, n_ring) -> bool:
    """Triangles tile the polygon exactly and use every boundary piece as an edge."""
    if len(tri) == 0:
        return False
    p = pts[tri]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    if abs(area.sum() - polygon.area) > 1e-9 * polygon.area or (area <= 0).any():
        return False
    edges = {tuple(sorted(e)) for t in tri.tolist() for e in ((t[0], t[1]), (t[1], t[2]),
                                                             (t[2], t[0]))}
    return all(tuple(sorted((k, (k + 1) % n_ring))) in edges for k in range(n_ring))


def _constrained(ring_xy: np.ndarray, polygon: shapely.Polygon) -> np.ndarray:
    triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(polygon))
    index = {tuple(p): i for i, p in enumerate(ring_xy.tolist())}
    out = []
    for t in triangles:
        coords = np.asarray(t.exterior.coords)[:3]
        out.append([index[tuple(c)] for c in coords.tolist()])
    return _counter_clockwise(ring_xy, np.array(out, dtype=np.int64))


def _boundary_sets(grains, owners, seg_points, cp_xy, node_of, node_xy, fluid_of_cp):
    """Node sets, boundary faces and fluid node sets for each named side."""
    outline = grains.outline
    on_side = outline.side_of_points(grains.vertices, tol=1e-7)
    names = list(outline.sides)
    node_sets: dict[str, list[int]] = {n: [] for n in names}
    fluid_sets: dict[str, list[int]] = {n: [] for n in names}
    faces: dict[str, list[tuple[int, int]]] = {n: [] for n in names}
    for key, g in owners.items():
        if len(g) != 1:
            continue
        u, v = key
        sides = [n for n in names if on_side[n][u] and on_side[n][v]]
        if not sides:
            raise GeometryError(
                f"boundary segment at {cp_xy[u] * 1e3} mm lies on no named side of the specimen"
            )
        side = sides[0]
        grain = g[0]
        cps = _points_along(key, grain, grains.rings[grain], seg_points)
        nodes = [node_of[(grain, cp)] for cp in cps.tolist()]
        node_sets[side].extend(nodes)
        fluid_sets[side].extend(fluid_of_cp[cps][fluid_of_cp[cps] >= 0].tolist())
        faces[side].extend(zip(nodes[:-1], nodes[1:], strict=True))
    # A vertex where a grain boundary meets the specimen boundary also belongs to
    # the neighbour grain, whose own boundary segment there may be on another side.
    for (_g, cp), node in node_of.items():
        if cp < len(grains.vertices):
            for n in names:
                if on_side[n][cp]:
                    node_sets[n].append(node)
                    if fluid_of_cp[cp] >= 0:
                        fluid_sets[n].append(int(fluid_of_cp[cp]))
    out_faces = {}
    for n in names:
        pairs = np.array(faces[n], dtype=np.int64).reshape(-1, 2)
        d = node_xy[pairs[:, 1]] - node_xy[pairs[:, 0]]
        length = np.hypot(d[:, 0], d[:, 1])
        normal = np.column_stack((d[:, 1], -d[:, 0])) / np.maximum(length, 1e-300)[:, None]
        out_faces[n] = BoundaryFaces(pairs, normal, length)
    return (
        {n: np.unique(np.array(v, dtype=np.int64)) for n, v in node_sets.items()},
        out_faces,
        {n: np.unique(np.array(v, dtype=np.int64)) for n, v in fluid_sets.items()},
    )
