"""3D Voronoi grains: convex polyhedral pieces with exact flat specimen faces.

Construction (the short-edge rule is step 4):

1. Seeds on a body-centred lattice whose Voronoi cells are Kelvin cells
   (truncated octahedra) of edge ``a = 0.95 (min_edge + max_edge) / 2``, the
   lattice constant ``2 sqrt(2) a`` rounded per axis so the box faces are
   lattice mirror planes; each seed is displaced at random by up to
   ``jitter x a``.
2. Flat boundaries are exact Voronoi faces: every seed is mirrored across each
   box face, so the bisector of a seed and its mirror is the box face itself.
   A borehole gets a ring of seeds, one per wall facet and layer, mirrored
   across its facet: the bisectors are the facet planes and the radial planes
   through the facet edges. Consecutive ring cells of a layer form one grain
   (about ``a`` wide at the wall; the grouping offset is random per layer).
   Every piece is therefore a convex Voronoi cell, computed by half-space
   intersection (Qhull), and the pieces tile the faceted solid exactly.
3. Vertices computed by several cells are merged (1 nm), faces are polygons
   of merged vertices, degenerate (edge-only) faces are dropped.
4. Short-edge rule: an edge shorter than ``0.4 x zone_size`` anywhere, or an
   interior grain edge (where three or more grains meet, off the specimen
   surface) outside ``[min_edge, max_edge]``, halves the displacement of the
   lattice seeds around it; the cells are recomputed, up to
   ``repair_rounds`` times. At zero displacement the Kelvin edges are ``a``.
   Edges that end on the specimen surface or belong to the borehole ring are
   exempt from the grain bounds (the 2D rule), not from the mesh bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay, HalfspaceIntersection, cKDTree

from grainfrac.errors import GeometryError
from grainfrac.geometry.solids3d import BOREHOLE, BOX_SIDES, Solid

_MERGE_TOL = 1e-9  # m: vertices computed twice by Qhull agree to ~1e-16 m
_MESH_MIN_EDGE = 0.4  # x zone size: shortest edge the mesher accepts
_REPAIR_SHRINK = 0.6  # a repaired lattice seed's new displacement, x its previous size


@dataclass(frozen=True)
class GrainComplex:
    """Grains as convex pieces sharing polygonal faces.

    Attributes
    ----------
    solid : Solid
        The specimen.
    vertices : np.ndarray
        (v, 3) merged vertex coordinates (m).
    faces : tuple[np.ndarray, ...]
        Per face, its vertex ids in order, counter-clockwise seen from outside
        ``face_pieces[f, 0]``.
    face_pieces : np.ndarray
        (f, 2) the piece on each side; the second is ``-1 - k`` on the
        specimen surface, ``k`` indexing :attr:`Solid.sides`.
    face_normal : np.ndarray
        (f, 3) unit normal out of ``face_pieces[f, 0]``.
    piece_grain : np.ndarray
        (p,) grain of each piece (ring grains have several pieces).
    piece_faces : tuple[np.ndarray, ...]
        Face ids of each piece.
    seeds : np.ndarray
        (p, 3) the seed of each piece.
    piece_ring : np.ndarray
        (p,) True for the borehole ring's pieces.
    """

    solid: Solid
    vertices: np.ndarray
    faces: tuple[np.ndarray, ...]
    face_pieces: np.ndarray
    face_normal: np.ndarray
    piece_grain: np.ndarray
    piece_faces: tuple[np.ndarray, ...]
    seeds: np.ndarray
    piece_ring: np.ndarray

    @property
    def n_grains(self) -> int:
        return int(self.piece_grain.max()) + 1

    @property
    def n_pieces(self) -> int:
        return len(self.piece_grain)

    def face_grains(self) -> np.ndarray:
        """(f, 2) grains on each side (the second is negative on the surface)."""
        a = self.piece_grain[self.face_pieces[:, 0]]
        b = np.where(self.face_pieces[:, 1] >= 0, self.piece_grain[self.face_pieces[:, 1]],
                     self.face_pieces[:, 1])
        return np.column_stack((a, b))

    def interface_faces(self) -> np.ndarray:
        """Ids of faces between two different grains."""
        g = self.face_grains()
        return np.flatnonzero((g[:, 1] >= 0) & (g[:, 0] != g[:, 1]))

    def face_areas(self) -> np.ndarray:
        return np.array([_polygon_area(self.vertices[f]) for f in self.faces])

    def piece_volumes(self) -> np.ndarray:
        """Volumes of the pieces by the divergence theorem (m3)."""
        area_vec = np.array([_polygon_vector_area(self.vertices[f]) for f in self.faces])
        centre = np.array([self.vertices[f].mean(axis=0) for f in self.faces])
        flux = np.einsum("ij,ij->i", area_vec, centre) / 3.0
        vol = np.zeros(self.n_pieces)
        for p, fl in enumerate(self.piece_faces):
            sign = np.where(self.face_pieces[fl, 0] == p, 1.0, -1.0)
            vol[p] = np.sum(sign * flux[fl])
        return vol

    def grain_volumes(self) -> np.ndarray:
        return np.bincount(self.piece_grain, weights=self.piece_volumes(),
                           minlength=self.n_grains)

    def edges(self) -> tuple[np.ndarray, list[list[int]]]:
        """Unique edges (e, 2) (u < v) and the faces each belongs to."""
        owner: dict[tuple[int, int], list[int]] = {}
        for f, ring in enumerate(self.faces):
            nxt = np.roll(ring, -1)
            for u, v in zip(ring.tolist(), nxt.tolist(), strict=True):
                owner.setdefault((min(u, v), max(u, v)), []).append(f)
        keys = sorted(owner)
        return np.array(keys, dtype=np.int64).reshape(-1, 2), [owner[k] for k in keys]

    def edge_classes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Edge vertex pairs, lengths, and a mask of interior grain edges.

        An interior grain edge lies on no specimen face and has three or more
        grains around it (the edges the grain-size bounds act on).
        """
        pairs, owners = self.edges()
        length = np.linalg.norm(self.vertices[pairs[:, 1]] - self.vertices[pairs[:, 0]], axis=1)
        grains = self.face_grains()
        interior = np.zeros(len(pairs), dtype=bool)
        for e, fl in enumerate(owners):
            g = grains[fl]
            if np.all(g[:, 1] >= 0):
                interior[e] = len(np.unique(g)) >= 3
        on_surface = np.zeros(len(self.vertices), dtype=bool)
        for f in np.flatnonzero(self.face_pieces[:, 1] < 0):
            on_surface[self.faces[f]] = True
        interior &= ~(on_surface[pairs[:, 0]] | on_surface[pairs[:, 1]])
        # Edges on the borehole ring's pieces are exempt like surface-cut ones.
        ring_vertex = np.zeros(len(self.vertices), dtype=bool)
        for f in np.flatnonzero(np.any(self.piece_ring[np.maximum(self.face_pieces, 0)]
                                       & (self.face_pieces >= 0), axis=1)):
            ring_vertex[self.faces[f]] = True
        interior &= ~(ring_vertex[pairs[:, 0]] & ring_vertex[pairs[:, 1]])
        return pairs, length, interior


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product (np.cross is slow on the many small arrays here)."""
    return np.stack((a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]), axis=-1)


def _polygon_vector_area(p: np.ndarray) -> np.ndarray:
    d = p - p.mean(axis=0)
    return 0.5 * _cross(d, np.concatenate((d[1:], d[:1]))).sum(axis=0)


def _polygon_area(p: np.ndarray) -> float:
    return float(np.linalg.norm(_polygon_vector_area(p)))


def kelvin_cell_volume(edge: float) -> float:
    """Volume of a truncated octahedron (Kelvin cell) with the given edge (m3)."""
    return 8.0 * math.sqrt(2.0) * edge ** 3


def target_edge(min_edge: float, max_edge: float) -> float:
    """Kelvin edge aimed at: slightly below the middle of the bounds, as in 2D."""
    return 0.5 * (min_edge + max_edge) * 0.95


def tessellate3d(
    solid: Solid,
    min_edge: float,
    max_edge: float,
    zone_size: float,
    rng: np.random.Generator,
    *,
    jitter: float = 0.4,
    repair_rounds: int = 8,
) -> GrainComplex:
    """Fill a solid with convex Voronoi pieces grouped into grains.

    Parameters
    ----------
    solid
        The specimen (m).
    min_edge, max_edge
        Bounds on interior grain edge length (m).
    zone_size
        Mesh zone size (m); no edge may be shorter than 0.4 of it.
    rng
        Random generator; the only source of randomness.
    jitter
        Largest seed displacement as a fraction of the Kelvin edge.
    repair_rounds
        Rounds of the short-edge rule (module docstring, step 4).
    """
    if not 0 < min_edge < max_edge:
        raise GeometryError(f"need 0 < min_edge < max_edge, got {min_edge:g}, {max_edge:g}")
    a = target_edge(min_edge, max_edge)
    base, _ = _lattice(solid, a)
    ring = _Ring.draw(solid, a, rng) if solid.has_borehole else None
    if ring is not None and len(base):
        r = np.hypot(base[:, 0], base[:, 1])
        base = base[r >= solid.apothem + _ring_clearance(solid, a)]
    n_lat = len(base)
    n_facets = solid.borehole_facets
    displacement = _displacements(rng, n_lat, jitter * a)
    ring_seeds = ring.seeds() if ring is not None else np.empty((0, 3))
    ring_piece = np.arange(n_lat + len(ring_seeds)) >= n_lat
    grain_of_piece = np.arange(n_lat + len(ring_seeds))
    if ring is not None:
        grain_of_piece[n_lat:] = n_lat + ring.grain
    best, best_edge = None, -1.0
    for _ in range(repair_rounds + 1):
        seeds = _inside_box(solid, base + displacement, a)
        if ring is not None:
            ring_seeds = ring.seeds()
        cx = _complex(solid, np.vstack((seeds, ring_seeds)), grain_of_piece, ring_piece)
        bad, shortest = _violations(cx, min_edge, max_edge, zone_size)
        # A round can make things worse elsewhere: keep the complex whose shortest
        # edge is longest (it sets the mesh's stable step).
        if shortest > best_edge:
            best, best_edge = cx, shortest
        if len(bad) == 0:
            break
        lat = bad[bad < n_lat]
        # A fresh, smaller displacement: halving alone would converge on the bare
        # lattice, whose edges against the borehole ring can themselves be short.
        amplitude = _REPAIR_SHRINK * np.linalg.norm(displacement[lat], axis=1)
        displacement[lat] = _displacements(rng, len(lat), 1.0) * amplitude[:, None]
        if ring is not None and np.any(bad >= n_lat):
            ring.redraw(np.unique((bad[bad >= n_lat] - n_lat) // n_facets), rng)
    cx = best
    volume = float(cx.piece_volumes().sum())
    if abs(volume - solid.volume) > 1e-9 * solid.volume:
        raise GeometryError(f"the grains fill {volume:.9g} m3 of a {solid.volume:.9g} m3 solid")
    return cx


def _displacements(rng: np.random.Generator, n: int, radius: float) -> np.ndarray:
    """``n`` points uniform in a ball of ``radius``."""
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    return d * (radius * np.cbrt(rng.uniform(size=n)))[:, None]


def _lattice(solid: Solid, a: float) -> tuple[np.ndarray, None]:
    """Body-centred lattice points in the box; box faces are lattice mirror planes."""
    big = 2.0 * math.sqrt(2.0) * a
    ext = solid.extent
    n_half = np.maximum(1, np.round(2.0 * ext / big)).astype(int)
    step = 2.0 * ext / n_half  # lattice constant per axis
    pts = []
    for shift in (0.0, 0.5):
        axes = [solid.lo[k] + step[k] * (np.arange(-1, n_half[k] // 2 + 2) + shift)
                for k in range(3)]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        pts.append(g)
    pts = np.vstack(pts)
    tol = 1e-9 * float(ext.max())
    inside = np.all((pts >= solid.lo - tol) & (pts <= solid.hi + tol), axis=1)
    return pts[inside], None


def _inside_box(solid: Solid, x: np.ndarray, a: float) -> np.ndarray:
    """Reflect displaced seeds back into the box, at least 2 % of ``a`` from each face."""
    margin = 0.02 * a
    x = x.copy()
    for k in range(3):
        lo, hi = solid.lo[k], solid.hi[k]
        d_lo = np.maximum(np.abs(x[:, k] - lo), margin)
        x[:, k] = np.where(x[:, k] - lo < margin, lo + d_lo, x[:, k])
        d_hi = np.maximum(np.abs(hi - x[:, k]), margin)
        x[:, k] = np.where(hi - x[:, k] < margin, hi - d_hi, x[:, k])
    return x


def _ring_offset(solid: Solid, a: float) -> float:
    # Ring seeds sit this far out of their facet plane; less than the apothem so
    # that the mirrors stay on their own side of the axis.
    return min(0.5 * a, 0.8 * solid.apothem)


def _ring_layers(solid: Solid, a: float) -> int:
    return max(1, round(float(solid.extent[2]) / a))


# Per-layer jitter of the ring (fractions of the layer spacing and of the
# offset). Regular layers at the slab's mid-plane and a lattice symmetric about
# it meet in degenerate vertices (five or more cells), which Qhull resolves into
# edges of 0.01-0.5 mm; repairs of the lattice seeds alone cannot remove them.
# A layer keeps one height and one offset for all its facets, so the radial
# bisectors still pass through the facet edges and the wall stays exact.
_RING_Z_JITTER = 0.1
_RING_OFFSET_JITTER = 0.1


def _ring_clearance(solid: Solid, a: float) -> float:
    """Lattice seeds stay this far out of the facet planes (m).

    A wall point is at most ``sqrt(t^2 + g^2 + (w/2)^2)`` from its nearest ring
    seed (offset at most ``t``; a layer height at most ``g = (1/2 + z jitter) dz``
    away, the z faces mirroring the end layers; facet width ``w``); a lattice
    seed 30 % farther than that can never claim a piece of the wall, so the wall
    stays exactly the facets (checked by the volume test). The bound holds for
    any draw of the layer jitter, so repairs may redraw a layer.
    """
    t = _ring_offset(solid, a)
    g = (0.5 + _RING_Z_JITTER) * float(solid.extent[2]) / _ring_layers(solid, a)
    w = 2 * solid.borehole_radius * math.sin(math.pi / solid.borehole_facets)
    return 1.3 * math.sqrt(t * t + g * g + 0.25 * w * w)


@dataclass
class _Ring:
    """The borehole ring: per layer a height and an offset jitter; grains per sector."""

    solid: Solid
    a: float
    z_jitter: np.ndarray  # (layers,) in [-_RING_Z_JITTER, _RING_Z_JITTER]
    offset_shrink: np.ndarray  # (layers,) in [0, _RING_OFFSET_JITTER]
    grain: np.ndarray  # (layers x facets,) grain of each ring seed, from 0

    @classmethod
    def draw(cls, solid: Solid, a: float, rng: np.random.Generator) -> _Ring:
        n = solid.borehole_facets
        layers = _ring_layers(solid, a)
        width = 2 * solid.borehole_radius * math.sin(math.pi / n)
        per_grain = max(1, min(n, round(a / width)))
        n_groups = max(1, round(n / per_grain))
        grain = []
        for layer in range(layers):
            offset = int(rng.integers(per_grain))
            # Sectors k belong to group floor(((k + offset) mod n) * n_groups / n).
            grain.append(layer * n_groups + ((np.arange(n) + offset) % n) * n_groups // n)
        ring = cls(solid, a, np.zeros(layers), np.zeros(layers), np.concatenate(grain))
        ring.redraw(np.arange(layers), rng)
        return ring

    @property
    def n_layers(self) -> int:
        return len(self.z_jitter)

    def redraw(self, layers: np.ndarray, rng: np.random.Generator) -> None:
        """New height and offset jitter for the given layers."""
        self.z_jitter[layers] = rng.uniform(-_RING_Z_JITTER, _RING_Z_JITTER, len(layers))
        self.offset_shrink[layers] = rng.uniform(0.0, _RING_OFFSET_JITTER, len(layers))

    def seeds(self) -> np.ndarray:
        """(layers x facets, 3) seeds, layer by layer."""
        s = self.solid
        n = s.borehole_facets
        dz = float(s.extent[2]) / self.n_layers
        z = s.lo[2] + (np.arange(self.n_layers) + 0.5 + self.z_jitter) * dz
        r = s.apothem + _ring_offset(s, self.a) * (1.0 - self.offset_shrink)
        phi = (np.arange(n) + 0.5) * 2 * math.pi / n
        return np.column_stack((np.outer(r, np.cos(phi)).ravel(),
                                np.outer(r, np.sin(phi)).ravel(), np.repeat(z, n)))


def _mirrors(solid: Solid, seeds: np.ndarray, n_lat: int) -> tuple[np.ndarray, np.ndarray]:
    """Mirror images and their side index: each seed across each box face; ring
    seeds also across their facet (and those images across the z faces)."""
    pts, side = [], []
    for k in range(3):
        for s, plane in enumerate((solid.lo[k], solid.hi[k])):
            m = seeds.copy()
            m[:, k] = 2 * plane - m[:, k]
            pts.append(m)
            side.append(np.full(len(m), 2 * k + s))
    if solid.has_borehole:
        ring = seeds[n_lat:]
        normals = solid.facet_normals()
        facet = np.argmax(ring @ normals.T, axis=1)
        nrm = normals[facet]
        dist = np.einsum("ij,ij->i", ring, nrm) - solid.apothem
        m = ring - 2 * dist[:, None] * nrm
        b = len(BOX_SIDES)
        pts.append(m)
        side.append(np.full(len(m), b))
        for plane in (solid.lo[2], solid.hi[2]):
            mz = m.copy()
            mz[:, 2] = 2 * plane - mz[:, 2]
            pts.append(mz)
            side.append(np.full(len(mz), b))
    return np.vstack(pts), np.concatenate(side)


def _complex(solid: Solid, seeds: np.ndarray, piece_grain: np.ndarray, ring_piece: np.ndarray
             ) -> GrainComplex:
    """Voronoi cells of the seeds among their mirrors, as a face complex."""
    mirrors, side = _mirrors(solid, seeds, int(np.sum(~ring_piece)))
    points = np.vstack((seeds, mirrors))
    n = len(seeds)
    label = np.concatenate((np.arange(n), -1 - side))
    tri = Delaunay(points)
    indptr, indices = tri.vertex_neighbor_vertices
    scale = float(solid.extent.max())

    raw_vertices, cell_faces = [], []
    for i in range(n):
        nb = indices[indptr[i]:indptr[i + 1]]
        normal = points[nb] - points[i]
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        offset = -np.einsum("ij,ij->i", normal, 0.5 * (points[nb] + points[i]))
        hs = HalfspaceIntersection(np.column_stack((normal, offset)), points[i])
        v = hs.intersections
        dist = v @ normal.T + offset  # (k, neighbours), <= 0 inside
        on = np.abs(dist) < 1e-9 * scale
        faces = []
        for j in range(len(nb)):
            ids = np.flatnonzero(on[:, j])
            if len(ids) >= 3:
                faces.append((int(label[nb[j]]), normal[j], ids))
        raw_vertices.append(v)
        cell_faces.append(faces)

    # Merge vertices computed by several cells (and duplicates from degenerate corners).
    allv = np.vstack(raw_vertices)
    start = np.cumsum([0] + [len(v) for v in raw_vertices])
    gid = _cluster(allv, _MERGE_TOL)
    n_v = int(gid.max()) + 1
    vertices = np.zeros((n_v, 3))
    np.add.at(vertices, gid, allv)
    vertices /= np.bincount(gid, minlength=n_v)[:, None]

    face_key: dict[tuple[int, int], int] = {}
    faces, face_pieces, face_normal = [], [], []
    piece_faces: list[list[int]] = [[] for _ in range(n)]
    for i, fl in enumerate(cell_faces):
        for other, nrm, ids in fl:
            vid = np.unique(gid[start[i] + ids])
            if len(vid) < 3:
                continue
            key = (min(i, other), max(i, other)) if other >= 0 else (i, other)
            if key in face_key:
                piece_faces[i].append(face_key[key])
                continue
            ring = _order_polygon(vertices[vid], nrm, vid)
            if _polygon_area(vertices[ring]) < 1e-12 * scale ** 2:
                continue
            face_key[key] = len(faces)
            piece_faces[i].append(len(faces))
            faces.append(ring)
            face_pieces.append((i, other))
            face_normal.append(nrm)
    cx = GrainComplex(
        solid=solid,
        vertices=vertices,
        faces=tuple(faces),
        face_pieces=np.array(face_pieces, dtype=np.int64),
        face_normal=np.array(face_normal),
        piece_grain=np.asarray(piece_grain, dtype=np.int64),
        piece_faces=tuple(np.array(p, dtype=np.int64) for p in piece_faces),
        seeds=seeds,
        piece_ring=ring_piece,
    )
    return _compact(cx)


def _compact(cx: GrainComplex) -> GrainComplex:
    """Drop vertices no face uses (the merged duplicates' leftovers)."""
    used = np.unique(np.concatenate(cx.faces))
    remap = np.full(len(cx.vertices), -1)
    remap[used] = np.arange(len(used))
    return GrainComplex(cx.solid, cx.vertices[used], tuple(remap[f] for f in cx.faces),
                        cx.face_pieces, cx.face_normal, cx.piece_grain, cx.piece_faces,
                        cx.seeds, cx.piece_ring)


def _cluster(x: np.ndarray, tol: float) -> np.ndarray:
    """Cluster ids of points closer than ``tol`` (connected components)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pairs = cKDTree(x).query_pairs(tol, output_type="ndarray")
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(x), len(x)))
    _, ids = connected_components(g, directed=False)
    # Renumber by first appearance so ids do not depend on scipy's labelling.
    _, first = np.unique(ids, return_index=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[ids]


def _order_polygon(p: np.ndarray, normal: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """Vertex ids of a convex planar polygon, counter-clockwise about ``normal``."""
    c = p.mean(axis=0)
    e1 = p[0] - c
    e1 /= np.linalg.norm(e1)
    e2 = _cross(normal, e1)
    ang = np.arctan2((p - c) @ e2, (p - c) @ e1)
    return ids[np.argsort(ang)]


def _violations(cx: GrainComplex, min_edge: float, max_edge: float, zone_size: float
                ) -> tuple[np.ndarray, float]:
    """Pieces around edges that break the short-edge rule, and the shortest edge (m)."""
    pairs, length, interior = cx.edge_classes()
    bad = (length < _MESH_MIN_EDGE * zone_size)
    bad |= interior & ((length < min_edge) | (length > max_edge))
    if not bad.any():
        return np.empty(0, dtype=np.int64), float(length.min())
    _, owners = cx.edges()
    pieces = set()
    for e in np.flatnonzero(bad):
        for f in owners[e]:
            pieces.update(int(p) for p in cx.face_pieces[f] if p >= 0)
    return np.array(sorted(pieces), dtype=np.int64), float(length.min())


def short_edge_report(cx: GrainComplex, min_edge: float, max_edge: float, zone_size: float
                      ) -> dict[str, int]:
    """Counts of edges that still break the rule after the repair rounds."""
    _, length, interior = cx.edge_classes()
    return {
        "below_mesh_bound": int(np.sum(length < _MESH_MIN_EDGE * zone_size)),
        "interior_below_min": int(np.sum(interior & (length < min_edge))),
        "interior_above_max": int(np.sum(interior & (length > max_edge))),
    }


__all__ = ["BOREHOLE", "GrainComplex", "kelvin_cell_volume", "short_edge_report",
           "target_edge", "tessellate3d"]
