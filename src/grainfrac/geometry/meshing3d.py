"""Tetrahedral meshing of 3D grains, sub-contacts on grain faces, flow graph on faces.

Points are generated once on the cell complex and shared by everything that
touches them: every vertex; points cutting each edge into pieces no longer
than the zone size (displaced along the edge by up to 10 % of a piece); points
inside each face on a hexagonal lattice of the zone size (random offset and
rotation per face, displaced by up to 10 %, kept half a zone inside the face).
Each face is triangulated once (2D Delaunay): its triangles give the
tributary areas of the sub-contacts (a third of each triangle per corner, so
they sum to the face area) and the pipes of the flow graph.

Each convex piece is tetrahedralised by Qhull's Delaunay (scipy) of its face
points plus interior points on a body-centred lattice. A Delaunay tetrahedron
face on a flat face of a convex point set is a 2D Delaunay triangle of the
points on that face, so with the face points in general position (the random
displacements) both pieces sharing a face cut it into the same triangles: the
mesh conforms, which is checked triangle by triangle. Tetrahedra of poor
shape that touch interior points lose those points and the piece is redone
(up to three times): no interior point is allowed to make a sliver.

Nodes are per grain: pieces of one grain share nodes, grains are duplicated
along grain faces, and a point on an internal grain face gives one
sub-contact per face (node of the lower grain, node of the higher grain).
"""

from __future__ import annotations

import math
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from scipy.spatial import ConvexHull, Delaunay

from grainfrac.errors import GeometryError
from grainfrac.geometry.mesh import Mesh, contact_frame, simplex_measure, tet_volumes
from grainfrac.geometry.node_steps import node_step_ratio
from grainfrac.geometry.solids3d import BOREHOLE
from grainfrac.geometry.tessellation3d import GrainComplex, _cross, disc_faces
from grainfrac.geometry.zone_sizes import ZoneSizes, as_zone_sizes

_EDGE_JITTER = 0.1  # fraction of a piece / of the zone size
_FACE_CLEARANCE = 0.5  # x zone: face lattice points kept this far inside the face
_CELL_CLEARANCE = 0.45  # x zone: interior lattice points kept this far from faces
_BCC_SPACING = 1.15  # x zone: lattice constant of the interior points
_SLIVER_QUALITY = 0.12  # normalised volume below which a tet is poor
_CLEANUP_PASSES = 3
_LINE_REACH = 0.75  # x zone: nodes of a named line (as the 2D NSCB rollers' reach)


@dataclass(frozen=True)
class FaceFlowGraph:
    """Fluid nodes on the grain faces and pipes between them (paper Fig. 9c boundaries).

    Attributes
    ----------
    node_x : np.ndarray
        (p, 3) fluid node positions (points on internal grain faces).
    node_area : np.ndarray
        (p,) face area each node stands for, summed over its faces (m2).
    pipe_nodes : np.ndarray
        (q, 2) fluid nodes joined by each pipe (an edge of a face triangulation;
        faces meeting at a grain edge share its points, so flow passes between them).
    pipe_length, pipe_width : np.ndarray
        (q,) pipe length and the width of face it carries (m): for a uniform
        aperture ``a`` the cubic-law conductance is ``a^3 / (12 mu) x width / length``,
        the cotangent weights of the linear triangle (exact for a linear pressure).
    pipe_face, pipe_interface : np.ndarray
        (q,) the grain face and the grain interface of each pipe.
    pipe_contacts : np.ndarray
        (q, 2) sub-contacts at the pipe ends on that face (for apertures).
    contact_fluid_node : np.ndarray
        (c,) fluid node of each sub-contact.
    node_sets : dict[str, np.ndarray]
        ``well`` (on the borehole wall), ``permeable`` (on the four outer
        sides, fixed pressure) and ``impermeable`` (top and bottom, no flow;
        listed for reference), plus one set per specimen side.
    """

    node_x: np.ndarray
    node_area: np.ndarray
    pipe_nodes: np.ndarray
    pipe_length: np.ndarray
    pipe_width: np.ndarray
    pipe_face: np.ndarray
    pipe_interface: np.ndarray
    pipe_contacts: np.ndarray
    contact_fluid_node: np.ndarray
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return len(self.node_x)

    @property
    def n_pipes(self) -> int:
        return len(self.pipe_nodes)


