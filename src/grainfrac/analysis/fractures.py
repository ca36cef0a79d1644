"""Fracture geometry and crack statistics from a crack set.

docs/outputs.md and paper sections 5.1-5.5: number of radial fractures and
their extent, tortuosity of the main fracture, tensile / shear counts and their
ratio, contact-type fractions (T among all contacts, C among failed ones) and
the strain energy released, split by failure mode.

Every function takes plain arrays in SI units (m, J), so it works on an
in-memory :class:`~grainfrac.physics.cracks.CrackCatalogue` as well as on a
run's ``cracks.csv`` (convert ``x_mm``, ``y_mm`` to m; ``mode`` and
``contact_type`` may stay strings).

Connectivity: two cracks belong to the same fracture when they lie within
``connect_distance`` of each other. Cracks are failed sub-contacts spaced about
one zone size apart along grain boundaries, so ``1.5 * zone_size``
(:data:`CONNECT_FACTOR`) links neighbouring sub-contacts along a boundary and
across triple junctions without bridging separate fractures.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import ConvexHull, QhullError, cKDTree

from grainfrac.physics.kernels import SHEAR, TENSILE

__all__ = [
    "CONNECT_FACTOR",
    "FracturePath",
    "RadialFractures",
    "connected_clusters",
    "contact_fractions",
    "crack_counts",
    "energy_split",
    "fracture_summary",
    "fracture_tortuosity",
    "main_fracture_path",
    "radial_fractures",
    "tortuosity",
]

#: Suggested ``connect_distance`` in units of the zone size (sub-contact spacing).
CONNECT_FACTOR = 1.5

_MODE_CODES = {"tensile": TENSILE, "t": TENSILE, "shear": SHEAR, "s": SHEAR}


# --------------------------------------------------------------------------- helpers


def _xy(x, y) -> np.ndarray:
    x = np.asarray(x, dtype=float).ravel()
    y = np.asarray(y, dtype=float).ravel()
    if x.shape != y.shape:
        raise ValueError(f"x and y differ in length ({x.size} != {y.size})")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("crack positions must be finite")
    return np.column_stack((x, y))


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not value > 0:
        raise ValueError(f"{name} must be > 0 (got {value})")
    return value


def _edges(xy: np.ndarray, connect_distance: float) -> np.ndarray:
    """(k, 2) index pairs of cracks within ``connect_distance`` of each other."""
    if len(xy) < 2:
        return np.empty((0, 2), dtype=np.int64)
    pairs = cKDTree(xy).query_pairs(connect_distance, output_type="ndarray")
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def _neighbourhood_edges(xy: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Keep the proximity edges of the relative neighbourhood graph.

    An edge ``(a, b)`` is dropped when some crack ``c`` is closer than
    ``|ab|`` to both ``a`` and ``b`` (``c`` lies in the lune between them), so
    a path follows consecutive cracks round a kink instead of cutting the
    corner. Such a ``c`` is itself joined to ``a`` and ``b`` by shorter
    proximity edges, so connectivity is unchanged, and loops around a grain
    survive (unlike in a spanning tree).
    """
    k = len(edges)
    if k == 0:
        return edges
    n = len(xy)
    length = np.hypot(*(xy[edges[:, 0]] - xy[edges[:, 1]]).T)
    both = np.vstack((edges, edges[:, ::-1]))
    both = both[np.argsort(both[:, 0], kind="stable")]
    indptr = np.searchsorted(both[:, 0], np.arange(n + 1))
    neighbour = both[:, 1]
    a, b = edges[:, 0], edges[:, 1]
    degree = indptr[a + 1] - indptr[a]
    edge_of = np.repeat(np.arange(k), degree)
    offset = np.arange(edge_of.size) - np.repeat(np.cumsum(degree) - degree, degree)
    c = neighbour[indptr[a][edge_of] + offset]
    d_ac = np.hypot(*(xy[a[edge_of]] - xy[c]).T)
    d_bc = np.hypot(*(xy[b[edge_of]] - xy[c]).T)
    inside = (c != b[edge_of]) & (np.maximum(d_ac, d_bc) < length[edge_of] * (1 - 1e-9))
    blocked = np.bincount(edge_of[inside], minlength=k) > 0
    return edges[~blocked]


