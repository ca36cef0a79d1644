"""Virtual laboratory: data reduction, the four tests, quasi-static loading, the CLI.

Run with ``pytest -s tests/test_labtests.py`` to see measured values next to
their tolerances.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from grainfrac import materials
from grainfrac.cli import app
from grainfrac.errors import ConfigError
from grainfrac.labtests import lab_test_config, measure, run_labtest
from grainfrac.labtests.config import LoadingSpec
from grainfrac.labtests.formulas import (
    brazilian_tensile_strength,
    darcy_permeability,
    nscb_fracture_toughness,
    nscb_geometry_factor,
    plane_strain_to_isotropic,
)
from grainfrac.stages.platen import first_peak

# Paper Table 3 orders of magnitude (laboratory), for "values of the paper's magnitude".
TABLE3 = {"ucs_MPa": 120.94, "bts_MPa": 6.38, "kic_MPa_sqrt_m": 1.35,
          "youngs_modulus_GPa": 17.13, "poisson_ratio": 0.24}


# ---------------------------------------------------------------------------------
# data reduction
# ---------------------------------------------------------------------------------
def test_diametral_split_needs_one_crack_through_the_centre():
    from grainfrac.labtests.mechanical import diametral_split

    r, link = 0.019, 0.0019
    y = np.arange(-15, 15.5, 1.0) * 1e-3
    through = np.column_stack((0.002 * np.sin(y * 400), y))  # zig-zag along the load
    assert diametral_split(through, r, link)
    gap = through[np.abs(through[:, 1]) > 0.003]  # a 6 mm intact bridge at the centre
    assert not diametral_split(gap, r, link)
    across = through[:, ::-1]  # the same crack across the load
    assert not diametral_split(across, r, link)
    off_axis = through + [0.012, 0.0]  # through, but outside the central band
    assert not diametral_split(off_axis, r, link)
    assert not diametral_split(np.empty((0, 2)), r, link)


def test_bts_is_read_at_the_split_not_at_the_lock_up():
    """After the split the halves of a 2D disk lock up and carry more load: not strength."""
    from grainfrac.labtests.mechanical import reduce_bts
    from grainfrac.stages.platen import LoadingCurve

    cfg = lab_test_config("bts", seed=0)
    load = np.concatenate((np.linspace(0, 8e3, 40), np.linspace(8e3, 20e3, 60)))
    curve = LoadingCurve(time=list(range(100)), closure=list(range(100)), load=list(load),
                         n_cracks=[0] * 100, extra={"split": [0.0] * 40 + [1.0] * 60})

    class Box:  # the reducer reads only the dimension, the disk's extent and thickness
        dimension = 2

        class mesh:
            thickness = 0.019

            class grains:
                vertices = np.array([[-0.019, -0.019], [0.019, 0.019]])

    at_split = reduce_bts(curve, Box, cfg)
    assert at_split["split_index"] == 40 and at_split["peak_load_kN"] == pytest.approx(8.0)
    assert at_split["bts_MPa"] == pytest.approx(2 * 8e3 / (math.pi * 0.038 * 0.019) / 1e6)
    curve.extra["split"] = [0.0] * 100  # never split: the first peak (here the maximum)
    no_split = reduce_bts(curve, Box, cfg)
    assert not no_split["split_found"] and no_split["peak_load_kN"] == pytest.approx(20.0)


def test_brazilian_and_darcy_formulas():
    # 10 kN on a 38 x 19 mm disk; Q = 1e-11 m3/s through 1 cm2 over 1 cm at 1 MPa, water.
    assert brazilian_tensile_strength(1e4, 0.038, 0.019) == pytest.approx(
        2e4 / (math.pi * 0.038 * 0.019), rel=1e-12)
    assert darcy_permeability(1e-11, 1e-3, 0.01, 1e-4, 1e6) == pytest.approx(1e-18, rel=1e-12)


def test_nscb_geometry_factor_matches_the_papers_eq7_with_the_full_span():
    """Paper Eq. 7 in s/2R and 2A/D with s = S = 40 mm equals Kuruppu's s/R, a/R form."""
    span, radius, notch = 0.040, 0.025, 0.00833
    s2r, beta = span / (2 * radius), 2 * notch / (2 * radius)
    paper = (-1.297 + 9.516 * s2r - (0.47 + 16.457 * s2r) * beta
             + (1.071 + 34.401 * s2r) * beta**2)
    ours = nscb_geometry_factor(span, radius, notch)
    print(f"\nY' = {ours:.4f} (paper Eq. 7 with s = S: {paper:.4f})")
    assert ours == pytest.approx(paper, rel=1e-12)
    assert ours == pytest.approx(4.9467, abs=1e-3)
    k = nscb_fracture_toughness(1000.0, radius, 0.020, notch, span)
    assert k == pytest.approx(ours * 1000.0 * math.sqrt(math.pi * notch) / (0.05 * 0.02))