@dataclass(frozen=True)
class GrainMesh3D:
    """A meshed 3D grain assembly: geometry only, no material properties (SI)."""

    grains: GrainComplex
    zone_size: float
    grain_bounds: tuple[float, float]  # (min_edge, max_edge) requested (m)
    node_x: np.ndarray  # (n, 3)
    node_grain: np.ndarray  # (n,)
    node_point: np.ndarray  # (n,) id of the shared point the node sits on
    element_nodes: np.ndarray  # (m, 4) right-handed
    element_grain: np.ndarray  # (m,)
    element_piece: np.ndarray  # (m,)
    interface_grains: np.ndarray  # (f, 2) lower grain first
    interface_area: np.ndarray  # (f,)
    face_interface: np.ndarray  # (faces,) interface of each face, -1 if none
    face_area: np.ndarray  # (faces,)
    face_triangles: tuple[np.ndarray, ...]  # per face, (t, 3) point ids
    contact_nodes: np.ndarray  # (c, 2)
    contact_area: np.ndarray  # (c,)
    contact_normal: np.ndarray  # (c, 3) from the first grain to the second
    contact_interface: np.ndarray  # (c,)
    contact_face: np.ndarray  # (c,)
    contact_point: np.ndarray  # (c,)
    contact_x: np.ndarray  # (c, 3)
    points: np.ndarray  # (P, 3) the shared points
    flow: FaceFlowGraph
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    surface_triangles: dict[str, np.ndarray] = field(default_factory=dict)  # node ids
    zone_sizes: ZoneSizes | None = None  # when refined near the borehole; else zone_size

    @property
    def wall_zone_size(self) -> float:
        """Zone size on the borehole wall (m): ``zone_size`` unless refined there."""
        return self.zone_size if self.zone_sizes is None else self.zone_sizes.smallest

    @property
    def n_nodes(self) -> int:
        return len(self.node_x)

    @property
    def n_elements(self) -> int:
        return len(self.element_nodes)

    @property
    def n_contacts(self) -> int:
        return len(self.contact_nodes)

    @property
    def n_interfaces(self) -> int:
        return len(self.interface_grains)

    @property
    def thickness(self) -> float:
        return 1.0

    dimension: ClassVar[int] = 3

    # The flow-facing interface shared with the 2D GrainMesh (grainfrac.physics.flow
    # and the coupling read these names in either dimension).
    @property
    def fluid_node_x(self) -> np.ndarray:
        return self.flow.node_x

    @property
    def fluid_node_sets(self) -> dict[str, np.ndarray]:
        return self.flow.node_sets

    @property
    def contact_fluid_node(self) -> np.ndarray:
        return self.flow.contact_fluid_node

    @property
    def pipe_nodes(self) -> np.ndarray:
        return self.flow.pipe_nodes

    @property
    def pipe_contacts(self) -> np.ndarray:
        return self.flow.pipe_contacts

    @property
    def pipe_length(self) -> np.ndarray:
        return self.flow.pipe_length

    @property
    def pipe_width(self) -> np.ndarray:
        return self.flow.pipe_width

    @property
    def pipe_interface(self) -> np.ndarray:
        return self.flow.pipe_interface

    @property
    def has_borehole(self) -> bool:
        return self.grains.solid.has_borehole

    @property
    def borehole_radius(self) -> float:
        return self.grains.solid.borehole_radius

    @property
    def borehole_center(self) -> tuple[float, float]:
        """(x, y) of the borehole axis: the solids are built around the z axis."""
        return (0.0, 0.0)

    @property
    def borehole_length(self) -> float:
        """Length of the borehole along z (m): the solid's extent along its axis."""
        return float(self.grains.solid.extent[2]) if self.has_borehole else 0.0

    def element_volumes(self) -> np.ndarray:
        """Signed tetrahedron volumes (m3)."""
        return simplex_measure(self.node_x, self.element_nodes)

    def grain_volumes(self) -> np.ndarray:
        return np.bincount(self.element_grain, weights=self.element_volumes(),
                           minlength=self.grains.n_grains)

    def record(self) -> Mesh:
        """The dimension-generic :class:`~grainfrac.geometry.mesh.Mesh` of this mesh."""
        return Mesh(
            x=self.node_x,
            cells=self.element_nodes,
            cell_grain=self.element_grain,
            cell_measure=self.element_volumes(),
            contact_nodes=self.contact_nodes,
            contact_area=self.contact_area,
            contact_frame=contact_frame(self.contact_normal),
            thickness=1.0,
        )

    def min_dihedral_angles(self) -> np.ndarray:
        """Smallest dihedral angle of each tetrahedron (degrees)."""
        return dihedral_angles(self.node_x[self.element_nodes]).min(axis=1)


def dihedral_angles(p: np.ndarray) -> np.ndarray:
    """(m, 6) dihedral angles (degrees) of tetrahedra ``p[m, 4, 3]``."""
    faces = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
    normals = []
    for i, j, k in faces:
        n = _cross(p[:, j] - p[:, i], p[:, k] - p[:, i])
        normals.append(n / np.linalg.norm(n, axis=1)[:, None])
    out = []
    for f in range(4):
        for g in range(f + 1, 4):
            cos = -np.einsum("ij,ij->i", normals[f], normals[g])
            out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.column_stack(out)


def tet_quality(p: np.ndarray) -> np.ndarray:
    """Normalised volume ``6 sqrt(2) V / l_rms^3`` (1 for a regular tetrahedron)."""
    vol = np.abs(tet_volumes(p))
    e = [p[:, j] - p[:, i] for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))]
    l2 = sum(np.einsum("ij,ij->i", v, v) for v in e) / 6.0
    return 6.0 * math.sqrt(2.0) * vol / l2 ** 1.5


