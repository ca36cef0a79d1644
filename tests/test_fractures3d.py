"""3D fracture analysis (issue 43): radial counts on planes, extent, tortuosity,
fracture area, patches and cross-sections, on cases whose answer is known."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from grainfrac.analysis import fractures3d as f3
from grainfrac.analysis.fractures import radial_fractures
from grainfrac.assembly import build_specimen
from grainfrac.physics.kernels import SHEAR, TENSILE

MM = 1e-3
SLAB3D = {"dimension": 3, "seed": 1,
          "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30, "thickness_mm": 16,
                       "borehole_diameter_mm": 6}}


@pytest.fixture(scope="module")
def assembly():
    return build_specimen(SLAB3D)


def _arm(angle_deg: float, r_mm: np.ndarray, z_mm: np.ndarray) -> np.ndarray:
    r, z = np.meshgrid(r_mm, z_mm, indexing="ij")
    a = np.radians(angle_deg)
    return np.column_stack((r.ravel() * np.cos(a), r.ravel() * np.sin(a), z.ravel())) * MM


@pytest.fixture(scope="module")
def synthetic(assembly):
    """The slab's mesh with its first sub-contacts moved onto known fracture planes.

    Two arms along +x (to r = 14 mm) and -x (to 12 mm) over the whole height, a
    third arm along +y (to 10 mm) only in the bottom 4 mm (so neither the top
    nor the mid-height band sees it), and an isolated cluster at (12, 12) mm
    not connected to the well. Crack positions are 1 mm apart (half a zone).
    """
    z = np.arange(0.0, 16.01, 1.0)
    parts = {
        "+x": _arm(0.0, np.arange(3.0, 14.01, 1.0), z),
        "-x": _arm(180.0, np.arange(3.0, 12.01, 1.0), z),
        "+y": _arm(90.0, np.arange(3.0, 10.01, 1.0), z[z <= 4.0]),
        "island": np.array([[12.0, 12.0, 8.0], [12.5, 12.0, 8.0], [12.0, 12.5, 8.5]]) * MM,
    }
    x = np.vstack(list(parts.values()))
    mesh = assembly.mesh
    assert len(x) < mesh.n_contacts
    moved = mesh.contact_x.copy()
    moved[:len(x)] = x
    cracks = np.arange(len(x))
    sizes = {k: len(v) for k, v in parts.items()}
    return dataclasses.replace(mesh, contact_x=moved), cracks, sizes


# --------------------------------------------------------------------------- radial counts


def test_two_arms_give_two_radial_fractures_on_top_and_mid_plane(synthetic):
    mesh, cracks, _ = synthetic
    for plane in ("top", "mid"):
        res = f3.radial_fractures3d(mesh, cracks, plane)
        print(plane, res.z, res.count, res.radial.angles_deg, res.radial.extents)
        assert res.count == 2
        assert np.allclose(res.radial.angles_deg, [0.0, 180.0], atol=1e-9)
        assert np.allclose(res.radial.extents, [14 * MM, 12 * MM])
        # The band reaches one zone (2 mm) from the plane.
        z = mesh.contact_x[cracks[res.members], 2]
        assert np.all(np.abs(z - res.z) <= mesh.zone_size)
    # Layers 1 mm apart: z = 14, 15, 16 mm at the top; 6 ... 10 mm (and the
    # island at 8 and 8.5 mm) at mid-height.
    assert f3.radial_fractures3d(mesh, cracks, "top").members.size == 3 * (12 + 10)
    assert f3.radial_fractures3d(mesh, cracks, "mid").members.size == 5 * (12 + 10) + 3
    # The third arm is in the bottom band only.
    bottom = f3.radial_fractures3d(mesh, cracks, "bottom")
    assert bottom.count == 3
    assert np.allclose(bottom.radial.angles_deg, [0.0, 90.0, 180.0], atol=1e-9)


def test_extent_counts_only_cracks_connected_to_the_well(synthetic):
    mesh, cracks, _ = synthetic
    assert f3.fracture_extent3d(mesh, cracks) == pytest.approx(14 * MM, rel=1e-12)
    assert f3.fracture_extent3d(mesh, cracks, well_connected=False) == pytest.approx(
        np.hypot(12.5, 12.0) * MM, rel=1e-12)
    assert f3.fracture_extent3d(mesh, cracks[:0]) is None


def test_straight_diametral_fracture_has_tortuosity_one(synthetic):
    mesh, cracks, _ = synthetic
    tau = f3.fracture_tortuosity3d(mesh, cracks)
    print(f"top tortuosity {tau}")
    assert tau == pytest.approx(1.0, abs=1e-12)


def test_summary_gathers_the_quantities(synthetic):
    mesh, cracks, sizes = synthetic
    mode = np.where(np.arange(cracks.size) < sizes["+x"], TENSILE, SHEAR)
    s = f3.fracture_summary3d(mesh, cracks, mode)
    print(s)
    assert s["n_cracks"] == cracks.size
    assert s["n_tensile_cracks"] == sizes["+x"]
    assert s["n_radial_fractures_top"] == s["n_radial_fractures_mid"] == 2
    assert s["fracture_extent_mm"] == pytest.approx(14.0, rel=1e-12)
    assert s["tortuosity_top"] == pytest.approx(1.0, abs=1e-12)
    assert s["fracture_area_m2"] == pytest.approx(mesh.contact_area[cracks].sum(), rel=1e-12)


def test_count_on_the_real_mesh_is_the_2d_count_of_the_projected_band(assembly):
    mesh = assembly.mesh
    x = mesh.contact_x
    cracks = np.flatnonzero(np.abs(x[:, 1]) < 1.5 * mesh.zone_size)
    for plane in ("top", "mid"):
        res = f3.radial_fractures3d(assembly, cracks, plane, radius=11 * MM)
        z = f3.plane_height(assembly, plane)
        band = cracks[np.abs(x[cracks, 2] - z) <= mesh.zone_size]
        ref = radial_fractures(x[band, 0], x[band, 1], well_radius=mesh.borehole_radius,
                               connect_distance=1.5 * mesh.zone_size, radius=11 * MM)
        assert np.array_equal(cracks[res.members], band)
        assert res.count == ref.count
        assert np.array_equal(res.radial.angles_deg, ref.angles_deg)


# --------------------------------------------------------------------------- area


def test_area_of_one_face_is_its_polygon_area(assembly):
    mesh = assembly.mesh
    areas = mesh.grains.face_areas()
    face = int(np.argmax(np.where(mesh.face_interface >= 0, areas, 0.0)))
    cracks = np.flatnonzero(mesh.contact_face == face)
    mode = np.where(np.arange(cracks.size) % 3 == 0, SHEAR, TENSILE)
    a = f3.fracture_area(assembly, cracks, mode)
    print(f"face {face}: {cracks.size} sub-contacts, {a}")
    assert a["fracture_area_m2"] == pytest.approx(areas[face], rel=1e-9)
    assert a["tensile_area_m2"] + a["shear_area_m2"] == pytest.approx(areas[face], rel=1e-12)
    assert a["tensile_area_m2"] == pytest.approx(
        mesh.contact_area[cracks[mode == TENSILE]].sum(), rel=1e-12)
    assert a["tensile_shear_area_ratio"] == pytest.approx(
        a["tensile_area_m2"] / a["shear_area_m2"], rel=1e-12)


def test_all_sub_contacts_cover_every_grain_boundary(assembly):
    mesh = assembly.mesh
    everything = np.arange(mesh.n_contacts)
    a = f3.fracture_area(assembly, everything, np.full(everything.size, TENSILE))
    assert a["fracture_area_m2"] == pytest.approx(mesh.interface_area.sum(), rel=1e-9)
    assert a["shear_area_m2"] == 0.0 and a["tensile_shear_area_ratio"] is None
    assert f3.fracture_area(assembly, [], [])["fracture_area_m2"] == 0.0


def test_patches_are_the_tributary_areas_of_the_sub_contacts(assembly):
    mesh = assembly.mesh
    everything = np.arange(mesh.n_contacts)
    quads, owner = f3.contact_patches(assembly, everything)
    area = np.bincount(owner, weights=f3.polygon_areas(quads), minlength=mesh.n_contacts)
    err = np.abs(area - mesh.contact_area).max() / mesh.contact_area.max()
    print(f"{len(quads)} quadrilaterals, largest relative area difference {err:.1e}")
    assert err < 1e-12
    # Each quadrilateral starts at its sub-contact's point.
    assert np.allclose(quads[:, 0], mesh.contact_x[owner], rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- sections


def test_section_segments_of_simple_polygons():
    square = np.array([[[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]], dtype=float)
    seg, which = f3.section_segments(square, 0.25)
    assert which.tolist() == [0]
    assert np.allclose(np.sort(seg[0, :, 0]), [0, 1]) and np.allclose(seg[0, :, 1], 0)
    # Touching the plane at a corner leaves no trace; a polygon off the plane neither.
    touching = np.array([[[0, 0, 0], [1, 0, 1], [0, 1, 1]]], dtype=float)
    assert f3.section_segments(touching, 0.0)[0].shape == (0, 2, 2)
    assert f3.section_segments(square, 2.0)[0].shape == (0, 2, 2)
    with pytest.raises(ValueError, match="polygons"):
        f3.section_segments(np.zeros((2, 3)), 0.0)


def test_sections_of_all_sub_contacts_are_the_grain_boundary_sections(assembly):
    mesh = assembly.mesh
    solid = mesh.grains.solid
    everything = np.arange(mesh.n_contacts)
    mode = np.where(everything % 2 == 0, TENSILE, SHEAR)
    sections = f3.cross_sections(assembly, everything, mode)
    assert [s.fraction for s in sections] == list(f3.SECTION_FRACTIONS)
    for s in sections:
        grain = f3.grain_boundary_section(assembly, s.z)
        total = np.hypot(*(grain[:, 1] - grain[:, 0]).T).sum()
        print(f"z = {s.z * 1e3:.1f} mm: {s.n_cracks} sub-contacts cut, traces "
              f"{s.trace_length() * 1e3:.2f} mm, grain boundaries {total * 1e3:.2f} mm")
        assert s.z == pytest.approx(solid.lo[2] + s.fraction * solid.extent[2])
        assert s.trace_length() == pytest.approx(total, rel=1e-9)
        assert s.trace_length(TENSILE) + s.trace_length(SHEAR) == pytest.approx(
            s.trace_length(), rel=1e-12)
        assert np.array_equal(s.mode, mode[s.contact])
        ends = s.segments.reshape(-1, 2)
        assert np.all(ends >= solid.lo[:2] - 1e-12) and np.all(ends <= solid.hi[:2] + 1e-12)
        assert np.hypot(*ends.T).min() >= solid.apothem - 1e-12


def test_section_of_one_face_is_its_chord(assembly):
    """The patches of one face cut by a plane: the face polygon's own chord."""
    mesh = assembly.mesh
    cx = mesh.grains
    z = f3.plane_height(assembly, "mid")
    best, chord = -1, 0.0
    for f in np.flatnonzero(mesh.face_interface >= 0):
        seg, _ = f3.section_segments(cx.vertices[cx.faces[f]][None], z)
        if len(seg) and np.hypot(*(seg[0, 1] - seg[0, 0])) > chord:
            best, chord = int(f), float(np.hypot(*(seg[0, 1] - seg[0, 0])))
    cracks = np.flatnonzero(mesh.contact_face == best)
    (s,) = f3.cross_sections(assembly, cracks, np.full(cracks.size, TENSILE), fractions=[0.5])
    print(f"face {best}: chord {chord * 1e3:.3f} mm, traces {s.trace_length() * 1e3:.3f} mm")
    assert s.trace_length() == pytest.approx(chord, rel=1e-9)