def _components(n: int, edges: np.ndarray) -> np.ndarray:
    if n == 0:
        return np.empty(0, dtype=np.int64)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return labels.astype(np.int64)


def _mode_codes(mode) -> np.ndarray:
    """Integer mode codes (kernels.TENSILE / SHEAR) from codes or names."""
    m = np.asarray(mode).ravel()
    if m.dtype.kind in "USO":
        try:
            return np.array([_MODE_CODES[str(v).strip().lower()] for v in m], dtype=np.int64)
        except KeyError as exc:
            raise ValueError(f"unknown crack mode {exc.args[0]!r}; expected "
                             "'tensile' or 'shear'") from None
    codes = m.astype(np.int64)
    bad = ~np.isin(codes, (TENSILE, SHEAR))
    if np.any(bad):
        raise ValueError(f"unknown crack mode code {codes[bad][0]}; expected "
                         f"{TENSILE} (tensile) or {SHEAR} (shear)")
    return codes


def _circular_groups(angles: np.ndarray, gap: float) -> list[np.ndarray]:
    """Group angles (rad) on the circle, splitting where consecutive ones differ by > gap.

    Returns the member indices (into ``angles``) of each group.
    """
    if angles.size == 0:
        return []
    order = np.argsort(angles)
    a = angles[order]
    gaps = np.diff(np.concatenate((a, [a[0] + 2 * math.pi])))  # last one wraps around
    cuts = np.flatnonzero(gaps > gap)
    if cuts.size == 0:
        return [order]  # one group closing on itself (e.g. a ring of cracks)
    # Start right after the first cut so that no group straddles the wrap.
    start = (cuts[0] + 1) % a.size
    rolled = np.roll(order, -start)
    bounds = np.sort((cuts - start) % a.size) + 1
    return [g for g in np.split(rolled, bounds) if g.size]


# --------------------------------------------------------------------------- connectivity


def connected_clusters(x, y, *, connect_distance: float) -> np.ndarray:
    """Label cracks by fracture: connected components of the proximity graph.

    Parameters
    ----------
    x, y : array_like
        Crack positions (m).
    connect_distance : float
        Cracks closer than this (m) are connected, e.g. ``CONNECT_FACTOR * zone_size``.

    Returns
    -------
    np.ndarray
        (n,) integer cluster label per crack (0 ... k-1).
    """
    xy = _xy(x, y)
    d = _check_positive("connect_distance", connect_distance)
    return _components(len(xy), _edges(xy, d))


# --------------------------------------------------------------------------- radial fractures


@dataclass(frozen=True)
class RadialFractures:
    """Fracture branches connected to the well that cross a circle around it.

    Attributes
    ----------
    count : int
        Number of branches crossing the circle.
    angles_deg : np.ndarray
        (count,) polar angle of each crossing, in [0, 360), ascending.
    extents : np.ndarray
        (count,) largest distance (m) from the well centre reached beyond the
        circle by each branch, in the order of ``angles_deg``.
    fracture_extent : float or None
        Largest distance (m) from the well centre reached by any crack cluster
        connected to the well; ``None`` when no crack is connected to it.
    radius : float
        Radius (m) of the counting circle.
    cluster : np.ndarray
        (n,) connected-component label of every crack.
    well_connected : np.ndarray
        (n,) True for cracks in a cluster connected to the well.
    branch : np.ndarray
        (n,) index into ``angles_deg`` of the crossing a crack belongs to
        (cracks connected to it outside the circle), -1 for the others.
    """

    count: int
    angles_deg: np.ndarray
    extents: np.ndarray
    fracture_extent: float | None
    radius: float
    cluster: np.ndarray
    well_connected: np.ndarray
    branch: np.ndarray


