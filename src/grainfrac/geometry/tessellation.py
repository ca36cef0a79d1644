"""Voronoi grain tessellation with grain edge-length control.

Raw Voronoi cells have edges down to micrometres, which give sliver elements
and a tiny critical time step. The paper's grains have edges between a minimum
and a maximum length (3-8 mm), so the tessellation is regularised:

1. seeds at a density matching the target edge length, relaxed by Lloyd steps
   towards a centroidal Voronoi tessellation (near-hexagonal cells);
2. cells clipped to the specimen, tiny clipped pieces merged into a neighbour;
3. the cells become a planar graph (shared vertices merged), on which internal
   edges shorter than the minimum are collapsed and very short pieces of the
   specimen boundary are removed;
4. where an internal edge is still longer than the maximum, a seed is added at
   its midpoint and steps 1-3 are repeated.

Internal edges that end on the specimen boundary are cut by it and are exempt
from the bounds (the issue's "except where the specimen boundary cuts a grain").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import cKDTree
from shapely.ops import nearest_points, split

from grainfrac.errors import GeometryError
from grainfrac.geometry.specimens import Outline

# Merge tolerance for vertices that shapely computed twice (metres): far below
# any physical length, far above round-off at the millimetre scale.
_MERGE_TOL = 1e-9


@dataclass(frozen=True)
class GrainMap:
    """Grains as a planar graph.

    Attributes
    ----------
    outline : Outline
        The specimen the grains fill.
    vertices : np.ndarray
        (v, 2) vertex coordinates (m).
    rings : tuple[np.ndarray, ...]
        Per grain, its vertex ids counter-clockwise (no closing repeat).
    on_boundary : np.ndarray
        (v,) True where a vertex lies on the specimen boundary.
    """

    outline: Outline
    vertices: np.ndarray
    rings: tuple[np.ndarray, ...]
    on_boundary: np.ndarray

    @property
    def n_grains(self) -> int:
        return len(self.rings)

    def polygons(self) -> list[shapely.Polygon]:
        return [shapely.Polygon(self.vertices[r]) for r in self.rings]

    def grain_areas(self) -> np.ndarray:
        return np.array([_ring_area(self.vertices[r]) for r in self.rings])

    def segments(self) -> dict[tuple[int, int], list[int]]:
        """Map of each undirected segment (u < v) to the grains that own it."""
        return _segment_owners(self.rings)

    def internal_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """Internal edges (shared by two grains): (e, 2) vertex ids, (e, 2) grain ids."""
        pairs, grains = [], []
        for key, owners in self.segments().items():
            if len(owners) == 2:
                pairs.append(key)
                grains.append(owners)
        return np.array(pairs, dtype=np.int64).reshape(-1, 2), np.array(
            grains, dtype=np.int64
        ).reshape(-1, 2)

    def edge_lengths(self) -> tuple[np.ndarray, np.ndarray]:
        """Lengths of internal edges and a mask of those cut by the specimen boundary."""
        pairs, _ = self.internal_edges()
        d = self.vertices[pairs[:, 0]] - self.vertices[pairs[:, 1]]
        cut = self.on_boundary[pairs[:, 0]] | self.on_boundary[pairs[:, 1]]
        return np.hypot(d[:, 0], d[:, 1]), cut


def _ring_area(xy: np.ndarray) -> float:
    x, y = xy[:, 0], xy[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _segment_owners(rings) -> dict[tuple[int, int], list[int]]:
    owners: dict[tuple[int, int], list[int]] = {}
    for g, ring in enumerate(rings):
        nxt = np.roll(ring, -1)
        for u, v in zip(ring.tolist(), nxt.tolist(), strict=True):
            owners.setdefault((min(u, v), max(u, v)), []).append(g)
    return owners


def hexagon_cell_area(edge: float) -> float:
    """Area of a regular hexagon with the given edge length."""
    return 1.5 * math.sqrt(3.0) * edge * edge


def tessellate(
    outline: Outline,
    min_edge: float,
    max_edge: float,
    rng: np.random.Generator,
    *,
    boundary_min_segment: float | None = None,
    lloyd_iterations: int = 30,
    max_reseeds: int = 8,
) -> GrainMap:
    """Fill a specimen with Voronoi grains whose internal edges lie in ``[min_edge, max_edge]``.

    Parameters
    ----------
    outline
        Specimen outline (m).
    min_edge, max_edge
        Bounds on grain edge length (m).
    rng
        Random generator; the only source of randomness.
    boundary_min_segment
        Pieces of the specimen boundary shorter than this are merged away
        (default: ``min_edge / 3``).
    lloyd_iterations
        Lloyd relaxation steps on the initial seeds.
    max_reseeds
        Rounds of seed insertion where an edge is longer than ``max_edge``.
    """
    if not 0 < min_edge < max_edge:
        raise GeometryError(f"need 0 < min_edge < max_edge, got {min_edge:g}, {max_edge:g}")
    if boundary_min_segment is None:
        boundary_min_segment = min_edge / 3
    target_edge = _target_edge(min_edge, max_edge)
    n_seeds = max(2, round(outline.area / hexagon_cell_area(target_edge)))
    seeds = _random_points_in(outline.polygon, n_seeds, rng)
    seeds = _lloyd(seeds, outline.polygon, rng, lloyd_iterations)

    for _ in range(max_reseeds + 1):
        grain_map = _regularised_map(seeds, outline, min_edge, max_edge, boundary_min_segment)
        lengths, cut = grain_map.edge_lengths()
        long = (lengths > max_edge) & ~cut
        if not long.any():
            return grain_map
        pairs, _ = grain_map.internal_edges()
        mids = 0.5 * (grain_map.vertices[pairs[long, 0]] + grain_map.vertices[pairs[long, 1]])
        seeds = _lloyd(np.vstack((seeds, mids)), outline.polygon, rng, 3)
    return grain_map


def _target_edge(min_edge: float, max_edge: float) -> float:
    # Centroidal Voronoi cells are mostly hexagons; their edges spread about
    # +-35 % around the regular-hexagon edge, so aim slightly below the middle.
    return 0.5 * (min_edge + max_edge) * 0.95


def _random_points_in(polygon: shapely.Polygon, n: int, rng: np.random.Generator) -> np.ndarray:
    xmin, ymin, xmax, ymax = polygon.bounds
    out = np.empty((0, 2))
    while len(out) < n:
        cand = rng.uniform((xmin, ymin), (xmax, ymax), size=(2 * n, 2))
        inside = shapely.contains_xy(polygon, cand[:, 0], cand[:, 1])
        out = np.vstack((out, cand[inside]))
    return out[:n]


def _voronoi_cells(seeds: np.ndarray, polygon: shapely.Polygon) -> np.ndarray:
    xmin, ymin, xmax, ymax = polygon.bounds
    span = max(xmax - xmin, ymax - ymin)
    frame = shapely.box(xmin - span, ymin - span, xmax + span, ymax + span)
    cells = shapely.voronoi_polygons(shapely.multipoints(seeds), extend_to=frame, ordered=True)
    return shapely.intersection(shapely.get_parts(cells), polygon)


def _lloyd(
    seeds: np.ndarray, polygon: shapely.Polygon, rng: np.random.Generator, iterations: int
) -> np.ndarray:
    """Move seeds to the centroids of their clipped cells (Lloyd relaxation)."""
    for _ in range(iterations):
        cells = _voronoi_cells(seeds, polygon)
        empty = shapely.is_empty(cells) | (shapely.area(cells) <= 0)
        cent = shapely.get_coordinates(shapely.centroid(np.where(empty, None, cells)))
        new = seeds.copy()
        new[~empty] = cent
        if empty.any():
            new[empty] = _random_points_in(polygon, int(empty.sum()), rng)
        # A centroid of a cell wrapped around a borehole can fall into the hole.
        outside = ~shapely.contains_xy(polygon, new[:, 0], new[:, 1])
        for i in np.flatnonzero(outside):
            near = nearest_points(polygon, shapely.Point(new[i]))[0]
            new[i] = np.asarray(near.coords[0]) + 1e-6 * (np.asarray(near.coords[0]) - new[i])
        seeds = new
    return seeds


def _clipped_grains(seeds: np.ndarray, outline: Outline) -> list[shapely.Polygon]:
    """Voronoi cells clipped to the specimen: single-piece, hole-free, no tiny pieces."""
    pieces: list[shapely.Polygon] = []
    for cell in _voronoi_cells(seeds, outline.polygon):
        for part in shapely.get_parts(cell):
            if isinstance(part, shapely.Polygon) and part.area > 0:
                pieces.extend(_split_holes(part))
    mean_area = outline.area / max(len(seeds), 1)
    return _merge_small(pieces, 0.3 * mean_area)


def _split_holes(poly: shapely.Polygon) -> list[shapely.Polygon]:
    """A cell that wraps all the way round a borehole is cut in two through the hole."""
    if not poly.interiors:
        return [shapely.Polygon(poly.exterior)]
    cx, cy = poly.interiors[0].centroid.coords[0]
    xmin, ymin, xmax, ymax = poly.bounds
    cutter = shapely.LineString([(cx, ymin - 1.0), (cx, ymax + 1.0)])
    out = []
    for part in split(poly, cutter).geoms:
        out.extend(_split_holes(part))
    return out


def _merge_small(pieces: list[shapely.Polygon], min_area: float) -> list[shapely.Polygon]:
    """Merge pieces below ``min_area`` into the neighbour sharing the longest boundary
    whose union is a simple polygon (next to a small borehole, the union with the
    longest-shared neighbour can close a ring round the hole)."""
    pieces = list(pieces)
    while True:
        areas = np.array([p.area for p in pieces])
        small = np.flatnonzero(areas < min_area)
        if len(small) == 0:
            return pieces
        i = int(small[np.argmin(areas[small])])
        tree = shapely.STRtree(pieces)
        shared = {int(j): pieces[i].boundary.intersection(pieces[j].boundary).length
                  for j in tree.query(pieces[i]) if j != i}
        neighbours = sorted((j for j, length in shared.items() if length > 0),
                            key=lambda j: (-shared[j], j))
        if not neighbours:
            raise GeometryError("a grain piece touches no neighbour; specimen too small for grains")
        for j in neighbours:
            merged = shapely.union(pieces[j], pieces[i])
            if isinstance(merged, shapely.Polygon) and not merged.interiors:
                break
        else:
            raise GeometryError("a small grain piece cannot be merged into any neighbour "
                                "without wrapping round the borehole; specimen too small "
                                "for grains")
        pieces[j] = merged
        del pieces[i]


def _build_graph(polys: list[shapely.Polygon]) -> tuple[np.ndarray, list[np.ndarray]]:
    """Planar graph of polygons: merged vertices, CCW rings, T-junctions resolved."""
    coords, owner = [], []
    for g, p in enumerate(polys):
        ring = np.asarray(shapely.orient_polygons(p).exterior.coords)[:-1]
        coords.append(ring)
        owner.append(np.full(len(ring), g))
    xy = np.vstack(coords)
    parent = np.arange(len(xy))
    for i, j in sorted(cKDTree(xy).query_pairs(_MERGE_TOL)):
        ri, rj = _find(parent, i), _find(parent, j)
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    roots = np.array([_find(parent, i) for i in range(len(xy))])
    uniq, ids = np.unique(roots, return_inverse=True)
    vertices = xy[uniq]
    rings, start = [], 0
    for ring_xy in coords:
        r = ids[start : start + len(ring_xy)]
        start += len(ring_xy)
        rings.append(_dedupe_ring(r))
    return vertices, _fix_t_junctions(vertices, rings)


def _find(parent: np.ndarray, i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


def _dedupe_ring(ring: np.ndarray) -> np.ndarray:
    keep = ring != np.roll(ring, 1)
    return ring[keep] if keep.any() else ring[:1]


def _fix_t_junctions(vertices: np.ndarray, rings: list[np.ndarray]) -> list[np.ndarray]:
    """Insert vertices that lie inside another grain's segment into that segment."""
    tree = cKDTree(vertices)
    out = []
    for ring in rings:
        new: list[int] = []
        nxt = np.roll(ring, -1)
        for u, v in zip(ring.tolist(), nxt.tolist(), strict=True):
            new.append(u)
            a, b = vertices[u], vertices[v]
            ab = b - a
            length = float(np.hypot(*ab))
            cand = tree.query_ball_point(0.5 * (a + b), 0.5 * length + _MERGE_TOL)
            inner = []
            for w in cand:
                if w in (u, v):
                    continue
                t = float(np.dot(vertices[w] - a, ab)) / (length * length)
                off = abs(ab[0] * (vertices[w][1] - a[1]) - ab[1] * (vertices[w][0] - a[0]))
                if 0 < t < 1 and off / length < 10 * _MERGE_TOL:
                    inner.append((t, w))
            new.extend(w for _, w in sorted(inner))
        out.append(np.array(new, dtype=np.int64))
    return out


