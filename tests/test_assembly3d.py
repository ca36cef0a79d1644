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
        ({**SLAB, "specimen": {"shape": "disk"}}, "specimen.shape"),
        ({**SLAB, "specimen": {"shape": "sphere"}}, "specimen"),
        ({**SLAB, "dimension": 4}, "dimension"),
    ],
    ids=["borehole-too-wide", "thinner-than-a-zone", "shape-not-in-3d", "unknown-shape",
         "bad-dimension"],
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

    ratio = stable_steps3d(fissured)["grains_ratio"]
    print(f"stable step / regular 2 mm quartz tet (tets only, real mass): {ratio:.3f}")
    assert ratio >= 0.15
