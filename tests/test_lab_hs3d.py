"""The laboratory hydraulic stimulation specimen in 3D (paper Sect. 2.3 and 5.2): a hollow
cylinder with a central hole along its axis, its lateral confinement, its scenario rules
and a breakdown run on a small one. The full-size test is
``examples/3d/lab-hs-5mlmin.toml`` (six realisations: ``examples/sweeps/lab-hs-3d.toml``).
"""

from __future__ import annotations

import csv

import numpy as np
import pytest

from grainfrac.assembly import build_specimen
from grainfrac.errors import ConfigError
from grainfrac.geometry.solids3d import BOREHOLE, LATERAL
from grainfrac.io.config import validate
from grainfrac.loading.boundary3d import far_field_stress_forces3d, surface_triangles
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario

SMALL = {"shape": "hollow_cylinder", "diameter_mm": 15.0, "height_mm": 10.0,
         "borehole_diameter_mm": 3.0}
GRAINS = {"min_edge_mm": 2.0, "max_edge_mm": 5.0, "zone_size_mm": 1.5}


@pytest.fixture(scope="module")
def cylinder():
    return build_specimen({"dimension": 3, "seed": 1, "specimen": SMALL, "grains": GRAINS})


def test_hollow_cylinder_is_filled_and_closed_by_its_sides(cylinder):
    m = cylinder.mesh
    solid = m.grains.solid
    vol = m.element_volumes()
    assert np.all(vol > 0)
    assert abs(vol.sum() / solid.volume - 1) < 1e-9
    assert set(solid.sides) == {"z-", "z+", LATERAL, BOREHOLE}
    # Divergence theorem over the named sides: the solid's volume, no net area vector.
    flux, total = 0.0, np.zeros(3)
    for side in solid.sides:
        tri, area, normal = surface_triangles(m, side)
        flux += np.sum(area * np.einsum("ij,ij->i", normal, m.node_x[tri].mean(axis=1))) / 3
        total += (area[:, None] * normal).sum(axis=0)
    print(f"\n{cylinder.n_grains} grains, {m.n_elements} tets, enclosed volume error "
          f"{flux / solid.volume - 1:.1e}")
    assert abs(flux / solid.volume - 1) < 1e-9 and np.all(np.abs(total) < 1e-12)
    # The hole runs through the whole height; the lateral surface is the fluid boundary.
    wall = m.node_x[m.node_sets[BOREHOLE]]
    assert np.all(np.hypot(wall[:, 0], wall[:, 1]) <= 1.5e-3 + 1e-12)
    assert np.isclose(wall[:, 2].min(), 0.0) and np.isclose(wall[:, 2].max(), 10e-3)
    assert len(m.flow.node_sets["permeable"]) == len(m.flow.node_sets[LATERAL]) > 0
    assert len(m.flow.node_sets["well"]) > 0


def test_confining_pressure_acts_on_the_lateral_surface(cylinder):
    m = cylinder.mesh
    p = 3e6
    force = far_field_stress_forces3d(m, p, p, 0.0)
    _, area, _ = surface_triangles(m, LATERAL)
    # Every facet lies at the apothem R cos(pi / n) from the axis, so the virial of the
    # nodal forces, -sum F . x, is p x the lateral area x the apothem (exact for linear
    # shape functions); the net force is zero.
    solid = m.grains.solid
    apothem = solid.facets[0, 3]
    virial = -np.einsum("ij,ij->i", force, m.node_x).sum()
    expected = p * area.sum() * apothem
    print(f"\nvirial {virial:.9e} J, expected {expected:.9e} J, net {force.sum(axis=0)} N")
    assert virial == pytest.approx(expected, rel=1e-12)
    assert np.all(np.abs(force.sum(axis=0)) < 1e-9 * p * area.sum())
    with pytest.raises(ValueError, match="sigma_x"):
        far_field_stress_forces3d(m, p, 2 * p, 0.0)


def _scenario(**changes):
    data = {"name": "lab-hs-small", "seed": 1, "dimension": 3, "specimen": SMALL,
            "grains": GRAINS, "stress": {"sigma_x_MPa": 0.0, "sigma_y_MPa": 0.0,
                                         "sigma_z_MPa": 5.12},
            "stages": [{"kind": "equilibrate"},
                       {"kind": "inject", "rate_ml_per_min": 5.0, "duration_ms": 20.0,
                        "stop_at_boundary": False, "stop_after_breakdown_ms": 1.0}]}
    data.update(changes)
    return validate(Scenario, data)


def test_hollow_cylinder_scenario_defaults_and_refusals():
    assert _scenario().fluid.permeable_sides == [LATERAL]
    bad = [({"stress": {"sigma_x_MPa": 1.0, "sigma_y_MPa": 2.0, "sigma_z_MPa": 5.0}},
            "stress.sigma_y_MPa"),
           ({"specimen": {**SMALL, "borehole_diameter_mm": 8.0}}, "borehole_diameter_mm"),
           ({"fluid": {"permeable_sides": ["left"]}}, "fluid.permeable_sides")]
    for changes, field in bad:
        with pytest.raises(ConfigError) as info:
            _scenario(**changes)
        print(info.value)
        assert "\n" not in str(info.value) and info.value.field.endswith(field)
    with pytest.raises(ConfigError) as info:
        build_specimen({"specimen": SMALL})  # 2D
    assert info.value.field == "specimen.shape"


@pytest.mark.slow  # 30 s
def test_small_hollow_cylinder_breaks_down_from_its_hole(tmp_path):
    """Unconfined, 5.12 MPa axial, 5 ml/min: the well pressure rises at the rate of the
    hole's storage, peaks and falls while a fracture runs from the hole to the lateral
    surface (seed 1: peak 7.9 MPa, 49 cracks, all tensile, 30 s)."""
    scenario = _scenario()
    summary = run_scenario(scenario, scenario.recipe(), tmp_path / "run")
    with open(tmp_path / "run" / "history.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if r["stage"] == "inject"]
    well = np.array([float(r["well_pressure_MPa"]) for r in rows])
    peak = summary["breakdown_pressure_MPa"]
    print(f"\nbreakdown {peak:.2f} MPa, {summary['n_cracks']} cracks "
          f"({summary['n_tensile_cracks']} tensile), last well pressure {well[-1]:.2f} MPa")
    assert peak is not None and 3.0 < peak < 30.0
    assert well[-1] < peak and np.isclose(well.max(), peak, rtol=1e-6)
    assert summary["n_tensile_cracks"] > summary["n_shear_cracks"]
    with open(tmp_path / "run" / "cracks.csv") as fh:
        cracks = list(csv.DictReader(fh))
    r = [np.hypot(float(c["x_mm"]), float(c["y_mm"])) for c in cracks]
    assert min(r) < 1.5 + 1.5  # the first cracks open within a zone of the hole's wall
    assert max(r) > 0.8 * 7.5  # and the fracture reaches the lateral surface
