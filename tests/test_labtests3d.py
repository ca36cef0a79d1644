"""The virtual laboratory in 3D: the Table 3 tests on solid specimens.

The full-size specimens take minutes each (``python benchmarks/labtests.py --dim 3``);
these tests use smaller ones with the same machinery.
"""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from grainfrac import materials
from grainfrac.cli import app
from grainfrac.labtests.config import lab_test_config
from grainfrac.labtests.run import measure

QUARTZ_E_GPA, QUARTZ_NU = 27.37, 0.21  # paper Table 2
SMALL_GRAINS = {"min_edge_mm": 2.0, "max_edge_mm": 5.0, "zone_size_mm": 1.5}


def test_3d_ucs_recovers_the_elastic_constants_of_a_homogeneous_grain_assembly():
    """Unbreakable quartz grains with 100x stiff contacts in a 12 x 24 mm cylinder:
    the UCS readings (tangent E from the end faces' closure, nu from the lateral
    surface's radial displacement) return quartz's E and nu. Measured at 2.5 mm/s:
    E -0.11 / -0.05 %, nu -0.22 / -0.13 % (seeds 0 / 1). Stiffer contacts take more
    mass (mass scaling) and ring: 1000x read E -7.0 % at 2.5 mm/s and needed 1 mm/s
    (74 s). Faster platens ring too (5 mm/s: E +2.6 % on seed 1); softer contacts show
    (10x: E -0.50 %)."""
    recipe = materials.homogeneous_recipe("quartz", stiffness_factor=100.0, unbreakable=True)
    cfg = lab_test_config("ucs", dimension=3, rock=recipe,
                          specimen={"shape": "rectangle", "width_mm": 12.0, "height_mm": 24.0},
                          grains=SMALL_GRAINS,
                          loading={"max_strain": 0.001, "peak_drop_fraction": 0.9,
                                   "stop_fraction": 0.05, "platen_speed_mm_per_s": 2.5})
    s = measure(cfg, recipe=recipe)["summary"]
    e_err = s["youngs_modulus_GPa"] / QUARTZ_E_GPA - 1
    nu_err = s["poisson_ratio"] / QUARTZ_NU - 1
    print(f"\nE {s['youngs_modulus_GPa']:.3f} GPa (error {e_err:+.2%}, tolerance 5 %), nu "
          f"{s['poisson_ratio']:.4f} (error {nu_err:+.2%}, tolerance 2 %); "
          f"{s['n_elements']} tetrahedra, {s['n_grains']} grains")
    assert s["dimension"] == 3 and not s["peak_found"]
    assert abs(e_err) < 0.05 and abs(nu_err) < 0.02


@pytest.mark.slow  # 13 s; keeps the default suite under 10 min
def test_cli_labtest_dim3_splits_a_brazilian_disc(tmp_path):
    """``grainfrac labtest bts --dim 3`` on a small disc: a split along the loaded
    diameter, the 3D crack figures and the summary."""
    config = tmp_path / "bts.toml"
    config.write_text('specimen = {shape = "disk", diameter_mm = 20.0, thickness_mm = 8.0}\n'
                      'grains = {min_edge_mm = 2.0, max_edge_mm = 5.0, zone_size_mm = 1.5}\n')
    out = tmp_path / "bts"
    result = CliRunner().invoke(app, ["labtest", "bts", "--dim", "3", "--config", str(config),
                                      "--out", str(out)])
    assert result.exit_code == 0, result.output
    s = json.loads((out / "summary.json").read_text())
    print(f"\nBTS {s['bts_MPa']:.2f} MPa, {s['n_cracks']} cracks, split {s['split_found']}")
    assert s["dimension"] == 3 and s["peak_found"] and s["split_found"]
    assert 2.0 < s["bts_MPa"] < 40.0
    for name in ("fractures3d.png", "fracture_sections.png", "curve.png"):
        assert (out / "figures" / name).stat().st_size > 10_000
    assert (out / "cracks.csv").read_text().splitlines()[0].endswith("z_mm,normal_z,area_mm2")