def mesh_grains3d(cx: GrainComplex, zone_size: float | ZoneSizes, rng: np.random.Generator,
                  grain_bounds: tuple[float, float] = (0.0, np.inf), *,
                  mend_steps: bool = False, threads: int = 1) -> GrainMesh3D:
    """Mesh every piece into tetrahedra; build sub-contacts and the face flow graph.

    Parameters
    ----------
    cx
        The grain complex.
    zone_size
        Target tetrahedron edge (m), or a :class:`ZoneSizes` that refines the zones
        near the borehole (each edge, face and piece at its own size).
    rng
        Random generator for the point displacements (general position).
    grain_bounds
        The (min, max) grain edge lengths the tessellation was asked for (m), kept
        for reports.
    mend_steps
        Edit the interior points of pieces whose nodes would set a short stable
        step (:func:`_mend_step`).
    threads
        Threads that mesh the pieces (the mesh is the same on any number).
    """
    zones = as_zone_sizes(zone_size)
    points = _PointBuffer(cx.vertices)
    n_pts = len(cx.vertices)

    # Edge points, once per edge.
    pairs, _ = cx.edges()
    edge_pts: dict[tuple[int, int], np.ndarray] = {}
    for u, v in pairs.tolist():
        a, b = cx.vertices[u], cx.vertices[v]
        h = zones.at(cx.vertices[[u, v]])
        n = max(1, math.ceil(np.linalg.norm(b - a) / h - 1e-9))
        t = (np.arange(1, n) + rng.uniform(-_EDGE_JITTER, _EDGE_JITTER, n - 1)) / n
        points.add(a + t[:, None] * (b - a))
        edge_pts[(u, v)] = np.concatenate(([u], np.arange(n_pts, n_pts + n - 1), [v]))
        n_pts += n - 1

    # Face points and the face triangulations.
    face_point_ids, face_tris, face_point_area = [], [], []
    for f, ring in enumerate(cx.faces):
        loop = _loop_points(ring, edge_pts)
        origin = cx.vertices[ring].mean(axis=0)
        e1, e2 = _plane_basis(cx.face_normal[f], cx.vertices[ring[0]] - origin)
        bxyz = points[loop]
        b2 = np.column_stack(((bxyz - origin) @ e1, (bxyz - origin) @ e2))
        h = zones.at(cx.vertices[ring])
        inner = _face_lattice(b2, h, rng)
        ids = np.concatenate((loop, np.arange(n_pts, n_pts + len(inner))))
        if len(inner):
            points.add(origin + inner[:, :1] * e1 + inner[:, 1:] * e2)
            n_pts += len(inner)
        p2 = np.vstack((b2, inner))
        tri = Delaunay(p2).simplices
        area = _tri_areas_2d(p2, tri)
        keep = np.abs(area) > 1e-12 * h * h
        tri, area = tri[keep], area[keep]
        # Counter-clockwise about the face normal (out of the face's first piece).
        tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
        area = np.abs(area)
        trib = np.zeros(len(ids))
        for k in range(3):
            np.add.at(trib, tri[:, k], area / 3.0)
        face_point_ids.append(ids)
        face_tris.append(ids[tri])
        face_point_area.append(trib)

    # Tetrahedralise each piece; interior points are the piece's own. The lattices are
    # drawn in piece order first, so the pieces can be meshed on several threads
    # (Qhull lets go of the GIL) with the same result on any number.
    boundary = [np.unique(np.concatenate([face_point_ids[f] for f in fl]))
                for fl in cx.piece_faces]
    interiors = [_cell_lattice(cx, p, zones, rng) for p in range(cx.n_pieces)]

    def mesh_piece(p: int) -> tuple[np.ndarray, np.ndarray]:
        bxyz = points[boundary[p]]
        local_x, tets = _tetrahedralise(bxyz, interiors[p], p)
        if mend_steps:
            local_x, tets = _mend_step(bxyz, local_x, tets, p, zones.at(bxyz))
        return local_x, tets

    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            meshed = list(pool.map(mesh_piece, range(cx.n_pieces)))
    else:
        meshed = [mesh_piece(p) for p in range(cx.n_pieces)]
    piece_tets = []
    for p, (bnd, (local_x, tets)) in enumerate(zip(boundary, meshed, strict=True)):
        fl = cx.piece_faces[p]
        ids = np.concatenate((bnd, np.arange(n_pts, n_pts + len(local_x) - len(bnd))))
        if len(local_x) > len(bnd):
            points.add(local_x[len(bnd):])
            n_pts += len(local_x) - len(bnd)
        tris = [face_tris[f] for f in fl]
        try:
            _check_conforming(ids[tets], tris, p)
        except GeometryError:
            # Only where the check fails: every mesh that passed stays as it was.
            tets = _split_quads_as_faces(tets, np.searchsorted(ids, np.vstack(tris)), local_x)
            _check_conforming(ids[tets], tris, p)
        piece_tets.append(ids[tets])
    pts = points.array()
    return _assemble(cx, zones, pts, face_point_ids, face_tris, face_point_area, piece_tets,
                     grain_bounds)


