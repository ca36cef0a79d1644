"""3D Voronoi grains: convex polyhedral pieces with exact flat specimen faces.

Construction (the short-edge rule is step 5):

1. Seeds on a body-centred lattice whose Voronoi cells are Kelvin cells
   (truncated octahedra) of edge ``a = 0.95 (min_edge + max_edge) / 2``, the
   lattice constant ``2 sqrt(2) a`` rounded per axis so the faces of the
   bounding box are lattice mirror planes; each seed is displaced at random by
   up to ``jitter x a`` (and reflected back into the solid).
2. Flat sides are exact Voronoi faces: every seed is mirrored across each of
   them, so the bisector of a seed and its mirror is the side itself. Faceted
   sides (a cylinder's lateral surface, the NSCB arc) are half-spaces added to
   every cell. A borehole gets a ring of seeds, one per wall facet and layer,
   mirrored across its facet: the bisectors are the facet planes and the radial
   planes through the facet edges. Consecutive ring cells of a layer form one
   grain (about ``a`` wide at the wall; the grouping offset is random per layer).
3. Solids made of convex parts (the NSCB notch, the penny block's cut plane):
   each cell is clipped to every part it overlaps (Qhull half-space
   intersection from an interior point found by linear programming), giving
   one convex piece per part. Pieces of a cell that touch are one grain, except
   across the penny's plane, where each piece is its own grain. The penny's
   pre-cut disc is made of whole faces: seeds on the plane, one inside and one
   outside each disc facet (mirror images across it), so the bisectors are the
   facet planes; lattice seeds are kept clear of the disc.
4. Vertices computed by several pieces are merged (1 nm), faces are polygons
   of merged vertices, degenerate (edge-only) faces are dropped.
5. Short-edge rule: an edge shorter than ``0.4 x zone_size`` anywhere, or an
   interior grain edge (where three or more grains meet, off the specimen
   surface and off cut planes) outside ``[min_edge, max_edge]``, gives the
   lattice seeds around it a new, smaller displacement; the cells are
   recomputed, up to ``repair_rounds`` times. At zero displacement the Kelvin
   edges are ``a``. Edges that end on the specimen surface or a cut plane, or
   belong to the borehole ring or the disc, are exempt from the grain bounds
   (the 2D rule), not from the mesh bound.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay, HalfspaceIntersection, QhullError, cKDTree

from grainfrac.errors import GeometryError
from grainfrac.geometry.solids3d import BOREHOLE, Solid, polygon_normals
from grainfrac.geometry.zone_sizes import ZoneSizes, as_zone_sizes

_MERGE_TOL = 1e-9  # m: vertices computed twice by Qhull agree to ~1e-16 m
_MESH_MIN_EDGE = 0.4  # x zone size: shortest edge the mesher accepts
_REPAIR_SHRINK = 0.6  # a repaired lattice seed's new displacement, x its previous size
MIN_SEEDS = 4  # fewest grains a 3D specimen is built with; fewer make no assembly


class TooFewGrains(GeometryError):
    """The specimen holds fewer than :data:`MIN_SEEDS` grains at the requested size."""


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
        (p,) True for the pieces of the borehole ring and of the penny's disc.
    piece_seed : np.ndarray | None
        (p,) the cell (seed index) each piece is cut from; None: piece ``k`` is cell ``k``.
    piece_part : np.ndarray | None
        (p,) the part of the solid each piece lies in (:attr:`Solid.parts`); None: one part.
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
    piece_seed: np.ndarray | None = None
    piece_part: np.ndarray | None = None

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

    def cut_faces(self) -> np.ndarray:
        """Ids of faces on a cut plane (between pieces of one cell in two parts)."""
        if self.piece_part is None:
            return np.empty(0, dtype=np.int64)
        a, b = self.face_pieces[:, 0], self.face_pieces[:, 1]
        inner = b >= 0
        bb = np.maximum(b, 0)
        same = inner & (self.piece_seed[a] == self.piece_seed[bb])
        return np.flatnonzero(same & (self.piece_part[a] != self.piece_part[bb]))

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

    def edges(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """Unique edges (e, 2) (u < v, sorted) and the faces each belongs to (ascending)."""
        pairs, _, face, start = self._edge_table
        return pairs, np.split(face, start[1:])

    @functools.cached_property
    def _edge_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Edges (e, 2); per (edge, face) row, sorted by edge then face: the edge and the
        face; and where each edge's rows start. Computed once (the repair rounds and the
        mesher ask for it several times)."""
        lens = np.array([len(r) for r in self.faces])
        flat = np.concatenate(self.faces)
        first = np.cumsum(lens) - lens
        nxt = np.arange(1, len(flat) + 1)
        nxt[first + lens - 1] = first
        u, v = flat, flat[nxt]
        face = np.repeat(np.arange(len(self.faces)), lens)
        lo, hi = np.minimum(u, v), np.maximum(u, v)
        order = np.lexsort((face, hi, lo))
        lo, hi, face = lo[order], hi[order], face[order]
        new = np.ones(len(lo), dtype=bool)
        new[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
        start = np.flatnonzero(new)
        pairs = np.column_stack((lo[start], hi[start])).astype(np.int64)
        edge = np.cumsum(new) - 1
        return pairs, edge, face, start

    def edge_classes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Edge vertex pairs, lengths, and a mask of interior grain edges.

        An interior grain edge lies on no specimen face and has three or more
        grains around it (the edges the grain-size bounds act on).
        """
        pairs, edge, face, _ = self._edge_table
        length = np.linalg.norm(self.vertices[pairs[:, 1]] - self.vertices[pairs[:, 0]], axis=1)
        grains = self.face_grains()[face]
        n_e = len(pairs)
        on_face_side = np.zeros(n_e, dtype=bool)
        np.logical_or.at(on_face_side, edge, grains[:, 1] < 0)
        # Distinct grains around each edge: unique (edge, grain) rows, counted per edge.
        # One int64 key per row (np.unique over rows is ten times slower); grains
        # below zero are the solid's sides.
        shift = int(-min(grains.min(), 0))
        span = int(grains.max()) + shift + 1
        key = np.unique(np.concatenate((edge * span + grains[:, 0] + shift,
                                        edge * span + grains[:, 1] + shift)))
        interior = ~on_face_side & (np.bincount(key // span, minlength=n_e) >= 3)
        on_surface = np.zeros(len(self.vertices), dtype=bool)
        # A cut plane is an imposed surface like the specimen's: edges ending on it
        # are cut by it, as the 2D rule exempts edges cut by the boundary.
        for f in np.concatenate((np.flatnonzero(self.face_pieces[:, 1] < 0), self.cut_faces())):
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
    zone_size: float | ZoneSizes,
    rng: np.random.Generator,
    *,
    jitter: float = 0.4,
    repair_rounds: int = 8,
    ring_repair: bool = False,
) -> GrainComplex:
    """Fill a solid with convex Voronoi pieces grouped into grains.

    Parameters
    ----------
    solid
        The specimen (m).
    min_edge, max_edge
        Bounds on interior grain edge length (m).
    zone_size
        Mesh zone size (m), or the zone sizes near a borehole; no edge may be shorter
        than 0.4 of the zone size where it lies (at its end nearer the borehole axis).
    rng
        Random generator; the only source of randomness.
    jitter
        Largest seed displacement as a fraction of the Kelvin edge.
    repair_rounds
        Rounds of the short-edge rule (module docstring, step 5); faceted and cut
        solids then get the local repair (:func:`_local_repair`).
    ring_repair
        Then redraw borehole-ring layers next to short edges (:func:`_ring_repair`).
    """
    if not 0 < min_edge < max_edge:
        raise GeometryError(f"need 0 < min_edge < max_edge, got {min_edge:g}, {max_edge:g}")
    a = target_edge(min_edge, max_edge)
    # The penny's plane lies on a lattice level (Kelvin vertices lie every quarter
    # lattice constant along z, so no height avoids them); measured on seeds 1-3,
    # a level gave fewer short edges on the plane (1-9) than the quarter (7-17)
    # or eighth (5-8) positions.
    base, _ = _lattice(solid, a)
    ring = _Ring.draw(solid, a, rng) if solid.has_borehole else None
    if ring is not None and len(base):
        r = np.hypot(base[:, 0], base[:, 1])
        base = base[r >= solid.apothem + _ring_clearance(solid, a)]
    if len(solid.facets) or solid.notch is not None or solid.disc_radius > 0:
        base = base[_lattice_keep(solid, base, a, jitter)]
    disc = _Disc.draw(solid, a, rng) if solid.disc_radius > 0 else None
    n_lat = len(base)
    n_facets = solid.borehole_facets
    displacement = _displacements(rng, n_lat, jitter * a)
    ring_seeds = ring.seeds() if ring is not None else np.empty((0, 3))
    n_ring = len(ring_seeds)
    disc_seeds = disc.seeds if disc is not None else np.empty((0, 3))
    n_seeds = n_lat + n_ring + len(disc_seeds)
    if n_seeds < MIN_SEEDS:
        raise TooFewGrains(
            f"specimen too small for its grains: it holds {n_seeds} grain seed(s) at a "
            f"{a * 1e3:.2g} mm grain edge, at least {MIN_SEEDS} are needed; enlarge the "
            f"specimen or lower grains.min_edge_mm / grains.max_edge_mm")
    seed_ring = np.arange(n_seeds) >= n_lat
    grain_of_seed = np.arange(n_seeds)
    if ring is not None:
        grain_of_seed[n_lat:n_lat + n_ring] = n_lat + ring.grain
    if disc is not None:
        grain_of_seed[n_lat + n_ring:] = int(grain_of_seed[:n_lat + n_ring].max(initial=-1)) \
            + 1 + disc.grain
    best, best_edge, best_seeds, best_ring = None, -1.0, None, None
    for _ in range(repair_rounds + 1):
        seeds = _inside_solid(solid, base + displacement, a)
        if ring is not None:
            ring_seeds = ring.seeds()
        all_seeds = np.vstack((seeds, ring_seeds, disc_seeds))
        cx = _complex(solid, all_seeds, grain_of_seed, seed_ring, slice(n_lat, n_lat + n_ring))
        bad, shortest = _violations(cx, min_edge, max_edge, zone_size)
        # A round can make things worse elsewhere: keep the complex whose shortest
        # edge is longest (it sets the mesh's stable step).
        if shortest > best_edge:
            best, best_edge, best_seeds = cx, shortest, all_seeds
            best_ring = ring.state() if ring is not None else None
        if len(bad) == 0:
            break
        bad = np.unique(cx.piece_seed[bad]) if cx.piece_seed is not None else bad
        lat = bad[bad < n_lat]
        # A fresh, smaller displacement: halving alone would converge on the bare
        # lattice, whose edges against the borehole ring can themselves be short.
        amplitude = _REPAIR_SHRINK * np.linalg.norm(displacement[lat], axis=1)
        displacement[lat] = _displacements(rng, len(lat), 1.0) * amplitude[:, None]
        in_ring = bad[(bad >= n_lat) & (bad < n_lat + n_ring)]
        if ring is not None and len(in_ring):
            ring.redraw(np.unique((in_ring - n_lat) // n_facets), rng)
    cx = best
    if ring is not None and ring_repair:
        ring.restore(best_ring)
        cx, best_seeds = _ring_repair(cx, best_seeds, ring, n_lat, grain_of_seed, seed_ring,
                                      zone_size, rng)
    if len(solid.facets) or solid.parts or solid.disc_radius > 0:
        cx = _local_repair(cx, best_seeds, base, grain_of_seed, seed_ring,
                           slice(n_lat, n_lat + n_ring), a, zone_size, jitter, rng)
    volume = float(cx.piece_volumes().sum())
    if abs(volume - solid.volume) > 1e-9 * solid.volume:
        raise GeometryError(f"the grains fill {volume:.9g} m3 of a {solid.volume:.9g} m3 solid")
    if disc is not None:
        area = float(cx.face_areas()[disc_faces(cx)].sum())
        if abs(area - solid.disc_area) > 1e-9 * solid.disc_area:
            raise GeometryError(f"the pre-cut disc has {area:.9g} m2 of grain faces, its "
                                f"polygon {solid.disc_area:.9g} m2")
    return cx


def disc_faces(cx: GrainComplex) -> np.ndarray:
    """Ids of the cut-plane faces inside the penny's faceted disc (whole faces, by
    construction, so a face is inside when its centroid is)."""
    solid = cx.solid
    faces = cx.cut_faces()
    if solid.disc_radius <= 0 or len(faces) == 0:
        return np.empty(0, dtype=np.int64)
    centre = np.array([cx.vertices[cx.faces[f]].mean(axis=0) for f in faces])
    apothem = solid.disc_vertex_radius * math.cos(math.pi / solid.disc_facets)
    reach = np.max(centre @ polygon_normals(solid.disc_facets).T, axis=1)
    return faces[reach < apothem]


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


def _lattice_keep(solid: Solid, base: np.ndarray, a: float, jitter: float) -> np.ndarray:
    """Lattice points to keep: inside the facets and out of the notch slot (the seeds
    are reflected back each round), and clear of the penny's disc."""
    tol = 1e-9 * float(solid.extent.max())
    keep = np.ones(len(base), dtype=bool)
    if len(solid.facets):
        keep &= np.max(base @ solid.facets[:, :3].T - solid.facets[:, 3], axis=1) <= tol
    if solid.notch is not None:
        keep &= solid.notch_distance(base) > 0
    if solid.disc_radius > 0:
        # Lower bound of the distance to the disc polygon (it lies in its circle); a
        # displaced seed stays at least the disc's clearance away.
        r = np.hypot(base[:, 0], base[:, 1])
        d = np.hypot(np.maximum(r - solid.disc_vertex_radius, 0.0), base[:, 2] - solid.cut_z)
        keep &= d >= _Disc.clearance(solid, a) + jitter * a
    return keep


