"""Tests of the grain geometry: tessellation, meshing, sub-contacts, flow network, node sets.

Every test measures a property of a real built specimen and prints the observed
value next to its tolerance (run ``pytest -s`` to see them). Reference values are
computed independently of the mesher where possible (shapely on the grain
polygons, the specimen dimensions from the config).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly, build_specimen
from grainfrac.geometry.meshing import GrainMesh
from grainfrac.io.config import validate

MM = 1e-3
SHAPES = ("slab", "disk", "semi_disk", "rectangle")
EXPECTED_SIDES = {
    "slab": {"left", "right", "top", "bottom", "borehole"},
    "disk": {"perimeter"},
    "semi_disk": {"arc", "base", "notch"},
    "rectangle": {"left", "right", "top", "bottom"},
}
MIN_ANGLE_DEG = 15.0



@pytest.fixture(scope="module")
def slab() -> GrainAssembly:
    """The default specimen: 100 x 100 mm slab, 10 mm borehole, grains 3-8 mm, zones 2 mm."""
    return build_specimen({})


@pytest.fixture(scope="module")
def shapes(slab) -> dict[str, GrainAssembly]:
    """One assembly of every specimen shape with its default dimensions (seed 0)."""
    out = {"slab": slab}
    for shape in SHAPES[1:]:
        out[shape] = build_specimen({"specimen": {"shape": shape}})
    return out


def _shared_length(polys: list[shapely.Polygon], a: int, b: int) -> float:
    """Length of the boundary shared by grains ``a`` and ``b`` (shapely, independent of mesh)."""
    return float(shapely.intersection(polys[a].boundary, polys[b].boundary).length)


def _side_lengths_mm(mesh: GrainMesh) -> dict[str, float]:
    return {k: float(v.length) / MM for k, v in mesh.grains.outline.sides.items()}


# ----------------------------------------------------------------- grain edges


@pytest.mark.parametrize(
    ("grains", "lo_mm", "hi_mm"),
    [(None, 3.0, 8.0), ({"min_edge_mm": 3, "max_edge_mm": 6}, 3.0, 6.0),
     ({"min_edge_mm": 3, "max_edge_mm": 9}, 3.0, 9.0)],
    ids=["default-3-8", "3-6", "3-9"],
)
def test_internal_edge_lengths_within_bounds(slab, grains, lo_mm, hi_mm):
    assembly = slab if grains is None else build_specimen({"grains": grains})
    lengths, cut = assembly.mesh.grains.edge_lengths()
    inner = lengths[~cut] / MM
    print(f"\n[edges {lo_mm:g}-{hi_mm:g} mm] grains={assembly.n_grains} internal edges="
          f"{len(lengths)} (cut by boundary: {int(cut.sum())}); uncut edges min={inner.min():.3f}"
          f" max={inner.max():.3f} mean={inner.mean():.3f} mm; bounds [{lo_mm:g}, {hi_mm:g}] mm")
    assert len(inner) > 0.5 * len(lengths)
    assert inner.min() >= lo_mm * (1 - 1e-9)
    assert inner.max() <= hi_mm * (1 + 1e-9)


# ----------------------------------------------------------------- elements


@pytest.mark.parametrize("shape", SHAPES)
def test_elements_positive_and_tile_grains(shapes, shape):
    mesh = shapes[shape].mesh
    areas = mesh.element_areas()
    grain_areas = mesh.grains.grain_areas()
    per_grain = np.bincount(mesh.element_grain, weights=areas, minlength=mesh.grains.n_grains)
    total_rel = abs(areas.sum() - grain_areas.sum()) / grain_areas.sum()
    per_grain_rel = np.max(np.abs(per_grain - grain_areas) / grain_areas)
    outline_rel = abs(grain_areas.sum() - mesh.grains.outline.area) / mesh.grains.outline.area
    min_angle = mesh.element_min_angles()
    print(f"\n[{shape}] elements={mesh.n_elements} nodes={mesh.n_nodes} grains="
          f"{mesh.grains.n_grains}; min element area={areas.min() / MM**2:.4f} mm2 (> 0); "
          f"sum rel. error={total_rel:.2e}, worst grain={per_grain_rel:.2e} (tol 1e-9); "
          f"grains vs outline area rel.={outline_rel:.2e} (tol 1e-3); "
          f"min angle={min_angle.min():.2f} deg, 1st percentile={np.percentile(min_angle, 1):.2f}")
    assert np.all(areas > 0)
    assert np.all(grain_areas > 0)
    assert total_rel < 1e-9
    assert per_grain_rel < 1e-9
    # Arcs lose a little area where short boundary pieces are merged away.
    assert outline_rel < 1e-3
    # Every element's nodes belong to the element's grain (nodes are per grain).
    assert np.all(mesh.node_grain[mesh.element_nodes] == mesh.element_grain[:, None])


@pytest.mark.parametrize(
    "shape",
    [
        "slab",
        "disk",
        "semi_disk",
        "rectangle",
    ],
)
def test_element_min_angle(shapes, shape):
    mesh = shapes[shape].mesh
    angles = mesh.element_min_angles()
    worst = int(np.argmin(angles))
    corners = mesh.node_xy[mesh.element_nodes[worst]] / MM
    print(f"\n[{shape}] min angle={angles[worst]:.2f} deg (must be > {MIN_ANGLE_DEG:g}); "
          f"elements below: {int((angles <= MIN_ANGLE_DEG).sum())} of {len(angles)}; "
          f"worst element corners (mm)={np.round(corners, 3).tolist()}")
    assert angles.min() > MIN_ANGLE_DEG


# ----------------------------------------------------------------- grain boundaries


def test_interfaces_match_shapely(slab):
    mesh = slab.mesh
    polys = mesh.grains.polygons()
    # Independent neighbour search: every pair of grains whose boundaries share a length.
    tree = shapely.STRtree(polys)
    expected: dict[tuple[int, int], float] = {}
    for a, poly in enumerate(polys):
        for b in tree.query(poly).tolist():
            if b > a:
                length = _shared_length(polys, a, b)
                if length > 1e-9:
                    expected[(a, b)] = length
    found = {tuple(p) for p in mesh.interface_grains.tolist()}
    print(f"\n[interfaces] mesh={mesh.n_interfaces} shapely neighbour pairs={len(expected)}")
    assert found == set(expected)
    assert np.all(mesh.interface_grains[:, 0] < mesh.interface_grains[:, 1])

    reference = np.array([expected[tuple(p)] for p in mesh.interface_grains.tolist()])
    from_contacts = np.bincount(mesh.contact_interface, weights=mesh.contact_area,
                                minlength=mesh.n_interfaces) / mesh.thickness
    rel = np.abs(from_contacts - reference) / reference
    rel_stored = np.abs(mesh.interface_length - reference) / reference
    print(f"[interfaces] sum(sub-contact area)/thickness vs shapely length: max rel. error="
          f"{rel.max():.2e} (tol 1e-9); interface_length max rel. error={rel_stored.max():.2e}; "
          f"lengths {reference.min() / MM:.3f}-{reference.max() / MM:.3f} mm")
    assert rel.max() < 1e-9
    assert rel_stored.max() < 1e-9


def test_sub_contacts_coincident_ordered_oriented(slab):
    mesh = slab.mesh
    a, b = mesh.contact_nodes[:, 0], mesh.contact_nodes[:, 1]
    gap = np.hypot(*(mesh.node_xy[a] - mesh.node_xy[b]).T)
    at_xy = np.hypot(*(mesh.node_xy[a] - mesh.contact_xy).T)
    own0 = mesh.node_grain[a] == mesh.interface_grains[mesh.contact_interface, 0]
    own1 = mesh.node_grain[b] == mesh.interface_grains[mesh.contact_interface, 1]
    unit = np.abs(np.hypot(*mesh.contact_normal.T) - 1.0)
    rot = np.column_stack((-mesh.contact_normal[:, 1], mesh.contact_normal[:, 0]))
    tangent_err = np.abs(mesh.contact_tangent - rot).max()

    polys = mesh.grains.polygons()
    centroids = np.array([p.centroid.coords[0] for p in polys])
    g0 = mesh.interface_grains[mesh.contact_interface, 0]
    g1 = mesh.interface_grains[mesh.contact_interface, 1]
    towards = np.sum(mesh.contact_normal * (centroids[g1] - centroids[g0]), axis=1) > 0

    # Point test on every pipe: a hair along the normal from the pipe midpoint lies in
    # grain 1, a hair against it in grain 0. All sub-contacts are pipe ends.
    p0 = mesh.fluid_node_xy[mesh.pipe_nodes[:, 0]]
    p1 = mesh.fluid_node_xy[mesh.pipe_nodes[:, 1]]
    mid = 0.5 * (p0 + p1)
    ends = mesh.pipe_contacts
    normal = mesh.contact_normal[ends[:, 0]]
    pg0 = mesh.interface_grains[mesh.pipe_interface, 0]
    pg1 = mesh.interface_grains[mesh.pipe_interface, 1]
    eps = 1e-6
    in1 = np.array([polys[g].contains(shapely.Point(p)) for g, p in zip(pg1, mid + eps * normal,
                                                                          strict=True)])
    in0 = np.array([polys[g].contains(shapely.Point(p)) for g, p in zip(pg0, mid - eps * normal,
                                                                          strict=True)])
    same_normal = np.abs(mesh.contact_normal[ends[:, 0]] - mesh.contact_normal[ends[:, 1]]).max()
    direction = p1 - p0
    perp = np.abs(np.sum(direction * normal, axis=1) / np.hypot(*direction.T)).max()

    print(f"\n[sub-contacts] n={mesh.n_contacts}; max node gap={gap.max():.1e} m (tol 1e-12); "
          f"node order ok: {own0.mean():.3f}/{own1.mean():.3f}; max |n|-1={unit.max():.1e}; "
          f"tangent error={tangent_err:.1e}; normal towards grain-1 centroid: "
          f"{towards.mean():.4f} (> 0.99); pipe midpoint test in grain 1: {in1.mean():.4f}, "
          f"in grain 0: {in0.mean():.4f} (== 1); normal . pipe direction max={perp:.1e}")
    assert gap.max() < 1e-12
    assert at_xy.max() < 1e-12
    assert own0.all() and own1.all()
    assert unit.max() < 1e-12
    assert tangent_err < 1e-15
    assert towards.mean() > 0.99
    assert in1.all() and in0.all()
    assert same_normal < 1e-15
    assert perp < 1e-9
    assert set(np.unique(ends).tolist()) == set(range(mesh.n_contacts))


# ----------------------------------------------------------------- flow network


def test_flow_network(slab):
    mesh = slab.mesh
    polys = mesh.grains.polygons()
    reference = np.array([_shared_length(polys, a, b) for a, b in mesh.interface_grains.tolist()])
    per_iface = np.bincount(mesh.pipe_interface, weights=mesh.pipe_length,
                            minlength=mesh.n_interfaces)
    rel = np.abs(per_iface - reference) / reference
    d = mesh.fluid_node_xy[mesh.pipe_nodes[:, 1]] - mesh.fluid_node_xy[mesh.pipe_nodes[:, 0]]
    length_err = np.abs(np.hypot(*d.T) - mesh.pipe_length).max()
    used = np.zeros(len(mesh.fluid_node_xy), dtype=bool)
    used[mesh.contact_fluid_node] = True
    fluid_at = np.hypot(*(mesh.fluid_node_xy[mesh.contact_fluid_node] - mesh.contact_xy).T)
    print(f"\n[flow] fluid nodes={len(mesh.fluid_node_xy)} pipes={len(mesh.pipe_length)}; "
          f"pipe length per interface vs shapely: max rel. error={rel.max():.2e} (tol 1e-9); "
          f"fluid nodes used by a sub-contact: {used.mean():.3f} (== 1); "
          f"pipe length vs node distance: {length_err:.1e} m; "
          f"pipe length {mesh.pipe_length.min() / MM:.3f}-{mesh.pipe_length.max() / MM:.3f} mm "
          f"(zone {mesh.zone_size / MM:g} mm)")
    assert rel.max() < 1e-9
    assert used.all()
    assert fluid_at.max() < 1e-12
    assert length_err < 1e-12
    assert np.all(mesh.pipe_length > 0)
    assert mesh.pipe_length.max() <= mesh.zone_size * (1 + 1e-9)
    assert np.all(mesh.pipe_width == mesh.thickness)
    assert mesh.pipe_nodes.min() >= 0 and mesh.pipe_nodes.max() < len(mesh.fluid_node_xy)
    # The two sub-contacts at a pipe's ends are its two fluid nodes, on its interface.
    assert np.array_equal(mesh.contact_fluid_node[mesh.pipe_contacts], mesh.pipe_nodes)
    assert np.array_equal(mesh.contact_interface[mesh.pipe_contacts[:, 0]], mesh.pipe_interface)
    assert np.array_equal(mesh.contact_interface[mesh.pipe_contacts[:, 1]], mesh.pipe_interface)


def test_slab_node_and_fluid_sets_on_their_sides(slab):
    mesh = slab.mesh
    half, radius = 50 * MM, 5 * MM
    straight = {"left": (0, -half), "right": (0, half), "bottom": (1, -half), "top": (1, half)}
    for name, (axis, value) in straight.items():
        nodes = mesh.node_xy[mesh.node_sets[name]]
        fluid = mesh.fluid_node_xy[mesh.fluid_node_sets[name]]
        err_n = np.abs(nodes[:, axis] - value).max()
        err_f = np.abs(fluid[:, axis] - value).max() if len(fluid) else 0.0
        span = nodes[:, 1 - axis]
        print(f"\n[slab {name}] nodes={len(nodes)} max |{'xy'[axis]} - {value / MM:g} mm|="
              f"{err_n:.1e} m; span {span.min() / MM:.2f}..{span.max() / MM:.2f} mm; "
              f"fluid nodes={len(fluid)} max err={err_f:.1e} m (tol 1e-12)")
        assert len(nodes) > 0 and len(fluid) > 0
        assert err_n < 1e-12 and err_f < 1e-12
        # The side is covered end to end (both corners belong to it).
        assert span.min() == pytest.approx(-half, abs=1e-12)
        assert span.max() == pytest.approx(half, abs=1e-12)

    nodes = mesh.node_xy[mesh.node_sets["borehole"]]
    fluid = mesh.fluid_node_xy[mesh.fluid_node_sets["borehole"]]
    r_nodes = np.hypot(*nodes.T)
    r_fluid = np.hypot(*fluid.T)
    print(f"[slab borehole] nodes={len(nodes)} r={r_nodes.min() / MM:.4f}-"
          f"{r_nodes.max() / MM:.4f} mm; well fluid nodes={len(fluid)} r={r_fluid.min() / MM:.4f}-"
          f"{r_fluid.max() / MM:.4f} mm (5 +- 0.2 mm)")
    assert len(nodes) > 0 and len(fluid) > 0
    assert np.abs(r_nodes - radius).max() < 0.2 * MM
    assert np.abs(r_fluid - radius).max() < 0.2 * MM
    # Every fluid node at the borehole wall is in the well set.
    r_all = np.hypot(*mesh.fluid_node_xy.T)
    assert set(np.flatnonzero(r_all < radius + 0.2 * MM).tolist()) == set(
        mesh.fluid_node_sets["borehole"].tolist())


def test_slab_boundary_face_normals_outward(slab):
    mesh = slab.mesh
    expected = {"left": (-1.0, 0.0), "right": (1.0, 0.0), "bottom": (0.0, -1.0), "top": (0.0, 1.0)}
    lengths = _side_lengths_mm(mesh)
    for name, direction in expected.items():
        faces = mesh.boundary_faces[name]
        cos = faces.normal @ np.asarray(direction)
        total = faces.length.sum() / MM
        print(f"\n[slab faces {name}] faces={len(faces.length)} min cos(normal, "
              f"{direction})={cos.min():.12f} (tol 1 - 1e-12); length sum={total:.6f} mm "
              f"(side {lengths[name]:g} mm)")
        assert cos.min() > 1 - 1e-12
        assert total == pytest.approx(lengths[name], rel=1e-12)
    faces = mesh.boundary_faces["borehole"]
    mid = 0.5 * (mesh.node_xy[faces.nodes[:, 0]] + mesh.node_xy[faces.nodes[:, 1]])
    inward = -mid / np.hypot(*mid.T)[:, None]  # out of the rock = towards the well centre
    cos = np.sum(faces.normal * inward, axis=1)
    total = faces.length.sum() / MM
    print(f"[slab faces borehole] faces={len(faces.length)} min cos(normal, -r_hat)="
          f"{cos.min():.6f} (> 0.99); length sum={total:.4f} mm (polygon {lengths['borehole']:.4f}"
          f", circle {10 * math.pi:.4f} mm)")
    assert cos.min() > 0.99
    assert total == pytest.approx(lengths["borehole"], rel=1e-3)


# ----------------------------------------------------------------- all shapes


@pytest.mark.parametrize("shape", SHAPES)
def test_shape_builds_with_named_sets(shapes, shape):
    mesh = shapes[shape].mesh
    sides = mesh.grains.outline.sides
    # The meshed domain: arcs lose the odd outline vertex where a short boundary piece
    # was merged away, so test normals against the grains rather than the outline.
    domain = shapely.union_all(mesh.grains.polygons())
    lengths = _side_lengths_mm(mesh)
    print(f"\n[{shape}] grains={mesh.grains.n_grains} elements={mesh.n_elements} "
          f"contacts={mesh.n_contacts} interfaces={mesh.n_interfaces}")
    assert set(mesh.node_sets) == EXPECTED_SIDES[shape]
    assert set(mesh.boundary_faces) == EXPECTED_SIDES[shape]
    assert set(mesh.fluid_node_sets) == EXPECTED_SIDES[shape]
    for name in sorted(EXPECTED_SIDES[shape]):
        nodes = mesh.node_xy[mesh.node_sets[name]]
        fluid = mesh.fluid_node_xy[mesh.fluid_node_sets[name]]
        faces = mesh.boundary_faces[name]
        d_nodes = shapely.distance(sides[name], shapely.points(nodes)).max()
        d_fluid = shapely.distance(sides[name], shapely.points(fluid)).max() if len(fluid) else 0.0
        # Outward normals: a hair along the normal from a face midpoint leaves the specimen.
        mid = 0.5 * (mesh.node_xy[faces.nodes[:, 0]] + mesh.node_xy[faces.nodes[:, 1]])
        out = mid + 1e-6 * faces.normal
        inn = mid - 1e-6 * faces.normal
        outside = ~shapely.contains_xy(domain, out[:, 0], out[:, 1])
        inside = shapely.contains_xy(domain, inn[:, 0], inn[:, 1])
        total = faces.length.sum() / MM
        print(f"  {name}: nodes={len(nodes)} fluid nodes={len(fluid)} faces={len(faces.length)}"
              f" length={total:.4f} mm (side {lengths[name]:.4f}); max dist to side: nodes "
              f"{d_nodes:.1e} m, fluid {d_fluid:.1e} m (tol 1e-9); normals outward "
              f"{outside.mean():.3f}, inward side inside {inside.mean():.3f}")
        assert len(nodes) > 0, name
        assert len(faces.length) > 0, name
        assert d_nodes < 1e-9 and d_fluid < 1e-9
        assert outside.all() and inside.all()
        assert np.abs(np.hypot(*faces.normal.T) - 1).max() < 1e-12
        assert total == pytest.approx(lengths[name], rel=1e-3)


@pytest.mark.parametrize("shape", ["slab", "disk", "semi_disk", "rectangle"])
def test_element_min_angle_over_seeds(shape):
    """No slivers for other seeds either (short boundary pieces are merged away)."""
    worst = []
    for seed in range(1, 8):
        cfg = validate(SpecimenConfig, {"seed": seed, "specimen": {"shape": shape}})
        worst.append(build_assembly(cfg, cfg.recipe()).mesh.element_min_angles().min())
    print(f"\n[{shape}] min angle over seeds 1-7: {min(worst):.2f} deg "
          f"(must be > {MIN_ANGLE_DEG:g})")
    assert min(worst) > MIN_ANGLE_DEG


def test_small_slab_round_a_small_well_builds_for_every_seed():
    """The lab HS specimen (22.5 mm slab, 3 mm well, 3-8 mm grains): merging a small
    piece into its longest-shared neighbour closed a ring round the well at seed 2
    (a failed run of `grainfrac study paper`); the next neighbour is taken instead."""
    cfg = validate(SpecimenConfig, {
        "seed": 0, "specimen": {"shape": "slab", "width_mm": 22.5, "height_mm": 22.5,
                                "thickness_mm": 45.0, "borehole_diameter_mm": 3.0},
        "grains": {"zone_size_mm": 1.0}})
    for seed in range(6):
        a = build_assembly(cfg.model_copy(update={"seed": seed}), cfg.recipe())
        hole = shapely.Point(0.0, 0.0).buffer(1.5e-3, 64)
        grains = a.mesh.grains.polygons()
        assert all(g.is_valid and not g.interiors for g in grains), seed
        covered = shapely.union_all(grains).area + hole.area
        assert covered == pytest.approx(0.0225**2, rel=2e-3), seed