class _PointBuffer:
    """The shared points, appended block by block and read back by id.

    Points are read while they are still being made (a face needs its edge points,
    a piece its face points); stacking a list of blocks for every read made meshing
    quadratic in the point count (5 s of the 100 mm slab's 14.7 s, most of the cube's
    164 s). Capacity doubles, so appending is amortised linear.
    """

    def __init__(self, first: np.ndarray):
        self._x = np.empty((max(4096, 2 * len(first)), 3))
        self._x[:len(first)] = first
        self.n = len(first)

    def add(self, block: np.ndarray) -> None:
        end = self.n + len(block)
        if end > len(self._x):
            grown = np.empty((max(end, 2 * len(self._x)), 3))
            grown[:self.n] = self._x[:self.n]
            self._x = grown
        self._x[self.n:end] = block
        self.n = end

    def __getitem__(self, ids: np.ndarray) -> np.ndarray:
        return self._x[:self.n][ids]

    def array(self) -> np.ndarray:
        return self._x[:self.n].copy()


def _loop_points(ring: np.ndarray, edge_pts: dict[tuple[int, int], np.ndarray]) -> np.ndarray:
    """Point ids around a face: vertices and edge points, in the ring's order."""
    out = []
    nxt = np.roll(ring, -1)
    for u, v in zip(ring.tolist(), nxt.tolist(), strict=True):
        seg = edge_pts[(u, v)] if u < v else edge_pts[(v, u)][::-1]
        out.append(seg[:-1])
    return np.concatenate(out)