def test_plane_strain_conversion_inverts_the_plane_strain_response():
    e, nu = 17.13e9, 0.24
    apparent_e, apparent_nu = e / (1 - nu**2), nu / (1 - nu)
    back = plane_strain_to_isotropic(apparent_e, apparent_nu)
    assert back == pytest.approx((e, nu), rel=1e-12)


def test_first_peak_ignores_later_reloading_and_single_sample_noise():
    load = np.array([0, 1, 2, 3, 2.5, 3.1, 4, 5, 3, 2.9, 4, 6, 8])
    index, found = first_peak(load, 0.1)
    assert found and index == 7
    # one sample 10 % down is noise, not a peak
    index, found = first_peak(np.array([0, 1, 2, 1.7, 2.5, 3.0]), 0.1)
    assert not found and index == 5


def test_default_first_peak_catches_a_small_fall_before_grain_columns_lock_up():
    """A UCS curve whose grain-boundary network fails with a 4 % fall, then intact
    grain columns carry load again (the shape measured at seed 2, softening
    contacts): the default rule reads the strength at the first peak."""
    rise = np.linspace(0.0, 60.0, 30)
    lock_up = np.linspace(57.5, 249.0, 60)
    load = np.concatenate([rise, [58.0, 57.6, 57.5], lock_up])
    index, found = first_peak(load, LoadingSpec().resolved("ucs").peak_drop_fraction)
    assert found and load[index] == 60.0
    assert not first_peak(load, 0.05)[1]  # a 5 % rule reads the lock-up instead


def test_nscb_peak_is_the_maximum_past_the_crack_first_step_from_the_notch():
    """An NSCB curve with a 12 % fall as the crack leaves the notch tip, then the
    ligament carrying more (the shape measured at seed 7, softening contacts):
    the NSCB default reads the maximum, and the test does not stop at the fall."""
    spec = LoadingSpec().resolved("nscb")
    load = np.concatenate([np.linspace(0.0, 0.355, 30), [0.32, 0.31],
                           np.linspace(0.33, 0.886, 60), [0.4, 0.2, 0.1]])
    index, found = first_peak(load, spec.peak_drop_fraction)
    assert found and load[index] == 0.886
    assert 0.31 > spec.stop_fraction * 0.355
    assert first_peak(load, LoadingSpec().resolved("ucs").peak_drop_fraction)[0] == 29


def test_nscb_peak_is_found_while_a_cohesive_tail_bridges_the_crossed_ligament():
    """An NSCB curve whose crack has crossed the ligament but whose cohesive tail
    still carries 0.56 x the peak (the shape measured at seed 1, calibrated
    breakable rock: 0.80 kN, then 0.45-0.50 kN for 0.4 mm): the NSCB rule finds
    the peak at the fall, so the test stops there instead of running on."""
    spec = LoadingSpec().resolved("nscb")
    load = np.concatenate([np.linspace(0.0, 0.80, 30), [0.61, 0.66, 0.77, 0.64],
                           np.full(200, 0.45)])
    index, found = first_peak(load, spec.peak_drop_fraction)
    assert found and load[index] == 0.80
    assert first_peak(load[:40], spec.peak_drop_fraction)[1]  # found within the fall
    assert not first_peak(load, 0.5)[1]  # halving never comes: it would run to max_strain


# ---------------------------------------------------------------------------------
# the four tests on the paper's Table 2 micro-parameters
# ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def table2_runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("lab")
    return {t: run_labtest(lab_test_config(t, seed=0), out / t) | {"dir": out / t}
            for t in ("ucs", "bts", "nscb", "permeability")}