def _inside_solid(solid: Solid, x: np.ndarray, a: float) -> np.ndarray:
    """Reflect displaced seeds back into the solid, at least 2 % of ``a`` inside each
    face of the bounding box and each facet (interior points of their cells)."""
    margin = 0.02 * a
    x = x.copy()
    for k in range(3):
        lo, hi = solid.lo[k], solid.hi[k]
        d_lo = np.maximum(np.abs(x[:, k] - lo), margin)
        x[:, k] = np.where(x[:, k] - lo < margin, lo + d_lo, x[:, k])
        d_hi = np.maximum(np.abs(hi - x[:, k]), margin)
        x[:, k] = np.where(hi - x[:, k] < margin, hi - d_hi, x[:, k])
    if len(solid.facets):
        n, d = solid.facets[:, :3], solid.facets[:, 3]
        # Across the most violated facet; a few passes settle the polygon's corners.
        for _ in range(3):
            depth = d - x @ n.T  # > 0 inside
            worst = np.argmin(depth, axis=1)
            dist = depth[np.arange(len(x)), worst]
            move = dist < margin
            if not move.any():
                break
            shift = np.maximum(np.abs(dist[move]), margin) - dist[move]
            x[move] -= shift[:, None] * n[worst[move]]
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
        grain = []
        for layer in range(layers):
            grain.append(layer * _n_groups(n, width, a) + _ring_groups(n, width, a, rng))
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

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.z_jitter.copy(), self.offset_shrink.copy()

    def restore(self, state: tuple[np.ndarray, np.ndarray]) -> None:
        self.z_jitter[:], self.offset_shrink[:] = state

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