def test_3d_permeability_of_the_lab_cylinder_obeys_the_cubic_law(tmp_path):
    """``grainfrac labtest permeability --dim 3``: the constant head between the
    cylinder's ends (paper Eq. 8, Table 4) on a 12 x 24 mm cylinder. The network
    conserves volume (inflow = outflow to round-off), k scales as a0^3 exactly (one
    aperture everywhere: the steady pressures do not depend on it), k lies just under
    the linear-field bound of the grain faces (Snow / Oda; the steady network
    dissipates least), and the section is the faceted cylinder's. Measured: k / k_lin
    0.97-1.0 on the full-size cylinder (1.11e-19 m2 at seed 0, lab 1e-19)."""
    fields = {"dimension": 3, "seed": 1, "grains": SMALL_GRAINS,
              "specimen": {"shape": "rectangle", "width_mm": 12.0, "height_mm": 24.0}}
    runs = [measure(lab_test_config("permeability", permeability={"initial_aperture_m": a},
                                    **fields))["summary"] for a in (2e-7, 4e-7)]
    s = runs[0]
    print(f"\nk {s['permeability_m2']:.4g} m2, linear field {s['linear_field_m2']:.4g}, "
          f"{s['n_grains']} grains")
    assert s["dimension"] == 3 and s["height_m"] == pytest.approx(0.024, rel=1e-12)
    assert s["outflow_m3_s"] == pytest.approx(s["flow_rate_m3_s"], rel=1e-9)
    assert runs[1]["permeability_m2"] / s["permeability_m2"] == pytest.approx(8.0, rel=1e-9)
    assert 0.85 < s["permeability_m2"] / s["linear_field_m2"] < 1.001
    assert s["area_m2"] == pytest.approx(math.pi * 0.006**2, rel=0.02)  # faceted, inside


@pytest.mark.parametrize("fields,field", [
    ({"test": "ucs", "dimension": 4}, "dimension"),
    ({"test": "permeability", "dimension": 3, "permeability": {"pressure_in_MPa": 0.0}},
     "permeability.pressure_in_MPa"),
])
def test_bad_3d_lab_test_input_names_the_field(fields, field):
    from grainfrac.errors import GrainfracError

    with pytest.raises((GrainfracError, ValueError), match=field):
        lab_test_config(**fields)


# Small specimens of each test (seed 1, grains 2-5 mm at 1.5 mm zones). Measured, change
# of the strength when the platens move at half the default speed: BTS -0.51 % (14
# grains, 29 s both runs; -0.37 % with the default fast approach, 22 s), UCS +0.29 % (7
# grains, 152 s), K_IC -0.44 % (15 grains, 315 s; -0.18 % with the default fast approach,
# 118 s).
SMALL_SPECIMENS = {
    "bts": {"shape": "disk", "diameter_mm": 20.0, "thickness_mm": 8.0},
    "ucs": {"shape": "rectangle", "width_mm": 15.0, "height_mm": 30.0},
    "nscb": {"shape": "semi_disk", "diameter_mm": 30.0, "thickness_mm": 10.0,
             "notch_length_mm": 5.0, "support_span_mm": 24.0},
}


@pytest.mark.slow
@pytest.mark.parametrize("test,key", [("bts", "bts_MPa"), ("ucs", "ucs_MPa"),
                                      ("nscb", "kic_MPa_sqrt_m")])
def test_halving_the_platen_speed_changes_3d_strength_by_under_2_percent(test, key):
    fields = {"dimension": 3, "seed": 1, "specimen": SMALL_SPECIMENS[test],
              "grains": SMALL_GRAINS}
    speed = lab_test_config(test, **fields).platen_speed_mm_per_s
    values = [measure(lab_test_config(test, loading={"platen_speed_mm_per_s": v}, **fields)
                      )["summary"][key] for v in (speed, speed / 2)]
    change = values[1] / values[0] - 1
    print(f"\n{test} 3D: {key} {values[0]:.4g} at {speed:g} mm/s, {values[1]:.4g} at "
          f"{speed / 2:g} mm/s: change {change:+.2%} (tolerance 2 %)")
    assert abs(change) < 0.02