def _plane_basis(normal: np.ndarray, first: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e1 = first - np.dot(first, normal) * normal
    e1 /= np.linalg.norm(e1)
    return e1, _cross(normal, e1)


def _tri_areas_2d(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                  - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def _face_lattice(boundary: np.ndarray, h: float, rng: np.random.Generator) -> np.ndarray:
    """Hexagonal lattice points (spacing h) inside a convex polygon, half a zone clear."""
    lo, hi = boundary.min(axis=0), boundary.max(axis=0)
    if np.min(hi - lo) < 2 * _FACE_CLEARANCE * h:
        return np.empty((0, 2))
    theta = rng.uniform(0, math.pi / 3)
    rot = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    r = float(np.linalg.norm(hi - lo)) / 2 + h
    dy = h * math.sqrt(3) / 2
    jj, ii = np.mgrid[-math.ceil(r / dy):math.ceil(r / dy) + 1, -math.ceil(r / h) - 1:
                      math.ceil(r / h) + 2]
    q = np.column_stack(((ii + 0.5 * (jj % 2)).ravel() * h, jj.ravel() * dy))
    q = (q + rng.uniform(0, h, 2)) @ rot.T + 0.5 * (lo + hi)
    q += rng.uniform(-_EDGE_JITTER * h, _EDGE_JITTER * h, q.shape)
    return q[_inside_convex_2d(boundary, q) >= _FACE_CLEARANCE * h]


def _inside_convex_2d(poly: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Signed distance of points inside a convex polygon (any orientation) to its edges."""
    d = np.roll(poly, -1, axis=0) - poly
    if _tri_areas_2d(np.vstack((poly.mean(axis=0), poly[:2])), np.array([[0, 1, 2]]))[0] < 0:
        d = -d
    n = np.column_stack((-d[:, 1], d[:, 0])) / np.linalg.norm(d, axis=1)[:, None]
    dist = np.einsum("qkj,kj->qk", q[:, None, :] - poly[None, :, :], n)
    return dist.min(axis=1) if len(q) else np.empty(0)


def _cell_lattice(cx: GrainComplex, piece: int, zones: ZoneSizes,
                  rng: np.random.Generator) -> np.ndarray:
    """Body-centred lattice points (anchored at the origin) inside a piece, clear of its
    faces, each displaced by up to 5 % of the spacing (Qhull then sees no ties); the
    spacing follows the zone size at the piece's corner nearest the borehole axis."""
    fl = cx.piece_faces[piece]
    sign = np.where(cx.face_pieces[fl, 0] == piece, 1.0, -1.0)
    normal = cx.face_normal[fl] * sign[:, None]
    offset = np.array([normal[k] @ cx.vertices[cx.faces[f][0]] for k, f in enumerate(fl)])
    vid = np.unique(np.concatenate([cx.faces[f] for f in fl]))
    lo, hi = cx.vertices[vid].min(axis=0), cx.vertices[vid].max(axis=0)
    h = zones.at(cx.vertices[vid])
    c = _BCC_SPACING * h
    out = []
    for shift in (0.0, 0.5):
        axes = [np.arange(math.floor(lo[k] / c) - 1, math.ceil(hi[k] / c) + 1) * c + shift * c
                for k in range(3)]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        g = g + rng.uniform(-0.05 * c, 0.05 * c, g.shape)
        clear = np.min(offset[None, :] - g @ normal.T, axis=1)
        out.append(g[clear >= _CELL_CLEARANCE * h])
    return np.vstack(out)


def _tetrahedralise(bxyz: np.ndarray, interior: np.ndarray, piece: int
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Delaunay tetrahedra of a convex piece; drop interior points that make poor tets."""
    nb = len(bxyz)
    for _ in range(_CLEANUP_PASSES + 1):
        x = np.vstack((bxyz, interior))
        tets = Delaunay(x).simplices
        vol = tet_volumes(x[tets])
        scale = float(np.ptp(x, axis=0).max()) ** 3
        tets = tets[np.abs(vol) > 1e-13 * scale]
        vol = vol[np.abs(vol) > 1e-13 * scale]
        tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
        poor = tet_quality(x[tets]) < _SLIVER_QUALITY
        culprits = np.unique(tets[poor][tets[poor] >= nb]) - nb
        if len(culprits) == 0:
            break
        interior = np.delete(interior, culprits, axis=0)
    return x, tets


# Node-step mending: a piece whose worst node allows less than this fraction of a
# regular zone's stable step gets its interior points edited (next function).
_STEP_TARGET = 0.35
_STEP_ROUNDS = 12
# Directions (cube faces and corners) in which points are tried around a node.
_DIRECTIONS = np.vstack((np.eye(3), -np.eye(3),
                         np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3)
                         / np.sqrt(3.0)))


def _mend_step(bxyz: np.ndarray, x: np.ndarray, tets: np.ndarray, piece: int, h: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Edit the interior points of a piece until no node sets too short a step.

    A handful of nodes among tens of thousands sets the real-mass step of a whole
    assembly: grain-surface nodes in flat tetrahedra whose corners all lie on the
    grain's faces, or corners left with one or two small tetrahedra. The face points
    are shared with the neighbouring grain and stay; the piece's own interior points
    are free. While the worst node's ratio (:func:`node_step_ratio`) is below
    ``_STEP_TARGET``, try removing each interior point of the tetrahedra around it,
    and adding one at 0.6 and 0.9 zone from it towards each of those tetrahedra's
    centroids and along fixed directions (inside the piece, 0.25 zone clear of its
    faces and 0.4 zone from other interior points); keep the edit that raises the
    piece's worst ratio most, and stop when none does. Deterministic: no random draw,
    so the pieces that need no mending are meshed exactly as before.
    """
    ratio = node_step_ratio(x, tets, h)
    worst = float(np.nanmin(ratio))
    if worst >= _STEP_TARGET:
        return x, tets
    hull = ConvexHull(bxyz)
    nb = len(bxyz)
    for _ in range(_STEP_ROUNDS):
        node = int(np.nanargmin(ratio))
        interior = x[nb:]
        around = tets[(tets == node).any(axis=1)]
        trials = [np.delete(interior, k - nb, axis=0) for k in np.unique(around[around >= nb])]
        towards = x[around].mean(axis=1) - x[node]
        towards /= np.linalg.norm(towards, axis=1)[:, None]
        offsets = np.vstack([f * towards for f in (0.6, 0.9)] + [0.7 * _DIRECTIONS])
        for q in x[node] + h * offsets:
            clear = -float(np.max(hull.equations[:, :3] @ q + hull.equations[:, 3]))
            near = float(np.min(np.linalg.norm(interior - q, axis=1), initial=np.inf))
            if clear >= 0.25 * h and near >= 0.4 * h:
                trials.append(np.vstack((interior, q)))
        best = None
        for trial in trials:
            xt, tt = _tetrahedralise(bxyz, trial, piece)
            rt = node_step_ratio(xt, tt, h)
            low = float(np.nanmin(rt))
            if low > (worst if best is None else best[0]):
                best = (low, xt, tt, rt)
        if best is None:
            break
        worst, x, tets, ratio = best
        if worst >= _STEP_TARGET:
            break
    return x, tets


def _split_quads_as_faces(tets: np.ndarray, face_tris: np.ndarray, x: np.ndarray
                          ) -> np.ndarray:
    """Re-split the quadrilaterals that the tetrahedra cut along the other diagonal than
    the piece's face triangulation ``face_tris`` does.

    Where a face's four points lie on one circle (a coarse zone on a thin slab: 4 mm
    zones in an 8 mm slab), either diagonal is Delaunay and Qhull may take the other
    one. The two tetrahedra on such a quadrilateral then share their apex (the five
    points lie on one sphere), and the pyramid is split again along the face's own
    diagonal. Anything else is left for :func:`_check_conforming` to report.
    """
    faces = _tet_faces(tets)
    owner = np.tile(np.arange(len(tets)), 4)
    apex = tets[owner, np.repeat(np.arange(4), len(tets))]  # face k is opposite corner k
    key = [tuple(sorted(f)) for f in faces.tolist()]
    count = Counter(key)
    expected = {tuple(sorted(t)) for t in face_tris.tolist()}
    wrong = [i for i, k in enumerate(key) if count[k] == 1 and k not in expected]
    surface = {k for k, c in count.items() if c == 1}
    missing = [k for k in expected if k not in surface]
    out = tets.copy()
    for first in range(len(wrong)):
        for second in range(first + 1, len(wrong)):
            i, j = wrong[first], wrong[second]
            quad = set(key[i]) | set(key[j])
            if len(quad) != 4 or apex[i] != apex[j]:
                continue
            given = [m for m in missing if set(m) <= quad]
            if len(given) != 2:
                continue
            for t, tri in zip((owner[i], owner[j]), given, strict=True):
                cell = np.array([*tri, apex[i]])
                a, b, c, d = x[cell]
                if np.dot(np.cross(b - a, c - a), d - a) < 0.0:
                    cell = cell[[0, 2, 1, 3]]
                out[t] = cell
    return out


def _tet_faces(tets: np.ndarray) -> np.ndarray:
    """The four faces of every tetrahedron ``(4 m, 3)``, outward for a positive one:
    block ``k`` holds each one's face opposite its corner ``k``."""
    return np.vstack((tets[:, [1, 2, 3]], tets[:, [0, 3, 2]], tets[:, [0, 1, 3]],
                      tets[:, [0, 2, 1]]))


def _check_conforming(tets: np.ndarray, face_tris: list[np.ndarray], piece: int) -> None:
    """Every tet face on the piece's surface must be a triangle of one of its faces."""
    faces = _tet_faces(tets)
    tris = np.vstack(face_tris)
    # Triangles as one int64 key each, over the piece's own point numbering (np.unique
    # over rows cost 3 s of the 100 mm cube's build).
    ids, local = np.unique(np.concatenate((faces.ravel(), tris.ravel())), return_inverse=True)
    n = len(ids)
    local = np.sort(local.reshape(-1, 3), axis=1)
    key = (local[:, 0] * n + local[:, 1]) * n + local[:, 2]
    uniq, count = np.unique(key[:len(faces)], return_counts=True)
    surface = uniq[count == 1]
    expected = np.unique(key[len(faces):])
    if len(surface) != len(expected) or not np.array_equal(surface, expected):
        raise GeometryError(
            f"piece {piece}: its tetrahedra do not conform to its face triangulations "
            f"({len(surface)} surface triangles, {len(expected)} expected)"
        )


def _assemble(cx, zones, pts, face_point_ids, face_tris, face_point_area, piece_tets,
              grain_bounds) -> GrainMesh3D:
    """Nodes per grain, elements, sub-contacts, flow graph and node sets."""
    h = zones.far
    grain_of_piece = cx.piece_grain
    tet_pts = np.vstack(piece_tets)
    tet_piece = np.repeat(np.arange(cx.n_pieces), [len(t) for t in piece_tets])
    tet_grain = grain_of_piece[tet_piece]
    # A node is a (grain, point) pair.
    key = tet_grain[:, None].astype(np.int64) * len(pts) + tet_pts
    uniq, inverse = np.unique(key.ravel(), return_inverse=True)
    node_grain = uniq // len(pts)
    node_point = uniq % len(pts)
    element_nodes = inverse.reshape(-1, 4)

    def node_of(grain: np.ndarray, point: np.ndarray) -> np.ndarray:
        k = grain.astype(np.int64) * len(pts) + point
        pos = np.searchsorted(uniq, k)
        if np.any(pos >= len(uniq)) or np.any(uniq[np.minimum(pos, len(uniq) - 1)] != k):
            raise GeometryError("a face point has no node in its grain")
        return pos

    fg = cx.face_grains()
    face_area = np.array([a.sum() for a in face_point_area])
    iface_faces = cx.interface_faces()
    lo = np.minimum(fg[iface_faces, 0], fg[iface_faces, 1])
    hi = np.maximum(fg[iface_faces, 0], fg[iface_faces, 1])
    pair_keys, iface_of = np.unique(np.column_stack((lo, hi)), axis=0, return_inverse=True)
    face_interface = np.full(len(cx.faces), -1)
    face_interface[iface_faces] = iface_of.ravel()

    c_nodes, c_area, c_normal, c_iface, c_face, c_point = [], [], [], [], [], []
    for f in iface_faces:
        ids = face_point_ids[f]
        ga, gb = fg[f]
        normal = cx.face_normal[f]
        if ga > gb:  # normals point from the lower grain to the higher
            ga, gb, normal = gb, ga, -normal
        c_nodes.append(np.column_stack((node_of(np.full(len(ids), ga), ids),
                                        node_of(np.full(len(ids), gb), ids))))
        c_area.append(face_point_area[f])
        c_normal.append(np.repeat(normal[None], len(ids), axis=0))
        c_iface.append(np.full(len(ids), face_interface[f]))
        c_face.append(np.full(len(ids), f))
        c_point.append(ids)
    if not c_nodes:
        raise GeometryError("the specimen holds a single grain: no grain faces to mesh")
    contact_nodes = np.vstack(c_nodes)
    contact_area = np.concatenate(c_area)
    contact_face = np.concatenate(c_face)
    contact_point = np.concatenate(c_point)
    contact_interface = np.concatenate(c_iface)

    flow = _flow_graph(cx, pts, face_tris, face_point_ids, face_point_area, iface_faces,
                       face_interface, contact_face, contact_point)
    node_sets, surface = _surface_sets(cx, face_point_ids, face_tris, node_of,
                                       pts[node_point], _LINE_REACH * h)
    return GrainMesh3D(
        grains=cx,
        zone_size=h,
        grain_bounds=(float(grain_bounds[0]), float(grain_bounds[1])),
        node_x=pts[node_point],
        node_grain=node_grain,
        node_point=node_point,
        element_nodes=element_nodes,
        element_grain=tet_grain,
        element_piece=tet_piece,
        interface_grains=pair_keys.reshape(-1, 2),
        interface_area=np.bincount(contact_interface, weights=contact_area,
                                   minlength=len(pair_keys)),
        face_interface=face_interface,
        face_area=face_area,
        face_triangles=tuple(face_tris),
        contact_nodes=contact_nodes,
        contact_area=contact_area,
        contact_normal=np.vstack(c_normal),
        contact_interface=contact_interface,
        contact_face=contact_face,
        contact_point=contact_point,
        contact_x=pts[contact_point],
        points=pts,
        flow=flow,
        node_sets=node_sets,
        surface_triangles=surface,
        zone_sizes=None if zones.uniform else zones,
    )


def _flow_graph(cx, pts, face_tris, face_point_ids, face_point_area, iface_faces,
                face_interface, contact_face, contact_point) -> FaceFlowGraph:
    """Fluid nodes on internal grain faces; a pipe per face-triangle edge."""
    fluid_pts, contact_fluid = np.unique(contact_point, return_inverse=True)
    fluid_of = np.full(len(pts), -1)
    fluid_of[fluid_pts] = np.arange(len(fluid_pts))
    node_area = np.zeros(len(fluid_pts))
    np.add.at(node_area, contact_fluid, np.concatenate([face_point_area[f] for f in iface_faces]))
    # Sub-contact of (face, point), found by a sorted key (one contact per pair).
    contact_key = contact_face.astype(np.int64) * len(pts) + contact_point
    by_key = np.argsort(contact_key)

    def contact_of(face: np.ndarray, point: np.ndarray) -> np.ndarray:
        return by_key[np.searchsorted(contact_key[by_key], face * len(pts) + point)]
    # Cotangent weights: edge (i, j) opposite corner k gets cot(angle at k) / 2, summed
    # over the (one or two) triangles of the face that share the edge. All faces at once;
    # pipes face by face, each face's edges in the order corner k, then triangle.
    tri = np.vstack([face_tris[f] for f in iface_faces]) if len(iface_faces) else \
        np.empty((0, 3), dtype=np.int64)
    tri_face = np.repeat(iface_faces, [len(face_tris[f]) for f in iface_faces])
    x = pts[tri]
    ends, cots, faces, order = [], [], [], []
    n_tri = len(tri)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        u, v = x[:, i] - x[:, k], x[:, j] - x[:, k]
        cots.append(np.einsum("ij,ij->i", u, v) / np.linalg.norm(_cross(u, v), axis=1))
        ends.append(np.sort(tri[:, [i, j]], axis=1))
        faces.append(tri_face)
        order.append(np.arange(n_tri))
    ends, cot = np.vstack(ends), np.concatenate(cots)
    face_of = np.concatenate(faces)
    # Rank of each (triangle, corner) row within its face in the dict's insertion order.
    first_tri = np.zeros(len(cx.faces), dtype=np.int64)
    if n_tri:
        starts = np.flatnonzero(np.r_[True, tri_face[1:] != tri_face[:-1]])
        first_tri[tri_face[starts]] = starts
    local = np.concatenate(order) - first_tri[face_of]
    k_of = np.repeat(np.arange(3), n_tri)
    count = np.zeros(len(cx.faces), dtype=np.int64)
    np.add.at(count, tri_face, 1)
    rank = k_of * count[face_of] + local
    face_pos = np.zeros(len(cx.faces), dtype=np.int64)
    face_pos[iface_faces] = np.arange(len(iface_faces))
    row_order = np.lexsort((rank, face_pos[face_of]))
    ends, cot, face_of = ends[row_order], cot[row_order], face_of[row_order]
    key = np.column_stack((face_of, ends))
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    weight = np.zeros(len(first))
    np.add.at(weight, inverse, 0.5 * cot)
    pipe = np.argsort(first, kind="stable")  # pipes in first-insertion order
    a, b = ends[first[pipe], 0], ends[first[pipe], 1]
    pipe_face_ids = face_of[first[pipe]]
    cw = weight[pipe]
    p_len = [float(np.linalg.norm(pts[bb] - pts[aa])) for aa, bb in zip(a, b, strict=True)]
    p_nodes = np.column_stack((fluid_of[a], fluid_of[b]))
    # Obtuse boundary corners: no negative flow.
    p_width = [max(c, 0.0) * length for c, length in zip(cw.tolist(), p_len, strict=True)]
    p_face = pipe_face_ids
    p_contacts = np.column_stack((contact_of(pipe_face_ids, a), contact_of(pipe_face_ids, b)))
    pipe_face = np.array(p_face, dtype=np.int64)
    fluid_x = pts[fluid_pts]
    sets = _fluid_sets(cx, pts, fluid_pts)
    return FaceFlowGraph(
        node_x=fluid_x,
        node_area=node_area,
        pipe_nodes=np.array(p_nodes, dtype=np.int64).reshape(-1, 2),
        pipe_length=np.array(p_len),
        pipe_width=np.array(p_width),
        pipe_face=pipe_face,
        pipe_interface=face_interface[pipe_face],
        pipe_contacts=np.array(p_contacts, dtype=np.int64).reshape(-1, 2),
        contact_fluid_node=contact_fluid,
        node_sets=sets,
    )


def _fluid_sets(cx, pts, fluid_pts) -> dict[str, np.ndarray]:
    sides = cx.solid.on_sides(pts[fluid_pts])
    sets = {name: np.flatnonzero(m) for name, m in sides.items()}
    sets["well"] = sets.get(BOREHOLE, np.empty(0, dtype=np.int64))
    sets["permeable"] = np.unique(np.concatenate(
        [sets[n] for n in cx.solid.permeable_sides] or [np.empty(0, dtype=np.int64)]))
    sets["impermeable"] = np.unique(np.concatenate([sets[n] for n in ("z-", "z+")]))
    return sets


def _surface_sets(cx, face_point_ids, face_tris, node_of, node_x, reach):
    """Node sets and surface triangles (node ids) of each specimen side, and the node
    sets of the solid's named lines (surface nodes within ``reach`` of each)."""
    sides = cx.solid.sides
    nodes: dict[str, list[np.ndarray]] = {n: [] for n in sides}
    tris: dict[str, list[np.ndarray]] = {n: [] for n in sides}
    fg = cx.face_grains()
    for f in np.flatnonzero(cx.face_pieces[:, 1] < 0):
        name = sides[-1 - int(cx.face_pieces[f, 1])]
        g = int(fg[f, 0])
        ids = face_point_ids[f]
        nodes[name].append(node_of(np.full(len(ids), g), ids))
        t = face_tris[f]
        tris[name].append(node_of(np.full(t.size, g), t.ravel()).reshape(-1, 3))
    node_sets = {n: np.unique(np.concatenate(v)) if v else np.empty(0, dtype=np.int64)
                 for n, v in nodes.items()}
    surface = {n: np.vstack(v) if v else np.empty((0, 3), dtype=np.int64)
               for n, v in tris.items()}
    if cx.solid.lines:
        outer = np.unique(np.concatenate(list(node_sets.values())))
        for name, (lx, ly) in cx.solid.lines.items():
            # A line load or a roller touches the surface nodes near its line (as the
            # 2D NSCB rollers); never none: then the nearest ones.
            d = np.hypot(node_x[outer, 0] - lx, node_x[outer, 1] - ly)
            near = d <= max(reach, float(d.min()) + 1e-9)
            node_sets[name] = outer[near]
    return node_sets, surface


# -- the penny block ----------------------------------------------------------------------
def _penny_solid(mesh: GrainMesh3D):
    solid = mesh.grains.solid
    if solid.cut_z is None:
        raise GeometryError(f"the specimen is a {solid.kind}, not a penny block")
    return solid


def penny_plane_contacts(mesh: GrainMesh3D) -> tuple[np.ndarray, np.ndarray]:
    """Sub-contacts on the penny block's cut plane, and those inside its pre-cut disc.

    Returns
    -------
    on_plane, in_disc : np.ndarray
        (c,) boolean masks. The disc is made of whole grain faces (the faceted
        polygon of :attr:`Solid.disc_facets` inscribed in the disc's circle), so the
        areas of the ``in_disc`` sub-contacts sum to :attr:`Solid.disc_area`, and those
        of ``on_plane`` to the plane's area.
    """
    _penny_solid(mesh)
    cx = mesh.grains
    plane = np.zeros(len(cx.faces), dtype=bool)
    plane[cx.cut_faces()] = True
    disc = np.zeros(len(cx.faces), dtype=bool)
    disc[disc_faces(cx)] = True
    return plane[mesh.contact_face], disc[mesh.contact_face]


def penny_injection_node(mesh: GrainMesh3D) -> int:
    """The fluid node at the centre of the penny's disc (the injection point).

    The disc's inner cells meet on the axis, so the centre is a vertex of the grain
    faces and always a fluid node.
    """
    solid = _penny_solid(mesh)
    centre = np.array([0.0, 0.0, solid.cut_z])
    d = np.linalg.norm(mesh.flow.node_x - centre, axis=1)
    k = int(np.argmin(d))
    if d[k] > 1e-9:
        raise GeometryError(f"no fluid node at the disc centre (nearest {d[k]:.3g} m away)")
    return k
