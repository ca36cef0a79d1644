"""3D elastic verification (``grainfrac verify patch3d / lame3d / kirsch3d``) and the 3D
boundary loads, on small models; the full-size numbers are in the case docstrings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainfrac.geometry.solids3d import BOREHOLE
from grainfrac.loading.boundary3d import (
    far_field_stress_forces3d,
    normal_pressure_forces3d,
    side_traction_forces3d,
    surface_triangles,
)
from grainfrac.verification import CASES
from grainfrac.verification.elastic3d import (
    homogeneous_slab3d,
    kirsch3d,
    lame3d,
    patch3d,
)

W, T, D = 30.0, 6.0, 10.0  # mm: slab width (= height), thickness, borehole diameter


@pytest.fixture(scope="module")
def slab():
    return homogeneous_slab3d(W, W, T, D, seed=1)


def test_face_forces_sum_to_stress_times_area(slab):
    mesh = slab.mesh
    w, t = W * 1e-3, T * 1e-3
    areas = {"x-": w * t, "x+": w * t, "y-": w * t, "y+": w * t,
             "z-": w * w - mesh.grains.solid.borehole_area,
             "z+": w * w - mesh.grains.solid.borehole_area}
    sx, sy, sz = 2.5e6, 5.0e6, 1.0e6
    stress = {"x": sx, "y": sy, "z": sz}
    for side, area in areas.items():
        _, tri_area, _ = surface_triangles(mesh, side)
        assert math.isclose(tri_area.sum(), area, rel_tol=1e-12), side
        f = normal_pressure_forces3d(mesh, side, stress[side[0]])
        axis = "xyz".index(side[0])
        inward = -1.0 if side[1] == "+" else 1.0  # compression pushes into the rock
        total = f.sum(axis=0)
        assert math.isclose(total[axis], inward * stress[side[0]] * area, rel_tol=1e-12)
        others = np.delete(total, axis)
        assert np.all(np.abs(others) <= 1e-12 * stress[side[0]] * area)
        # only the face's nodes are loaded
        loaded = np.flatnonzero(np.any(f != 0, axis=1))
        assert np.all(np.isin(loaded, mesh.node_sets[side]))
    shear = side_traction_forces3d(mesh, "x+", (0.0, 1.0e6, 0.0)).sum(axis=0)
    assert np.allclose(shear, (0.0, 1.0e6 * w * t, 0.0), rtol=1e-12, atol=0.0)


def test_far_field_and_borehole_pressure_have_no_net_force_or_moment(slab):
    mesh = slab.mesh
    solid = mesh.grains.solid
    for f, scale in ((far_field_stress_forces3d(mesh, 2.5e6, 5.0e6, 1.0e6), 5.0e6 * 9e-4),
                     (normal_pressure_forces3d(mesh, BOREHOLE, 10e6), 10e6 * 3e-4)):
        assert np.all(np.abs(f.sum(axis=0)) <= 1e-12 * scale)
        moment = np.cross(mesh.node_x - mesh.node_x.mean(axis=0), f).sum(axis=0)
        assert np.all(np.abs(moment) <= 1e-12 * scale * 0.03)
    # the wall pressure's total radial push: p x wall area (perimeter x thickness)
    n = solid.borehole_facets
    perimeter = 2 * n * solid.borehole_radius * math.sin(math.pi / n)
    _, area, normal = surface_triangles(mesh, BOREHOLE)
    assert math.isclose(area.sum(), perimeter * T * 1e-3, rel_tol=1e-12)
    assert np.all(np.abs(normal[:, 2]) < 1e-12)


def test_cases_are_registered():
    assert {"patch3d", "lame3d", "kirsch3d", "kirsch3d-plane-strain"} <= set(CASES)


def test_patch3d_uniform_stress():
    rows = {c.quantity: c for c in patch3d(size_mm=15.0, zone_size_mm=3.0)}
    for c in rows.values():
        print(c.as_row())
    assert all(c.passed for c in rows.values())


@pytest.fixture(scope="module")
def lame3d_rows():
    """The small slab's Lame row by the static solve and by dynamic relaxation."""
    return {equilibrium: lame3d(width_mm=40.0, thickness_mm=4.0, equilibrium=equilibrium)[0]
            for equilibrium in ("static", "explicit")}


def test_lame3d_small_slab(lame3d_rows):
    # 40 mm slab (b = 4 a): the free outer square adds ~+3 % (measured +3.1 %).
    for row in lame3d_rows.values():
        print(row.as_row())
        assert row.passed