def _n_groups(n: int, width: float, a: float) -> int:
    per_grain = max(1, min(n, round(a / width)))
    return max(1, round(n / per_grain))


def _ring_groups(n: int, width: float, a: float, rng: np.random.Generator) -> np.ndarray:
    """Group of each of ``n`` consecutive sectors of ``width`` around a ring: groups about
    ``a`` wide, starting at a random sector."""
    per_grain = max(1, min(n, round(a / width)))
    n_groups = _n_groups(n, width, a)
    offset = int(rng.integers(per_grain))
    # Sectors k belong to group floor(((k + offset) mod n) * n_groups / n).
    return ((np.arange(n) + offset) % n) * n_groups // n


@dataclass(frozen=True)
class _Disc:
    """The penny's disc: seeds on the cut plane, an inner and an outer one per disc
    facet, mirror images across it, so that the facet planes are their bisectors.

    The inner seeds sit at the distance ``t`` inside the facets that makes the disc
    centre and the polygon's vertices equally far from their nearest inner seed
    (``D``); no other seed claims a point of the disc if it is farther than ``D``
    from all of it, and the lattice is kept farther (:meth:`clearance`). The inner
    cells meet on the axis, so the disc centre is a vertex: a fluid node.
    """

    seeds: np.ndarray  # (2 n, 3): inner seeds, then outer seeds
    grain: np.ndarray  # (2 n,) group of each seed, from 0

    @staticmethod
    def geometry(solid: Solid) -> tuple[int, float, float, float]:
        """Facets, apothem, chord and seed offset ``t`` of the disc (m)."""
        n, r = solid.disc_facets, solid.disc_vertex_radius
        apothem = r * math.cos(math.pi / n)
        chord = 2 * r * math.sin(math.pi / n)
        t = (apothem ** 2 - 0.25 * chord ** 2) / (2 * apothem)
        return n, apothem, chord, t

    @staticmethod
    def clearance(solid: Solid, a: float) -> float:
        """Lattice seeds stay this far from the disc (m): 30 % beyond ``D`` for
        exactness, and at least ``a`` so that the disc's cells are a zone or so thick."""
        _, apothem, chord, t = _Disc.geometry(solid)
        reach = max(math.hypot(t, 0.5 * chord), apothem - t)
        return max(1.3 * reach, a)

    @classmethod
    def draw(cls, solid: Solid, a: float, rng: np.random.Generator) -> _Disc:
        n, apothem, chord, t = cls.geometry(solid)
        normal = polygon_normals(n)
        z = np.full((n, 1), solid.cut_z)
        inner = np.hstack(((apothem - t) * normal[:, :2], z))
        outer = np.hstack(((apothem + t) * normal[:, :2], z))
        groups_in = _ring_groups(n, chord, a, rng)
        groups_out = groups_in.max() + 1 + _ring_groups(n, chord, a, rng)
        return cls(np.vstack((inner, outer)), np.concatenate((groups_in, groups_out)))