def radial_fractures(x, y, center: Sequence[float] = (0.0, 0.0), *, well_radius: float,
                     connect_distance: float, radius: float | None = None,
                     angle_bin_deg: float = 10.0) -> RadialFractures:
    """Count the radial fractures crossing a circle around the well and measure their extent.

    1. Cracks within ``connect_distance`` of each other form clusters; a
       cluster is connected to the well when one of its cracks lies within
       ``well_radius + connect_distance`` of the centre.
    2. A well-connected branch crosses the circle of ``radius`` when it has a
       crack at ``radius <= r < radius + connect_distance`` (consecutive cracks
       along a branch are at most ``connect_distance`` apart, so any branch
       reaching beyond the circle has one there). The polar angles of these
       cracks are grouped on the circle, splitting where consecutive angles
       differ by more than ``max(angle_bin_deg, 2 * connect_distance / radius)``;
       each group is one fracture, at the circular mean of its angles.
    3. The extent of a fracture is the largest distance from the centre
       reached by the well-connected cracks outside the circle that are
       connected (outside the circle) to its crossing; the overall fracture
       extent is the largest distance from the centre of any well-connected crack.

    Parameters
    ----------
    x, y : array_like
        Crack positions (m).
    center : sequence of float, optional
        Well centre (m).
    well_radius : float
        Borehole radius (m).
    connect_distance : float
        Connection distance between cracks (m), e.g. ``CONNECT_FACTOR * zone_size``.
    radius : float, optional
        Radius (m) of the counting circle; default ``2 * well_radius``.
    angle_bin_deg : float, optional
        Smallest angular gap (degrees) that separates two fractures.

    Returns
    -------
    RadialFractures
        Distances are measured from the well centre (subtract ``well_radius``
        for the length beyond the borehole wall).
    """
    xy = _xy(x, y)
    well_radius = _check_positive("well_radius", well_radius)
    d = _check_positive("connect_distance", connect_distance)
    radius = 2.0 * well_radius if radius is None else _check_positive("radius", radius)
    if not 0 < angle_bin_deg < 360:
        raise ValueError(f"angle_bin_deg must be in (0, 360) (got {angle_bin_deg})")
    n = len(xy)
    rel = xy - np.asarray(center, dtype=float).reshape(2)
    r = np.hypot(rel[:, 0], rel[:, 1])
    theta = np.mod(np.arctan2(rel[:, 1], rel[:, 0]), 2 * math.pi)

    edges = _edges(xy, d)
    cluster = _components(n, edges)
    touching = np.unique(cluster[r <= well_radius + d])
    connected = np.isin(cluster, touching)
    extent = float(r[connected].max()) if np.any(connected) else None

    crossing = np.flatnonzero(connected & (r >= radius) & (r < radius + d))
    gap = max(math.radians(angle_bin_deg), 2.0 * d / radius)
    groups = _circular_groups(theta[crossing], gap)
    angles = np.array([math.degrees(math.atan2(np.sin(theta[crossing[g]]).mean(),
                                               np.cos(theta[crossing[g]]).mean()))
                       % 360.0 for g in groups])
    # A circular mean can round to exactly 360.0 in floating point.
    angles = np.where(angles >= 360.0, 0.0, angles)
    order = np.argsort(angles)

    # Branches beyond the circle: components of the well-connected cracks at r >= radius.
    outer = connected & (r >= radius)
    keep = outer[edges[:, 0]] & outer[edges[:, 1]] if len(edges) else np.zeros(0, bool)
    outer_label = _components(n, edges[keep])
    branch = np.full(n, -1, dtype=np.int64)
    extents = np.empty(len(groups))
    for k, gi in enumerate(order):
        labels = np.unique(outer_label[crossing[groups[gi]]])
        members = outer & np.isin(outer_label, labels)
        branch[members & (branch < 0)] = k
        extents[k] = r[members].max()
    return RadialFractures(
        count=len(groups),
        angles_deg=angles[order] if len(groups) else np.empty(0),
        extents=extents,
        fracture_extent=extent,
        radius=radius,
        cluster=cluster,
        well_connected=connected,
        branch=branch,
    )


# --------------------------------------------------------------------------- tortuosity