def _regularised_map(
    seeds: np.ndarray,
    outline: Outline,
    min_edge: float,
    max_edge: float,
    boundary_min_segment: float,
) -> GrainMap:
    polys = _clipped_grains(seeds, outline)
    vertices, rings = _build_graph(polys)
    on_boundary = shapely.distance(outline.polygon.boundary, shapely.points(vertices)) < 1e-7
    corner = np.zeros(len(vertices), dtype=bool)
    if len(outline.corners):
        d = cKDTree(outline.corners).query(vertices)[0]
        corner = d < 1e-7
    graph = _Graph(vertices.copy(), rings, on_boundary, corner, outline)
    graph.collapse_short_internal(min_edge)
    graph.collapse_short_boundary(boundary_min_segment)
    graph.relax_edges(min_edge, max_edge)
    return graph.finish()


class _Graph:
    """Mutable planar graph used only while regularising edges."""

    def __init__(self, xy, rings, on_boundary, corner, outline: Outline):
        self.xy = xy
        self.rings = [r.copy() for r in rings]
        self.on_boundary = on_boundary
        self.corner = corner
        self.outline = outline

    def _grains_of(self) -> dict[int, list[int]]:
        out: dict[int, list[int]] = {}
        for g, ring in enumerate(self.rings):
            for v in ring.tolist():
                out.setdefault(v, []).append(g)
        return out

    def _try_merge(self, keep: int, drop: int, pos: np.ndarray, grains: list[int]) -> bool:
        """Merge vertex ``drop`` into ``keep`` placed at ``pos`` if all rings stay valid."""
        xy = self.xy.copy()
        xy[keep] = pos
        new_rings = {}
        for g in grains:
            ring = self.rings[g].copy()
            ring[ring == drop] = keep
            ring = _dedupe_ring(ring)
            if len(ring) < 3:
                return False
            poly = shapely.Polygon(xy[ring])
            if not poly.is_valid or _ring_area(xy[ring]) <= 0:
                return False
            new_rings[g] = ring
        self.xy = xy
        for g, ring in new_rings.items():
            self.rings[g] = ring
        return True

    def collapse_short_internal(self, min_edge: float) -> None:
        blocked: set[tuple[int, int]] = set()
        while True:
            owners = _segment_owners(self.rings)
            cands = [
                k for k, g in owners.items()
                if len(g) == 2 and k not in blocked
                and not (self.on_boundary[k[0]] and self.on_boundary[k[1]])
            ]
            if not cands:
                return
            pairs = np.array(cands)
            lengths = np.hypot(*(self.xy[pairs[:, 0]] - self.xy[pairs[:, 1]]).T)
            order = np.argsort(lengths)
            if lengths[order[0]] >= min_edge:
                return
            u, v = (int(x) for x in pairs[order[0]])
            if self.on_boundary[u]:
                keep, drop, pos = u, v, self.xy[u]
            elif self.on_boundary[v]:
                keep, drop, pos = v, u, self.xy[v]
            else:
                keep, drop, pos = u, v, 0.5 * (self.xy[u] + self.xy[v])
            grains = sorted(set(self._grains_of().get(u, []) + self._grains_of().get(v, [])))
            if not self._try_merge(keep, drop, pos, grains):
                blocked.add((u, v))

    def collapse_short_boundary(self, min_segment: float) -> None:
        blocked: set[tuple[int, int]] = set()
        while True:
            owners = _segment_owners(self.rings)
            cands = [k for k, g in owners.items() if len(g) == 1 and k not in blocked]
            if not cands:
                return
            pairs = np.array(cands)
            lengths = np.hypot(*(self.xy[pairs[:, 0]] - self.xy[pairs[:, 1]]).T)
            order = np.argsort(lengths)
            if lengths[order[0]] >= min_segment:
                return
            u, v = (int(x) for x in pairs[order[0]])
            grains_of = self._grains_of()
            soft = [w for w in (u, v) if len(grains_of[w]) == 1 and not self.corner[w]]
            if soft:
                drop = soft[-1]
                keep = v if drop == u else u
                pos = self.xy[keep]
            elif self.corner[u] and self.corner[v]:
                blocked.add((u, v))
                continue
            elif self.corner[u] or self.corner[v]:
                keep, drop = (u, v) if self.corner[u] else (v, u)
                pos = self.xy[keep]
            else:
                keep, drop = u, v
                mid = shapely.Point(0.5 * (self.xy[u] + self.xy[v]))
                pos = np.asarray(nearest_points(self.outline.polygon.boundary, mid)[0].coords[0])
            grains = sorted(set(grains_of[u] + grains_of[v]))
            if not self._try_merge(keep, drop, pos, grains):
                blocked.add((u, v))

    def relax_edges(self, min_edge: float, max_edge: float, iterations: int = 400) -> None:
        """Nudge interior vertices until internal edges lie inside the bounds.

        Only out-of-range edges act, like springs that engage at the bounds
        (with a 2 % margin); vertices on the specimen boundary stay put. A
        step that would make any grain invalid is halved until it does not.
        The topology is fixed here, so edges and ring indices are built once.
        """
        lo, hi = 1.02 * min_edge, 0.98 * max_edge
        pairs = np.array([k for k, g in _segment_owners(self.rings).items() if len(g) == 2])
        if len(pairs) == 0:
            return
        cut = self.on_boundary[pairs[:, 0]] | self.on_boundary[pairs[:, 1]]
        flat = np.concatenate(self.rings)
        ring_of = np.repeat(np.arange(len(self.rings)), [len(r) for r in self.rings])
        step = 0.5
        for _ in range(iterations):
            d = self.xy[pairs[:, 1]] - self.xy[pairs[:, 0]]
            length = np.hypot(d[:, 0], d[:, 1])
            excess = np.where(length > hi, length - hi, 0.0)
            excess += np.where((length < lo) & ~cut, length - lo, 0.0)
            if not np.any(excess):
                return
            pull = (excess / length)[:, None] * d * 0.5
            move = np.zeros_like(self.xy)
            np.add.at(move, pairs[:, 0], pull)
            np.add.at(move, pairs[:, 1], -pull)
            move[self.on_boundary] = 0.0
            while True:
                trial = self.xy + step * move
                rings = shapely.linearrings(trial[flat], indices=ring_of)
                polys = shapely.polygons(rings)
                if shapely.is_valid(polys).all() and shapely.is_ccw(rings).all():
                    self.xy = trial
                    step = min(1.0, 1.5 * step)
                    break
                step *= 0.5
                if step < 1e-3:
                    return

    def finish(self) -> GrainMap:
        used = np.unique(np.concatenate(self.rings))
        remap = np.full(len(self.xy), -1)
        remap[used] = np.arange(len(used))
        rings = tuple(remap[r] for r in self.rings)
        return GrainMap(self.outline, self.xy[used], rings, self.on_boundary[used])