# --------------------------------------------------------------------------- bad input


def test_bad_inputs_name_the_argument(assembly):
    n = assembly.mesh.n_contacts
    with pytest.raises(ValueError, match=rf"contact: sub-contact id {n} out of range"):
        f3.fracture_area(assembly, [0, n], [1, 1])
    with pytest.raises(ValueError, match="contact: sub-contact id -1"):
        f3.radial_fractures3d(assembly, [-1])
    with pytest.raises(ValueError, match="contact: sub-contact ids must be integers"):
        f3.fracture_extent3d(assembly, [0.5])
    with pytest.raises(ValueError, match="contact: sub-contact 3 is listed 2 times"):
        f3.fracture_area(assembly, [3, 3], [1, 1])
    with pytest.raises(ValueError, match="mode: 1 modes for 2 cracks"):
        f3.fracture_area(assembly, [0, 1], [1])
    with pytest.raises(ValueError, match="mode: unknown crack mode 'opening'"):
        f3.cross_sections(assembly, [0], ["opening"])
    with pytest.raises(ValueError, match="plane: 'middle'"):
        f3.radial_fractures3d(assembly, [0], "middle")
    with pytest.raises(ValueError, match="plane: z = 1 m is outside"):
        f3.plane_height(assembly, 1.0)
    with pytest.raises(ValueError, match="fractions"):
        f3.cross_sections(assembly, [0], [1], fractions=[1.5])
    with pytest.raises(ValueError, match="assembly: a 3D assembly"):
        f3.fracture_area(object(), [0], [1])


def test_radial_quantities_need_a_borehole(assembly):
    mesh = assembly.mesh
    solid = dataclasses.replace(mesh.grains.solid, borehole_radius=0.0, borehole_facets=0)
    plain = dataclasses.replace(mesh, grains=dataclasses.replace(mesh.grains, solid=solid))
    with pytest.raises(ValueError, match="borehole"):
        f3.radial_fractures3d(plain, [0, 1])
    with pytest.raises(ValueError, match="borehole"):
        f3.fracture_extent3d(plain, [0, 1])
    assert f3.fracture_extent3d(plain, [0], well_connected=False) == pytest.approx(
        np.hypot(*mesh.contact_x[0, :2]))