def tortuosity(points_xy) -> float:
    """Tortuosity of a fracture path: geodesic length / straight distance between its ends.

    Parameters
    ----------
    points_xy : array_like
        (k, 2) vertices of the fracture path in order along it (m), k >= 2.

    Returns
    -------
    float
        Sum of segment lengths divided by the distance from the first to the
        last vertex (1 for a straight path).

    Raises
    ------
    ValueError
        Fewer than two vertices, or the two ends coincide.
    """
    pts = np.asarray(points_xy, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
        raise ValueError("points_xy must be a (k, 2) array with k >= 2")
    chord = float(np.hypot(*(pts[-1] - pts[0])))
    if chord == 0.0:
        raise ValueError("the ends of the fracture path coincide")
    length = float(np.hypot(*np.diff(pts, axis=0).T).sum())
    return length / chord


@dataclass(frozen=True)
class FracturePath:
    """The main fracture followed through the crack connectivity graph.

    Attributes
    ----------
    indices : np.ndarray
        Crack indices along the path, from one end to the other; -1 marks the
        well centre where the path passes through the well.
    points : np.ndarray
        (k, 2) positions along the path (m).
    geodesic_length : float
        Length of the path (m).
    euclidean_length : float
        Straight distance between its ends (m).
    """

    indices: np.ndarray
    points: np.ndarray
    geodesic_length: float
    euclidean_length: float

    @property
    def tortuosity(self) -> float:
        """Geodesic length / Euclidean length."""
        return self.geodesic_length / self.euclidean_length


def _farthest_pair(pts: np.ndarray) -> tuple[int, int]:
    """Indices of the two points farthest apart (exact)."""
    if len(pts) <= 3:
        cand = np.arange(len(pts))
    else:
        try:
            cand = ConvexHull(pts).vertices
        except QhullError:  # collinear or coincident: the extremes along the line
            axis = pts - pts.mean(axis=0)
            _, _, vt = np.linalg.svd(axis, full_matrices=False)
            s = axis @ vt[0]
            cand = np.array([int(np.argmin(s)), int(np.argmax(s))])
    c = pts[cand]
    dist = np.hypot(c[:, None, 0] - c[None, :, 0], c[:, None, 1] - c[None, :, 1])
    i, j = np.unravel_index(int(np.argmax(dist)), dist.shape)
    return int(cand[i]), int(cand[j])


def main_fracture_path(x, y, *, connect_distance: float, center: Sequence[float] | None = None,
                       well_radius: float | None = None) -> FracturePath | None:
    """Follow the main fracture between its two farthest-apart cracks.

    The main fracture is the crack cluster (cracks within ``connect_distance``
    of each other) connected to the well when ``center`` and ``well_radius``
    are given and a cluster reaches it, otherwise the cluster with most cracks.
    With a well, the well centre is a node of the graph, joined to every crack
    within ``well_radius + connect_distance`` of it, so that the two wings of
    a diametrical fracture form one path through the well. The path is the
    shortest one (edges weighted by distance) between the two cracks of the
    main fracture that are farthest apart, through the relative neighbourhood
    graph of the cracks: a link between two cracks is dropped when a third
    crack is closer to both, so the path steps from crack to neighbouring
    crack round kinks instead of cutting corners.

    Parameters
    ----------
    x, y : array_like
        Crack positions (m).
    connect_distance : float
        Connection distance between cracks (m).
    center : sequence of float, optional
        Well centre (m).
    well_radius : float, optional
        Borehole radius (m); needed with ``center``.

    Returns
    -------
    FracturePath or None
        ``None`` when the main fracture has fewer than two distinct crack positions.
    """
    xy = _xy(x, y)
    d = _check_positive("connect_distance", connect_distance)
    n = len(xy)
    if n < 2:
        return None
    edges = _neighbourhood_edges(xy, _edges(xy, d))
    with_well = center is not None
    if with_well:
        if well_radius is None:
            raise ValueError("well_radius is needed together with center")
        well_radius = _check_positive("well_radius", well_radius)
        c = np.asarray(center, dtype=float).reshape(2)
        r = np.hypot(*(xy - c).T)
        at_well = np.flatnonzero(r <= well_radius + d)
        if at_well.size == 0:
            with_well = False
    if with_well:
        well = n  # the extra node
        edges = np.vstack((edges, np.column_stack((at_well, np.full(at_well.size, well)))))
        nodes_xy = np.vstack((xy, c))
        labels = _components(n + 1, edges)
        members = np.flatnonzero(labels == labels[well])
        cracks = members[members != well]
    else:
        nodes_xy = xy
        labels = _components(n, edges)
        counts = np.bincount(labels)
        cracks = members = np.flatnonzero(labels == int(np.argmax(counts)))

    a, b = _farthest_pair(xy[cracks])
    a, b = int(cracks[a]), int(cracks[b])
    chord = float(np.hypot(*(xy[b] - xy[a])))
    if chord == 0.0:
        return None
    # Shortest path on the subgraph of the main fracture.
    local = np.full(len(nodes_xy), -1, dtype=np.int64)
    local[members] = np.arange(members.size)
    inside = (local[edges[:, 0]] >= 0) & (local[edges[:, 1]] >= 0)
    e = local[edges[inside]]
    w = np.hypot(*(nodes_xy[members[e[:, 0]]] - nodes_xy[members[e[:, 1]]]).T)
    # Coincident cracks (one point on several grain boundaries) are edges of length
    # zero; keep them as edges with a negligible positive weight.
    w = np.maximum(w, 1e-12 * d)
    m = members.size
    graph = coo_matrix((np.concatenate((w, w)),
                        (np.concatenate((e[:, 0], e[:, 1])), np.concatenate((e[:, 1], e[:, 0])))),
                       shape=(m, m)).tocsr()
    _, pred = dijkstra(graph, directed=True, indices=int(local[a]), return_predecessors=True)
    path = [int(local[b])]
    while path[-1] != local[a]:
        path.append(int(pred[path[-1]]))
    path_nodes = members[np.array(path[::-1])]
    points = nodes_xy[path_nodes]
    geodesic = float(np.hypot(*np.diff(points, axis=0).T).sum())
    indices = np.where(path_nodes == n, -1, path_nodes) if with_well else path_nodes
    return FracturePath(indices=indices, points=points, geodesic_length=geodesic,
                        euclidean_length=chord)


def fracture_tortuosity(x, y, *, connect_distance: float, center: Sequence[float] | None = None,
                        well_radius: float | None = None) -> float | None:
    """Tortuosity of the main fracture of a crack set (paper Sect. 5.3).

    Geodesic length along the main fracture / straight distance between its
    ends; see :func:`main_fracture_path` for how the fracture is found and
    followed. On a fracture trace sampled by its cracks (sub-contacts along
    grain boundaries) the path runs through consecutive cracks, so the value
    is that of the polyline through them.

    Parameters
    ----------
    x, y : array_like
        Crack positions (m).
    connect_distance : float
        Connection distance between cracks (m).
    center : sequence of float, optional
        Well centre (m); with it the path may pass through the well.
    well_radius : float, optional
        Borehole radius (m); needed with ``center``.

    Returns
    -------
    float or None
        ``None`` when there is no fracture with two distinct ends.
    """
    path = main_fracture_path(x, y, connect_distance=connect_distance, center=center,
                              well_radius=well_radius)
    return None if path is None else path.tortuosity


# --------------------------------------------------------------------------- statistics


def crack_counts(mode) -> dict[str, int | float | None]:
    """Number of cracks, split by failure mode, and the tensile / shear (T/S) ratio.

    Parameters
    ----------
    mode : array_like
        Failure mode per crack: ``kernels.TENSILE`` / ``kernels.SHEAR`` codes,
        or the names ``"tensile"`` / ``"shear"`` of ``cracks.csv``.

    Returns
    -------
    dict
        ``n_cracks``, ``n_tensile_cracks``, ``n_shear_cracks`` and
        ``tensile_shear_ratio`` (``None`` without shear cracks).
    """
    codes = _mode_codes(mode)
    n_t = int(np.count_nonzero(codes == TENSILE))
    n_s = int(np.count_nonzero(codes == SHEAR))
    return {
        "n_cracks": int(codes.size),
        "n_tensile_cracks": n_t,
        "n_shear_cracks": n_s,
        "tensile_shear_ratio": (n_t / n_s) if n_s else None,
    }


def energy_split(mode, energy) -> dict[str, float]:
    """Strain energy released at failure, summed by failure mode.

    Parameters
    ----------
    mode : array_like
        Failure mode per crack (codes or names, as for :func:`crack_counts`).
    energy : array_like
        Energy released by each crack (J).

    Returns
    -------
    dict
        ``energy_tensile_J`` and ``energy_shear_J``.
    """
    codes = _mode_codes(mode)
    e = np.asarray(energy, dtype=float).ravel()
    if e.shape != codes.shape:
        raise ValueError(f"mode and energy differ in length ({codes.size} != {e.size})")
    return {
        "energy_tensile_J": float(e[codes == TENSILE].sum()),
        "energy_shear_J": float(e[codes == SHEAR].sum()),
    }


def _pair_ids(pair, pair_names: tuple[str, ...], what: str) -> np.ndarray:
    p = np.asarray(pair).ravel()
    if p.dtype.kind in "USO":
        index = {name: i for i, name in enumerate(pair_names)}
        try:
            return np.array([index[str(v)] for v in p], dtype=np.int64)
        except KeyError as exc:
            raise ValueError(f"unknown mineral pair {exc.args[0]!r} in {what}; "
                             f"expected one of {list(pair_names)}") from None
    ids = p.astype(np.int64)
    if ids.size and (ids.min() < 0 or ids.max() >= len(pair_names)):
        raise ValueError(f"mineral-pair id out of range in {what} "
                         f"(0 ... {len(pair_names) - 1} allowed)")
    return ids


def contact_fractions(pair_of_all_contacts, pair_of_failed,
                      pair_names: Sequence[str] | None = None
                      ) -> tuple[dict[str, float], dict[str, float]]:
    """Contact-type fractions per mineral pair: among all contacts (T) and failed ones (C).

    Paper Fig. 14e. Use the same kind of contact for both sets, e.g.
    ``assembly.contact_view("pair")`` (every sub-contact) and
    ``catalogue.pair`` (the failed sub-contacts).

    Parameters
    ----------
    pair_of_all_contacts : array_like
        Mineral-pair id (or name) of every contact, failed and intact.
    pair_of_failed : array_like
        Mineral-pair id (or name) of every failed contact.
    pair_names : sequence of str, optional
        Names of the pairs, indexed by id (``assembly.pair_names``). Without
        it the inputs must be names, and the pairs found in them, sorted, are used.

    Returns
    -------
    (dict, dict)
        ``{pair: fraction}`` among all contacts and among failed ones, every
        pair present; each sums to 1, or is all zeros for an empty set.
    """
    if pair_names is None:
        arrays = [np.asarray(a).ravel() for a in (pair_of_all_contacts, pair_of_failed)]
        if any(a.size and a.dtype.kind not in "USO" for a in arrays):
            raise ValueError("pair_names is needed when pairs are given as ids")
        pair_names = tuple(sorted({str(v) for a in arrays for v in a}))
    names = tuple(str(n) for n in pair_names)

    def fractions(pair, what: str) -> dict[str, float]:
        counts = np.bincount(_pair_ids(pair, names, what), minlength=len(names)).astype(float)
        total = counts.sum()
        return {n: (float(c / total) if total else 0.0)
                for n, c in zip(names, counts, strict=True)}

    total = fractions(pair_of_all_contacts, "pair_of_all_contacts")
    failed = fractions(pair_of_failed, "pair_of_failed")
    return total, failed


# --------------------------------------------------------------------------- summary


def fracture_summary(x, y, mode, energy=None, *, center: Sequence[float] = (0.0, 0.0),
                     well_radius: float, connect_distance: float,
                     radius: float | None = None) -> dict[str, int | float | None]:
    """The summary.json crack and fracture keys (docs/outputs.md) of a crack set.

    Parameters
    ----------
    x, y : array_like
        Crack positions (m).
    mode : array_like
        Failure mode per crack (codes or names).
    energy : array_like, optional
        Energy released per crack (J); the energy keys are left out without it.
    center, well_radius, connect_distance, radius
        As for :func:`radial_fractures`; the tortuosity is that of the main
        fracture through the well (:func:`fracture_tortuosity`).

    Returns
    -------
    dict
        ``n_cracks``, ``n_tensile_cracks``, ``n_shear_cracks``,
        ``tensile_shear_ratio``, ``n_radial_fractures``, ``fracture_extent_mm``,
        ``tortuosity`` and, with ``energy``, ``energy_tensile_J`` and ``energy_shear_J``.
    """
    out: dict[str, int | float | None] = dict(crack_counts(mode))
    radial = radial_fractures(x, y, center, well_radius=well_radius,
                              connect_distance=connect_distance, radius=radius)
    out["n_radial_fractures"] = radial.count
    out["fracture_extent_mm"] = (None if radial.fracture_extent is None
                                 else radial.fracture_extent * 1e3)
    out["tortuosity"] = fracture_tortuosity(x, y, connect_distance=connect_distance,
                                            center=center, well_radius=well_radius)
    if energy is not None:
        out.update(energy_split(mode, energy))
    return out