def test_lame3d_static_and_explicit_equilibria_agree(lame3d_rows):
    """The same wall displacement within 5e-4 of it (measured 1.2e-4): dynamic
    relaxation stops at the 1e-5 unbalanced-force ratio, the static solve meets it
    to round-off."""
    static, explicit = lame3d_rows["static"], lame3d_rows["explicit"]
    assert static.simulated == pytest.approx(explicit.simulated, rel=5e-4)


class _Built(Exception):
    """Stops a verification case once its slab's zone sizes are known."""


@pytest.mark.parametrize(("call", "zones", "wall"), [
    (lambda: kirsch3d(), 2.0, 1.0),  # the wall refined to 1 mm (decision record 0023)
    (lambda: kirsch3d(zone_size_mm=0.8), 0.8, 0.8),  # never coarser than the zones
    (lambda: kirsch3d(wall_zone_size_mm=2.0), 2.0, 2.0),  # unrefined when told
    (lambda: CASES["kirsch3d-plane-strain"](), 2.0, 2.0),  # plane strain: unrefined
])
def test_kirsch3d_wall_zone_size_defaults(monkeypatch, call, zones, wall):
    from grainfrac.verification import elastic3d

    def record(*args, zone_size_mm, wall_zone_size_mm, **kwargs):
        raise _Built(zone_size_mm, wall_zone_size_mm)

    monkeypatch.setattr(elastic3d, "homogeneous_slab3d", record)
    with pytest.raises(_Built) as built:
        call()
    assert built.value.args == (zones, wall)


def test_kirsch3d_small_slab_wall():
    # 40 mm slab (b = 4 a): the decay bands feel the outer boundary (30 mm: the wall
    # at 90 deg is 15 % off), so only the wall values are checked here.
    rows = {c.quantity: c for c in kirsch3d(width_mm=40.0, thickness_mm=4.0,
                                            wall_zone_size_mm=2.0)}
    for c in rows.values():
        print(c.as_row())
    assert rows["hoop_stress_wall_0deg_MPa"].passed
    assert rows["hoop_stress_wall_90deg_MPa"].passed


def test_kirsch3d_plane_strain_small_slab_wall():
    # Rollers on the top and bottom: Kirsch is exact at every height, so the wall rows
    # measure the discretisation alone (40 x 4 mm: 0 deg +1.2 %, 90 deg -0.7 %).
    rows = {c.quantity: c for c in kirsch3d(width_mm=40.0, thickness_mm=4.0,
                                            wall_zone_size_mm=2.0, plane_strain=True)}
    for c in rows.values():
        print(c.as_row())
        assert c.case == "kirsch3d-plane-strain"
    assert rows["hoop_stress_wall_0deg_MPa"].passed
    assert rows["hoop_stress_wall_90deg_MPa"].passed


def test_kirsch3d_wall_within_5_percent_with_zones_refined_at_the_wall():
    """Plane strain, 60 x 60 x 4 mm slab, seed 0, 2 mm zones with 1 mm at the wall.
    Measured: 2.2 % / 2.7 % at 0 / 90 deg (dynamic relaxation to the 1e-5 ratio read
    2.0 % / 2.6 %, in 44-58 s against 8 s; 2 mm throughout: 2.2 % / 18 %; 1 mm
    throughout: 2.0 % / 4.0 %, five times the run time)."""
    rows = {c.quantity: c for c in kirsch3d(width_mm=60.0, thickness_mm=4.0,
                                            wall_zone_size_mm=1.0, plane_strain=True)}
    for key in ("hoop_stress_wall_0deg_MPa", "hoop_stress_wall_90deg_MPa"):
        print(rows[key].as_row())
        assert rows[key].relative_error < 0.05


@pytest.mark.slow  # 40 s
def test_kirsch3d_wall_converges_with_the_zone_size():
    """Plane strain, 60 x 60 x 4 mm slab (b = 6 a), seed 0. Measured wall errors at 0 / 90
    deg: 2 mm zones 2.2 % / 18 %, 1.5 mm 0.8 % / 6.0 % (dynamic relaxation), 1 mm 2.0 %
    / 4.0 % (static solve; dynamic relaxation to the 1e-5 ratio read 2.0 % / 3.4 %): the
    wall's error is the mesh's and falls within 5 % at 1 mm zones."""
    rows = {c.quantity: c for c in kirsch3d(width_mm=60.0, thickness_mm=4.0,
                                            zone_size_mm=1.0, plane_strain=True)}
    for key in ("hoop_stress_wall_0deg_MPa", "hoop_stress_wall_90deg_MPa"):
        print(rows[key].as_row())
        assert rows[key].relative_error < 0.05