def _mirrors(solid: Solid, seeds: np.ndarray, ring: slice) -> tuple[np.ndarray, np.ndarray]:
    """Mirror images and their side index: each seed across each flat side; borehole
    ring seeds also across their facet (and those images across the z faces)."""
    pts, side = [], []
    names = solid.sides
    for f in solid.flat_sides:
        m = seeds.copy()
        m[:, f.axis] = 2 * f.value - m[:, f.axis]
        pts.append(m)
        side.append(np.full(len(m), names.index(f.name)))
    if solid.has_borehole:
        ring_seeds = seeds[ring]
        normals = solid.facet_normals()
        facet = np.argmax(ring_seeds @ normals.T, axis=1)
        nrm = normals[facet]
        dist = np.einsum("ij,ij->i", ring_seeds, nrm) - solid.apothem
        m = ring_seeds - 2 * dist[:, None] * nrm
        b = names.index(BOREHOLE)
        pts.append(m)
        side.append(np.full(len(m), b))
        for plane in (solid.lo[2], solid.hi[2]):
            mz = m.copy()
            mz[:, 2] = 2 * plane - mz[:, 2]
            pts.append(mz)
            side.append(np.full(len(mz), b))
    return np.vstack(pts), np.concatenate(side)


# Half-space labels: (kind, value). Kind 0: a neighbour, value the seed (>= 0) or
# -1 - side for a mirror or a part's surface plane; kind 1: an internal cut plane,
# value the part on its other side; kind 2: a facet, value its index (a piece can
# have several faces on the faceted side, which must not be taken for one).
_NEIGHBOUR, _CUT, _FACET = 0, 1, 2


def _cell_faces(v: np.ndarray, rows: np.ndarray, labels: np.ndarray, scale: float) -> list:
    """Faces of a convex polytope: its half-spaces holding three or more vertices."""
    dist = v @ rows[:, :3].T + rows[:, 3]  # (k, half-spaces), <= 0 inside
    on = np.abs(dist) < 1e-9 * scale
    faces = []
    for j in range(len(rows)):
        ids = np.flatnonzero(on[:, j])
        if len(ids) >= 3:
            faces.append(((int(labels[j, 0]), int(labels[j, 1])), rows[j, :3], ids))
    return faces