def test_table2_values_are_of_the_papers_magnitude(table2_runs):
    """Uncalibrated 2D values within a factor 3 of Table 3 (they need not match yet)."""
    print()
    for test, summary in table2_runs.items():
        for key, lab in TABLE3.items():
            if key in summary:
                ratio = summary[key] / lab
                print(f"  {test}: {key} {summary[key]:.4g} vs laboratory {lab:g} "
                      f"(x{ratio:.2f}; tolerance x1/3 - x3) in {summary['wall_time_s']:.1f} s")
                assert 1 / 3 < ratio < 3
        if test != "permeability":
            assert summary["peak_found"], f"{test}: no peak"
    k = table2_runs["permeability"]["permeability_m2"]
    print(f"  permeability {k:.3g} m2 vs 1e-19 (Kumari et al. 2018)")
    assert 1e-20 < k < 1e-18


def test_bts_splits_the_disk_along_the_loaded_diameter(table2_runs):
    rows = np.genfromtxt(table2_runs["bts"]["dir"] / "cracks.csv", delimiter=",", names=True,
                         dtype=None, encoding="utf-8")
    x = np.abs(rows["x_mm"])
    near = float(np.mean(x < 38.0 / 6))
    print(f"\nBTS: {len(x)} cracks, {near:.0%} within D/6 of the loaded diameter "
          f"(tolerance > 50 %; a uniform spread would put ~{2 / 6 * 1.2:.0%} there)")
    assert near > 0.5


def test_ucs_splits_axially(table2_runs):
    """Tensile cracks of the UCS test open sideways: their planes run along the load."""
    from grainfrac.assembly import build_assembly

    cfg = lab_test_config("ucs", seed=0)
    mesh = build_assembly(cfg.specimen_config(), cfg.recipe()).mesh
    rows = np.genfromtxt(table2_runs["ucs"]["dir"] / "cracks.csv", delimiter=",", names=True,
                         dtype=None, encoding="utf-8")
    tensile = rows["mode"] == "tensile"
    xy = np.column_stack((rows["x_mm"], rows["y_mm"]))[tensile] * 1e-3
    # locate each crack's sub-contact by position to read its normal
    d = np.linalg.norm(mesh.contact_xy[None, :, :] - xy[:, None, :], axis=2)
    normal = mesh.contact_normal[np.argmin(d, axis=1)]
    sideways = float(np.mean(np.abs(normal[:, 0])))
    print(f"\nUCS: {int(tensile.sum())} tensile cracks, mean |n_x| of their normals "
          f"{sideways:.2f} (tolerance > 0.64 = random orientation)")
    assert sideways > 2 / math.pi


def test_run_directory_has_curve_cracks_figures_summary(table2_runs):
    d = table2_runs["ucs"]["dir"]
    for name in ("config.toml", "curve.csv", "cracks.csv", "summary.json",
                 "figures/curve.png", "figures/cracks.png"):
        assert (d / name).is_file(), name
    summary = json.loads((d / "summary.json").read_text())
    for key in ("ucs_MPa", "youngs_modulus_GPa", "poisson_ratio", "n_grains", "seed"):
        assert key in summary


# The NSCB cases take 24 s and 17 s: slow, to keep the default suite under 10 min.
NSCB_SLOW = pytest.mark.slow


@pytest.mark.parametrize("test,key", [("ucs", "ucs_MPa"), ("bts", "bts_MPa"),
                                      pytest.param("nscb", "kic_MPa_sqrt_m", marks=NSCB_SLOW)])
def test_halving_the_platen_speed_changes_strength_by_under_3_percent(test, key):
    base = lab_test_config(test, seed=1)
    speed = base.platen_speed_mm_per_s
    values = [measure(lab_test_config(test, seed=1, loading={"platen_speed_mm_per_s": v})
                      )["summary"][key] for v in (speed, speed / 2)]
    change = values[1] / values[0] - 1
    print(f"\n{test}: {key} {values[0]:.4g} at {speed:g} mm/s, {values[1]:.4g} at "
          f"{speed / 2:g} mm/s: change {change:+.2%} (tolerance 3 %)")
    assert abs(change) < 0.03