def _chebyshev(rows: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre and radius of the largest ball in ``rows . (x, 1) <= 0`` (unit normals)."""
    from scipy.optimize import linprog

    res = linprog(np.array([0.0, 0.0, 0.0, -1.0]),
                  A_ub=np.column_stack((rows[:, :3], np.ones(len(rows)))), b_ub=-rows[:, 3],
                  bounds=[(None, None)] * 3 + [(0.0, None)], method="highs")
    if res.status != 0:
        return np.zeros(3), 0.0
    return res.x[:3], float(res.x[3])


def _split_parts(solid: Solid, v: np.ndarray, rows: np.ndarray, labels: np.ndarray,
                 scale: float):
    """The pieces of a cell (vertices ``v`` of the half-spaces ``rows``), one per part
    of the solid it overlaps: ``(part, vertices, rows, labels)``."""
    if not solid.parts:
        yield 0, v, rows, labels
        return
    tol = 1e-9 * scale
    for p, part in enumerate(solid.parts):
        s = v @ part.planes[:, :3].T - part.planes[:, 3]  # (vertices, planes), <= 0 in part
        if np.all(s <= tol):
            yield p, v, rows, labels  # the whole cell lies in this part
            return
        if np.any(np.all(s >= -tol, axis=0)):
            continue  # a plane of the part has the whole cell on its far side
        p_rows = np.column_stack((part.planes[:, :3], -part.planes[:, 3]))
        p_labels = np.array([(_NEIGHBOUR, -1 - solid.sides.index(name)) if name
                             else (_CUT, across)
                             for name, across in zip(part.side, part.across, strict=True)])
        all_rows = np.vstack((rows, p_rows))
        centre, radius = _chebyshev(all_rows)
        if radius <= tol:
            continue
        vp = HalfspaceIntersection(all_rows, centre).intersections
        yield p, vp, all_rows, np.vstack((labels, p_labels))


def _cell_halfspaces(points: np.ndarray, label: np.ndarray, indptr: np.ndarray,
                     indices: np.ndarray, i: int, clip: np.ndarray, clip_labels: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Half-spaces (Qhull rows) and labels of the Voronoi cell of point ``i``: the
    bisectors with its Delaunay neighbours, then the solid's facets."""
    nb = indices[indptr[i]:indptr[i + 1]]
    normal = points[nb] - points[i]
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    offset = -np.einsum("ij,ij->i", normal, 0.5 * (points[nb] + points[i]))
    rows = np.column_stack((normal, offset))
    labels = np.column_stack((np.zeros(len(nb), dtype=np.int64), label[nb]))
    if len(clip):
        rows = np.vstack((rows, clip))
        labels = np.vstack((labels, clip_labels))
    return rows, labels


def _complex(solid: Solid, seeds: np.ndarray, grain_of_seed: np.ndarray,
             seed_ring: np.ndarray, ring: slice) -> GrainComplex:
    """Voronoi cells of the seeds among their mirrors, clipped to the solid's facets and
    cut into its parts, as a face complex (``ring``: the borehole ring's seeds)."""
    mirrors, side = _mirrors(solid, seeds, ring)
    points = np.vstack((seeds, mirrors))
    n = len(seeds)
    label = np.concatenate((np.arange(n), -1 - side))
    try:
        tri = Delaunay(points)
    except QhullError as exc:
        # Seeds and mirrors in a degenerate position: a few seeds in a small solid.
        raise GeometryError(
            f"the grain seeds of this specimen ({n} of them) have no 3D Voronoi diagram "
            f"(Qhull: {str(exc).splitlines()[0]}); enlarge the specimen or lower "
            f"grains.min_edge_mm / grains.max_edge_mm") from None
    indptr, indices = tri.vertex_neighbor_vertices
    scale = float(solid.extent.max())
    clip = solid.clip_halfspaces()
    clip_labels = np.column_stack((np.full(len(clip), _FACET), np.arange(len(clip))))
    facet_label = -1 - solid.sides.index(solid.facet_side) if len(clip) else 0

    # Pieces: (seed, part, vertices, faces).
    pieces = []
    for i in range(n):
        rows, labels = _cell_halfspaces(points, label, indptr, indices, i, clip, clip_labels)
        v = HalfspaceIntersection(rows, points[i]).intersections
        for part, vp, prows, plabels in _split_parts(solid, v, rows, labels, scale):
            pieces.append((i, part, vp, _cell_faces(vp, prows, plabels, scale)))
    piece_seed = np.array([p[0] for p in pieces], dtype=np.int64)
    piece_part = np.array([p[1] for p in pieces], dtype=np.int64)
    piece_of = {(i, part): k for k, (i, part, _, _) in enumerate(pieces)}

    # Merge vertices computed by several pieces (and duplicates from degenerate corners).
    raw_vertices = [p[2] for p in pieces]
    allv = np.vstack(raw_vertices)
    start = np.cumsum([0] + [len(v) for v in raw_vertices])
    gid = _cluster(allv, _MERGE_TOL)
    n_v = int(gid.max()) + 1
    vertices = np.zeros((n_v, 3))
    np.add.at(vertices, gid, allv)
    vertices /= np.bincount(gid, minlength=n_v)[:, None]

    # Each face of each piece, with what lies on its other side and the merged ids of
    # its corners (a set: np.unique costs 35 us a call).
    entries = []
    for k, (i, part, _, fl) in enumerate(pieces):
        for (kind, value), nrm, ids in fl:
            if kind == _CUT:
                other = piece_of.get((i, value))
            elif kind == _FACET:
                other = facet_label
            elif value >= 0:
                other = piece_of.get((value, part))
            else:
                other = value
            if other is None:
                raise GeometryError(f"cell {i}: a face of its piece in part {part} has no "
                                    "piece on its other side (a sliver below 1 nm)")
            if kind == _FACET:
                key = (k, other, value)
            else:
                key = (min(k, other), max(k, other)) if other >= 0 else (k, other)
            corners = set(gid[start[k] + ids].tolist())
            if len(corners) >= 3:
                entries.append((k, other, key, nrm, np.array(sorted(corners), dtype=np.int64)))
    # Polygons of the first entry of each key, ordered all at once.
    first: dict[tuple[int, ...], int] = {}
    for e, entry in enumerate(entries):
        first.setdefault(entry[2], e)
    chosen = list(first.values())  # in entry order
    ordered, areas = _order_polygons(vertices, [entries[e][4] for e in chosen],
                                     np.array([entries[e][3] for e in chosen]).reshape(-1, 3))
    rings = {e: (ring, area) for e, ring, area in zip(chosen, ordered, areas, strict=True)}
    tiny = 1e-12 * scale ** 2

    face_key: dict[tuple[int, ...], int] = {}
    faces, face_pieces, face_normal = [], [], []
    piece_faces: list[list[int]] = [[] for _ in pieces]
    for e, (k, other, key, nrm, vid) in enumerate(entries):
        if key in face_key:
            piece_faces[k].append(face_key[key])
            continue
        if e not in rings:  # an earlier entry of its key had no area
            (ring,), (area,) = _order_polygons(vertices, [vid], nrm[None, :])
            rings[e] = ring, area
        ring, area = rings[e]
        if area < tiny:
            continue
        face_key[key] = len(faces)
        piece_faces[k].append(len(faces))
        faces.append(ring)
        face_pieces.append((k, other))
        face_normal.append(nrm)
    face_pieces = np.array(face_pieces, dtype=np.int64)
    split = bool(solid.parts)
    cx = GrainComplex(
        solid=solid,
        vertices=vertices,
        faces=tuple(faces),
        face_pieces=face_pieces,
        face_normal=np.array(face_normal),
        piece_grain=_grains(solid, grain_of_seed[piece_seed], piece_part, face_pieces),
        piece_faces=tuple(np.array(p, dtype=np.int64) for p in piece_faces),
        seeds=seeds[piece_seed],
        piece_ring=seed_ring[piece_seed],
        piece_seed=piece_seed if split else None,
        piece_part=piece_part if split else None,
    )
    return _compact(cx)


# Local repair of faceted and cut solids: sweeps over the lattice seeds next to edges
# below the mesh bound, and tries per seed (seeds 0-3, 3-8 mm grains: UCS cylinder
# 14 -> 6-8 short edges, Brazilian disc 22-27 -> 6-12).
_LOCAL_SWEEPS = 4
_LOCAL_TRIES = 6
# Tries in all: each costs a Delaunay of all seeds and mirrors (25 ms on the 60 mm
# penny, whose repair took 45 s unbounded for 80 -> 37 short edges).
_LOCAL_BUDGET = 300


def _local_repair(cx: GrainComplex, seeds: np.ndarray, base: np.ndarray,
                  grain_of_seed: np.ndarray, seed_ring: np.ndarray, ring: slice, a: float,
                  zone_size: float | ZoneSizes, jitter: float, rng: np.random.Generator
                  ) -> GrainComplex:
    """Move lattice seeds one at a time off the junctions that make short edges.

    On a faceted surface (or the penny's plane and disc) a grain edge ends at a
    random point of a facet and is short wherever that point falls within 0.4
    zone of a facet edge; every cell of a lab specimen touches the surface, so the
    global rounds redraw them all at once and never settle (and their shrinking
    steps lead back to the lattice, which meets the facets at fixed places). Here a
    seed next to a short edge gets a fresh displacement about its lattice point,
    kept only if the cells around it (its neighbours before and after, uncut) are
    better by :func:`_better` (no more edges below the bound, no shorter shortest
    edge, one of the two improved); after each sweep the whole complex is kept if
    it is better by the same rule. Edges made by the parts' cut planes are not
    judged (the cells are uncut), only found as the next sweep's seeds.
    """
    solid = cx.solid
    limit = _MESH_MIN_EDGE * as_zone_sizes(zone_size).smallest
    n_lat = len(base)
    cells = _LocalCells(solid, ring)
    best, best_score = cx, _complex_score(cx, limit)
    budget = _LOCAL_BUDGET
    for _ in range(_LOCAL_SWEEPS):
        bad, _ = _violations(cx, 0.0, np.inf, zone_size)
        if cx.piece_seed is not None:
            bad = np.unique(cx.piece_seed[bad])
        lat = bad[bad < n_lat]
        moved = False
        before = cells.triangulate(seeds)
        for s in lat:
            for _ in range(min(_LOCAL_TRIES, budget)):
                budget -= 1
                trial = seeds.copy()
                trial[s] = _inside_solid(solid, base[s:s + 1] + _displacements(rng, 1, jitter * a),
                                         a)[0]
                after = cells.triangulate(trial)
                around = sorted({int(s)} | cells.neighbours(before, s)
                                | cells.neighbours(after, s))
                old = cells.score(before, around, limit)
                if _better(cells.score(after, around, limit, against=old), old):
                    seeds, moved, before = trial, True, after
                    break
        if not moved:
            break
        cx = _complex(solid, seeds, grain_of_seed, seed_ring, ring)
        score = _complex_score(cx, limit)
        if _better(score, best_score):
            best, best_score = cx, score
        if budget <= 0:
            break
    return best


# Ring-layer repair: sweeps and tries per layer (100 mm cube, seed 1: the short edges
# all lay where two ring layers meet the lattice, 121 of them at 8 layer boundaries).
_RING_SWEEPS = 4
_RING_TRIES = 12
# Bounds (x zone) of the two passes: the mesh's own, then one that lengthens the
# ring's shortest edges further where that costs nothing elsewhere (a grain corner
# at 0.45 zone edges caps the real-mass step near 0.3 of a regular zone's).
_RING_BOUNDS = (_MESH_MIN_EDGE, 0.5)
_RING_WINDOW = 4.0  # x the Kelvin edge: seeds around a layer that its cells depend on


def _ring_repair(cx: GrainComplex, seeds: np.ndarray, ring: _Ring, n_lat: int,
                 grain_of_seed: np.ndarray, seed_ring: np.ndarray,
                 zone_size: float | ZoneSizes, rng: np.random.Generator
                 ) -> tuple[GrainComplex, np.ndarray]:
    """Redraw the jitter of ring layers next to short edges, one layer at a time.

    Where two ring layers meet the lattice cells outside them, the lattice faces
    reach the ring's skin at heights the layers' jitter sets; a tall specimen has so
    many layer boundaries (19 layers in the 100 mm cube) that the global rounds,
    which redraw every bad layer at once, leave some boundary short. Here a layer's
    new draw is judged on the uncut cells of it and the layers beside it with their
    lattice neighbours (Voronoi cells of the seeds in a window around the layer), and
    kept if better by :func:`_better`. After each sweep the whole complex is kept if
    it is better by the same rule (the next sweep goes on from the last one: going
    back to the kept complex left more short edges in the cube, 55 against 11). Two
    passes, at the bounds ``_RING_BOUNDS``; the ring is left at the kept complex's
    draw.
    """
    for fraction in _RING_BOUNDS:
        cx, seeds = _ring_pass(cx, seeds, ring, n_lat, grain_of_seed, seed_ring,
                               zone_size, fraction, rng)
    return cx, seeds


def _ring_pass(cx: GrainComplex, seeds: np.ndarray, ring: _Ring, n_lat: int,
               grain_of_seed: np.ndarray, seed_ring: np.ndarray,
               zone_size: float | ZoneSizes, fraction: float, rng: np.random.Generator
               ) -> tuple[GrainComplex, np.ndarray]:
    solid = cx.solid
    n_facets = solid.borehole_facets
    ring_slice = slice(n_lat, n_lat + n_facets * ring.n_layers)
    limit = fraction * as_zone_sizes(zone_size).smallest
    reach = _RING_WINDOW * ring.a
    best, best_score, best_seeds, best_ring = cx, _complex_score(cx, limit), seeds, ring.state()
    start = seeds
    measured: dict[bytes, np.ndarray] = {}  # cells' edges, shared by the layers' windows
    for _ in range(_RING_SWEEPS):
        bad, _ = _violations(cx, 0.0, np.inf, zone_size, fraction)
        if cx.piece_seed is not None:
            bad = np.unique(cx.piece_seed[bad])
        in_ring = bad[(bad >= n_lat) & (bad < ring_slice.stop)]
        layers = np.unique((in_ring - n_lat) // n_facets)
        if len(layers) == 0:
            break
        moved = False
        for layer in layers.tolist():
            # Cells near the layer depend on nearby seeds only: a window of seeds
            # around it makes each Delaunay several times cheaper than all of them.
            z = seeds[n_lat + layer * n_facets, 2]
            window = np.flatnonzero((np.abs(seeds[:, 2] - z) < reach)
                                    & (np.hypot(seeds[:, 0], seeds[:, 1])
                                       < solid.apothem + reach))
            # Box solids hold no seeds after the ring's, so the window ends with them.
            n_local_ring = int(np.count_nonzero(window >= n_lat))
            cells = _LocalCells(solid, slice(len(window) - n_local_ring, len(window)),
                                box=True, cache=measured)
            near = range(max(0, layer - 1), min(ring.n_layers, layer + 2))
            own = np.searchsorted(window, [n_lat + k * n_facets + j for k in near
                                           for j in range(n_facets)]).tolist()
            before = cells.triangulate(seeds[window])
            around_before = set(own).union(*(cells.neighbours(before, s) for s in own))
            kept = ring.state()
            for _ in range(_RING_TRIES):
                ring.redraw(np.array([layer]), rng)
                trial = seeds.copy()
                trial[ring_slice] = ring.seeds()
                after = cells.triangulate(trial[window])
                around = sorted(around_before.union(*(cells.neighbours(after, s)
                                                      for s in own)))
                old = cells.score(before, around, limit)
                if _better(cells.score(after, around, limit, against=old), old):
                    seeds, moved = trial, True
                    kept = ring.state()
                    break
                ring.restore(kept)
        if not moved:
            break
        cx = _complex(solid, seeds, grain_of_seed, seed_ring, ring_slice)
        score = _complex_score(cx, limit)
        if _better(score, best_score):
            best, best_score, best_seeds, best_ring = cx, score, seeds, ring.state()
        elif best_seeds is start and fraction == _MESH_MIN_EDGE:
            # The first sweep at the mesh's bound gained nothing: in a block the ring
            # nearly fills (40 mm, seeds 1-2) the short edges are where the lattice
            # meets it, which no layer draw mends, and more sweeps only cost time.
            # The second pass keeps going from worse sweeps: on the default slab
            # that found a 0.95 mm shortest edge where stopping kept 0.82.
            break
    ring.restore(best_ring)
    return best, best_seeds


def _better(new: tuple[int, float], old: tuple[int, float]) -> bool:
    """Fewer short edges without a shorter shortest edge, or a longer shortest edge
    without more short edges (the shortest edge sets the stable step)."""
    return new[0] <= old[0] and new[1] <= old[1] and new != old


def _complex_score(cx: GrainComplex, limit: float) -> tuple[int, float]:
    """Edges below ``limit`` and minus the shortest edge: smaller is better."""
    length = cx.edge_classes()[1]
    return int(np.sum(length < limit)), -float(length.min())


class _LocalCells:
    """Voronoi cells of a few seeds among all (uncut: the solid's parts are left out),
    for judging a seed move by the edges around it.

    ``box``: the box's sides are half-spaces of every cell instead of mirror images
    of every seed across them (the same planes: a mirror's bisector is its side), so a
    window of seeds costs a Delaunay of those seeds and the borehole's facet mirrors
    only; for box solids (the ring repair). ``cache``: cells' edges measured so far,
    to share between instances over the same solid.
    """

    def __init__(self, solid: Solid, ring: slice, box: bool = False,
                 cache: dict[bytes, np.ndarray] | None = None):
        self.solid, self.ring, self.box = solid, ring, box
        self.scale = float(solid.extent.max())
        clip = solid.clip_halfspaces()
        if box:
            eye = np.eye(3)
            clip = np.vstack((clip, np.column_stack((eye, -solid.hi)),
                              np.column_stack((-eye, solid.lo))))
        self.clip = clip
        self.clip_labels = np.column_stack((np.full(len(clip), _FACET), np.arange(len(clip))))
        self._cache = {} if cache is None else cache

    def triangulate(self, seeds: np.ndarray) -> tuple:
        mirrors, side = _mirrors(self.solid, seeds, self.ring)
        if self.box:
            facet = np.all((mirrors >= self.solid.lo) & (mirrors <= self.solid.hi), axis=1)
            mirrors, side = mirrors[facet], side[facet]
        points = np.vstack((seeds, mirrors))
        label = np.concatenate((np.arange(len(seeds)), -1 - side))
        indptr, indices = Delaunay(points).vertex_neighbor_vertices
        return points, label, indptr, indices, len(seeds)

    @staticmethod
    def neighbours(tri: tuple, s: int) -> set[int]:
        _, _, indptr, indices, n = tri
        return {int(j) for j in indices[indptr[s]:indptr[s + 1]] if j < n}

    def score(self, tri: tuple, around: list[int], limit: float,
              against: tuple[int, float] | None = None) -> tuple[int, float]:
        """Edges below ``limit`` of the cells ``around`` (each counted per cell), and
        minus the shortest.

        ``against``: a score to beat (:func:`_better`); the count stops at the first
        cell that makes this score worse in either part, since more cells only make
        it worse still (on the 100 mm cube the repairs then measure 34,520 cells
        instead of 47,607, and keep the same seeds).
        """
        count, shortest = 0, np.inf
        for i in around:
            length = self._edges(tri, i)
            count += int(np.sum(length < limit))
            shortest = min(shortest, float(length.min(initial=np.inf)))
            if against is not None and (count > against[0] or -shortest > against[1]):
                break
        return count, -shortest

    def _edges(self, tri: tuple, i: int) -> np.ndarray:
        """Edge lengths of the cell of point ``i``, measured once per cell: a cell is
        its point and its Delaunay neighbours' points, so a try that moves a few seeds
        measures only the cells around them (the ring repair's cost was these cells:
        80,000 in the 100 mm cube, 22 s)."""
        points, label, indptr, indices, _ = tri
        nb = points[indices[indptr[i]:indptr[i + 1]]]
        key = points[i].tobytes() + nb[np.lexsort(nb.T)].tobytes()
        length = self._cache.get(key)
        if length is None:
            rows, _ = _cell_halfspaces(points, label, indptr, indices, i, self.clip,
                                       self.clip_labels)
            v = HalfspaceIntersection(rows, points[i]).intersections
            length = self._cache[key] = _polytope_edges(v, rows, self.scale)
        return length


@functools.lru_cache(maxsize=256)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs i < j of n items (``np.triu_indices`` builds a mask each call: 4 of
    the cube's 8 s in :func:`_polytope_edges`)."""
    return np.triu_indices(n, 1)


def _polytope_edges(v: np.ndarray, rows: np.ndarray, scale: float) -> np.ndarray:
    """Edge lengths of a convex polytope from its vertices and half-spaces: vertex pairs
    on two common faces (faces: half-spaces holding three vertices or more); vertices
    Qhull computed twice (closer than 1 nm) are one."""
    on = np.abs(v @ rows[:, :3].T + rows[:, 3]) < 1e-9 * scale
    on = on[:, on.sum(axis=0) >= 3].astype(np.int64)
    i, j = _pairs(len(v))
    shared = (on @ on.T)[i, j] >= 2
    length = np.linalg.norm(v[i[shared]] - v[j[shared]], axis=1)
    return length[length > _MERGE_TOL]


def _grains(solid: Solid, group: np.ndarray, part: np.ndarray, face_pieces: np.ndarray
            ) -> np.ndarray:
    """Grain of each piece: the pieces of one group (a cell, or a ring grain) that touch
    form one grain, except across the penny's plane (``split_grains``).

    Grains are numbered by group, then by their first piece; with one grain per
    group (every solid without parts) the grain is the group itself.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = len(group)
    a, b = face_pieces[:, 0], face_pieces[:, 1]
    inner = b >= 0
    a, b = a[inner], b[inner]
    join = group[a] == group[b]
    if solid.split_grains:
        join &= part[a] == part[b]
    g = coo_matrix((np.ones(int(join.sum())), (a[join], b[join])), shape=(n, n))
    _, comp = connected_components(g, directed=False)
    first = np.full(comp.max() + 1, n)
    np.minimum.at(first, comp, np.arange(n))
    key = group.astype(np.int64) * (n + 1) + first[comp]
    _, grain = np.unique(key, return_inverse=True)
    return grain.ravel().astype(np.int64)


def _compact(cx: GrainComplex) -> GrainComplex:
    """Drop vertices no face uses (the merged duplicates' leftovers)."""
    used = np.unique(np.concatenate(cx.faces))
    remap = np.full(len(cx.vertices), -1)
    remap[used] = np.arange(len(used))
    return GrainComplex(cx.solid, cx.vertices[used], tuple(remap[f] for f in cx.faces),
                        cx.face_pieces, cx.face_normal, cx.piece_grain, cx.piece_faces,
                        cx.seeds, cx.piece_ring, cx.piece_seed, cx.piece_part)


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


def _order_polygons(vertices: np.ndarray, vids: list[np.ndarray], normals: np.ndarray
                    ) -> tuple[list[np.ndarray], np.ndarray]:
    """Vertex ids of convex planar polygons, each counter-clockwise about its normal and
    starting at its smallest angle from its first vertex about its centroid, and the
    polygons' areas; all polygons at once (one at a time cost 85 us each)."""
    if not vids:
        return [], np.empty(0)
    lens = np.array([len(v) for v in vids])
    ids = np.concatenate(vids)
    face = np.repeat(np.arange(len(vids)), lens)
    head = np.cumsum(lens) - lens
    p = vertices[ids]
    c = np.add.reduceat(p, head, axis=0) / lens[:, None]
    d = p - c[face]
    e1 = d[head] / np.linalg.norm(d[head], axis=1)[:, None]
    e2 = _cross(normals, e1)
    ang = np.arctan2(np.einsum("ij,ij->i", d, e2[face]), np.einsum("ij,ij->i", d, e1[face]))
    order = np.lexsort((ang, face))
    ids, d = ids[order], d[order]
    nxt = np.arange(1, len(ids) + 1)
    nxt[head + lens - 1] = head
    area = 0.5 * np.linalg.norm(np.add.reduceat(_cross(d, d[nxt]), head, axis=0), axis=1)
    return np.split(ids, head[1:]), area


def _mesh_bound(cx: GrainComplex, pairs: np.ndarray, zone_size: float | ZoneSizes,
                fraction: float = _MESH_MIN_EDGE) -> np.ndarray | float:
    """Shortest edge the mesher accepts (m), per edge where the zones are refined."""
    zones = as_zone_sizes(zone_size)
    if zones.uniform:
        return fraction * zones.far
    ends = zones.of_points(cx.vertices[pairs.ravel()]).reshape(-1, 2)
    return fraction * ends.min(axis=1)


def _violations(cx: GrainComplex, min_edge: float, max_edge: float,
                zone_size: float | ZoneSizes, fraction: float = _MESH_MIN_EDGE
                ) -> tuple[np.ndarray, float]:
    """Pieces around edges that break the short-edge rule, and the shortest edge (m)."""
    pairs, length, interior = cx.edge_classes()
    bad = (length < _mesh_bound(cx, pairs, zone_size, fraction))
    bad |= interior & ((length < min_edge) | (length > max_edge))
    if not bad.any():
        return np.empty(0, dtype=np.int64), float(length.min())
    _, edge, face, _ = cx._edge_table
    around = cx.face_pieces[face[bad[edge]]].ravel()
    return np.unique(around[around >= 0]), float(length.min())


def short_edge_report(cx: GrainComplex, min_edge: float, max_edge: float,
                      zone_size: float | ZoneSizes) -> dict[str, int]:
    """Counts of edges that still break the rule after the repair rounds."""
    pairs, length, interior = cx.edge_classes()
    return {
        "below_mesh_bound": int(np.sum(length < _mesh_bound(cx, pairs, zone_size))),
        "interior_below_min": int(np.sum(interior & (length < min_edge))),
        "interior_above_max": int(np.sum(interior & (length > max_edge))),
    }


__all__ = ["BOREHOLE", "GrainComplex", "disc_faces", "kelvin_cell_volume", "short_edge_report",
           "target_edge", "tessellate3d"]