@pytest.mark.parametrize("test,key,fracture_energy", [
    ("bts", "bts_MPa", 100.0),  # softening contacts, G_I = G_II = 100 J/m2
    pytest.param("nscb", "kic_MPa_sqrt_m", 0.0, marks=NSCB_SLOW),  # brittle contacts
])
def test_strengths_x_f_and_fracture_energies_x_f2_give_f_times_the_strength(
        test, key, fracture_energy):
    """Dimensional similarity of the contact law (Table 2, seed 0): at strength_scale
    0.85, with the platens at 0.85 x the speed so that time maps to time, a test
    gives 0.85 x the strength, within 2 % (measured: 0.04 % for this BTS, 0.05 % for
    this NSCB). Exact in exact arithmetic; rounding can change which bond fails
    first somewhere in a specimen, and the peak follows (measured: BTS 0.2-1.5 % off
    on breakable-grain rocks). The calibration's similarity step rests on this."""
    from grainfrac.calibration import scaled_recipe

    table2 = materials.load_recipe("strathbogie-granite")
    rock = table2.model_copy(update={"contacts": {
        name: c.model_copy(update={"tensile_fracture_energy_J_per_m2": fracture_energy,
                                   "shear_fracture_energy_J_per_m2": fracture_energy})
        for name, c in table2.contacts.items()}})
    values = []
    for f in (1.0, 0.85):
        speed = f * lab_test_config(test).platen_speed_mm_per_s
        recipe = scaled_recipe(rock, {"strength_scale": f})
        values.append(measure(lab_test_config(test, seed=0, rock=recipe, loading={
            "platen_speed_mm_per_s": speed}), recipe=recipe)["summary"][key])
    ratio = values[1] / values[0]
    print(f"\n{test}: {key} {values[0]:.4g} -> {values[1]:.4g} at 0.85 x the strengths: "
          f"ratio {ratio:.4f} (0.85 +- 2 %)")
    assert ratio == pytest.approx(0.85, rel=0.02)


@pytest.mark.xfail(strict=True, reason="with 1000x stiff contacts the test stops at ~6 MPa "
                   "on start-up ringing before the 40-60 % window is sampled (open, issue 6)")
def test_ucs_recovers_the_elastic_constants_of_a_homogeneous_grain_assembly():
    """Unbreakable quartz with very stiff contacts: the UCS machinery returns quartz's E, nu."""
    recipe = materials.homogeneous_recipe("quartz", stiffness_factor=1000.0, unbreakable=True)
    cfg = lab_test_config("ucs", rock=recipe, loading={"max_strain": 0.004})
    s = measure(cfg, recipe=recipe)["summary"]
    e_err = s["youngs_modulus_GPa"] / 27.37 - 1
    nu_err = s["poisson_ratio"] / 0.21 - 1
    print(f"\nE {s['youngs_modulus_GPa']:.3f} GPa (error {e_err:+.2%}), nu "
          f"{s['poisson_ratio']:.4f} (error {nu_err:+.2%}); tolerance 2 %")
    assert not s["peak_found"]
    assert abs(e_err) < 0.02 and abs(nu_err) < 0.02


def test_permeability_scales_with_the_cube_of_the_aperture():
    k = [measure(lab_test_config("permeability", permeability={"initial_aperture_m": a}))
         ["summary"]["permeability_m2"] for a in (2e-7, 4e-7)]
    assert k[1] / k[0] == pytest.approx(8.0, rel=1e-9)


def test_fissured_disk_keeps_its_grains_and_splits_at_a_lower_load(table2_runs):
    """Pre-existing microcracks in a lab specimen (``fissures``): the same grain structure
    with round(f x N) unbonded boundaries, and a Brazilian disk that splits lower."""
    from grainfrac.assembly import build_assembly

    intact = lab_test_config("bts", seed=0)
    fissured = lab_test_config("bts", seed=0, fissures={"fraction": 0.15})
    a, b = (build_assembly(c.specimen_config(), c.recipe()) for c in (intact, fissured))
    np.testing.assert_array_equal(a.mesh.node_xy, b.mesh.node_xy)
    assert not a.interface_fissure.any()
    assert b.interface_fissure.sum() == round(0.15 * b.mesh.n_interfaces)
    assert np.all(b.interface_tensile_strength[b.interface_fissure] == 0.0)
    weak = measure(fissured)["summary"]["bts_MPa"]
    print(f"\nBTS seed 0: intact {table2_runs['bts']['bts_MPa']:.2f} MPa, "
          f"15 % fissures {weak:.2f} MPa")
    assert weak < 0.8 * table2_runs["bts"]["bts_MPa"]


# ---------------------------------------------------------------------------------
# the fast approach
# ---------------------------------------------------------------------------------
def test_the_split_is_looked_for_again_after_going_back_in_time():
    from types import SimpleNamespace

    from grainfrac.labtests.mechanical import SplitMonitor

    r = 0.019
    y = np.arange(-15, 15.5, 1.0) * 1e-3
    xy = np.column_stack((np.zeros_like(y), y))  # contacts along the loaded diameter
    monitor = SplitMonitor(xy, r, 0.0019)
    solver = SimpleNamespace(cracks=SimpleNamespace(contact=[]))
    assert monitor(solver) == 0.0
    solver.cracks.contact = list(range(len(y)))
    assert monitor(solver) == 1.0
    solver.cracks.contact = list(range(len(y) // 2))  # a rewind dropped cracks
    assert monitor(solver) == 0.0


def test_fast_approach_reads_the_fixed_speed_strength_in_fewer_steps():
    """Approaching at 8 x the speed and loading from 75 % of the peak at the test's
    speed reads the strength of the fixed-speed test (2D disc, seed 1; tolerance 1 %)
    in fewer steps, on a curve without the discarded stretch."""
    runs = [measure(lab_test_config("bts", seed=1, loading={"approach_speed_factor": f}))
            for f in (1.0, 8.0)]
    (fixed, fast), (_, curve) = [r["summary"] for r in runs], [r["curve"] for r in runs]
    change = fast["bts_MPa"] / fixed["bts_MPa"] - 1
    total = fast["steps"] + fast["steps_discarded"]
    print(f"\nBTS {fixed['bts_MPa']:.4g} fixed, {fast['bts_MPa']:.4g} fast approach "
          f"({change:+.2%}); steps {fixed['steps']} against {total} "
          f"({fast['steps_discarded']} discarded)")
    assert fixed["steps_discarded"] == 0 and fast["steps_discarded"] > 0
    assert (fixed["approach_speed_factor"], fast["approach_speed_factor"]) == (1.0, 8.0)
    assert abs(change) < 0.01 and total < 0.7 * fixed["steps"]
    assert fast["split_found"]
    closure, time = curve.array("closure"), curve.array("time")
    assert np.all(np.diff(time) > 0) and closure[-1] > closure[fast["peak_index"]]
    assert len(curve.n_cracks) == len(curve.load) == len(curve.extra["split"])
    assert curve.n_cracks[-1] == fast["n_cracks"]


def test_3d_brazilian_and_nscb_tests_approach_fast_by_default():
    for test in ("bts", "nscb"):
        loading = lab_test_config(test, dimension=3).resolved_loading
        assert loading.approach_speed_factor == 8.0
    for test, dimension in (("bts", 2), ("nscb", 2), ("ucs", 3), ("ucs", 2)):
        loading = lab_test_config(test, dimension=dimension).resolved_loading
        assert loading.approach_speed_factor == 1.0


# ---------------------------------------------------------------------------------
# input errors and the CLI
# ---------------------------------------------------------------------------------
@pytest.mark.parametrize("fields,field", [
    ({"test": "bts", "specimen": {"shape": "rectangle"}}, "specimen.shape"),
    ({"test": "ucs", "loading": {"platen_speed_mm_per_s": -1}},
     "loading.platen_speed_mm_per_s"),
    ({"test": "nscb", "loading": {"stop_fraction": 0.6}}, "loading.stop_fraction"),
    ({"test": "permeability", "permeability": {"pressure_in_MPa": 0.0}},
     "permeability.pressure_in_MPa"),
    ({"test": "shear"}, "test"),
    ({"test": "bts", "fissures": {"clear_radius_mm": 5.0}}, "fissures.clear_radius_mm"),
    ({"test": "bts", "loading": {"approach_speed_factor": 0.5}},
     "loading.approach_speed_factor"),
])
def test_bad_lab_test_input_names_the_field(fields, field):
    test = fields.pop("test")
    with pytest.raises(ConfigError) as info:
        lab_test_config(test, **fields)
    message = str(info.value)
    print(f"\n{message}")
    assert field in message and "\n" not in message


def test_cli_labtest_writes_a_run_directory(tmp_path):
    result = CliRunner().invoke(app, ["labtest", "permeability", "--out", str(tmp_path / "k"),
                                      "--seed", "2"])
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "k" / "summary.json").read_text())
    assert summary["seed"] == 2 and summary["permeability_m2"] > 0
    bad = CliRunner().invoke(app, ["labtest", "triaxial", "--out", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "unknown lab test" in bad.output
