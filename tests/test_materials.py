"""Tests of grainfrac.materials: recipes, SI tables, Weibull draws, RDP, fissures."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import tomli_w
from scipy import stats

from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.errors import ConfigError
from grainfrac.io.config import validate
from grainfrac.materials import (
    MINERAL_CODES,
    WEIBULL_CONTACT_PROPERTIES,
    WEIBULL_GRAIN_PROPERTIES,
    ContactTable,
    MineralTable,
    RockRecipe,
    WeibullSpec,
    assign_minerals,
    contact_table,
    load_recipe,
    load_scda,
    mineral_table,
    pair_index,
    preset_names,
    select_fissures,
    weibull_draw,
    weibull_multipliers,
)
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA


@pytest.fixture(scope="module")
def granite() -> RockRecipe:
    return load_recipe("strathbogie-granite")


def _raw(recipe: RockRecipe) -> dict:
    return copy.deepcopy(recipe.model_dump())


def _config_error(data: dict) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        validate(RockRecipe, data)
    err = info.value
    assert "\n" not in str(err), str(err)
    print(str(err))
    return err


# ----------------------------------------------------------------- presets and tables


def test_presets_listed():
    assert "strathbogie-granite" in preset_names()
    assert "scda" in preset_names("scda")
    assert "scda" not in preset_names()


def test_granite_preset_matches_table2(granite):
    assert [m.name for m in granite.minerals] == ["mica", "feldspar", "quartz"]
    minerals = mineral_table(granite)
    assert isinstance(minerals, MineralTable)
    assert minerals.codes == ("M", "F", "Q")
    np.testing.assert_allclose(minerals.youngs_modulus_Pa, np.array([11.73, 15.64, 27.37]) * GPA)
    np.testing.assert_allclose(minerals.poisson_ratio, [0.29, 0.25, 0.21])
    np.testing.assert_allclose(minerals.density_kg_m3, [3050.0, 2620.0, 2650.0])
    np.testing.assert_allclose(minerals.volume_fraction, [0.1634, 0.3268, 0.5098])
    assert granite.weibull == WeibullSpec(scale=1.0, shape=7.0, table_value="scale")


def test_contact_table_mixed_pairs_are_means(granite):
    table = contact_table(granite)
    assert isinstance(table, ContactTable)
    assert table.pair_names == ("M-M", "M-F", "M-Q", "F-F", "F-Q", "Q-Q")
    assert list(table.pair_names) == granite.pair_names()
    mf = table.pair_names.index("M-F")
    assert table.normal_stiffness_Pa_per_m[mf] == pytest.approx((79475 + 113900) / 2 * GPA_PER_M)
    assert table.shear_stiffness_Pa_per_m[mf] == pytest.approx((15130 + 21675) / 2 * GPA_PER_M)
    assert table.friction_angle_rad[mf] == pytest.approx((20.25 + 33.75) / 2 * DEG)
    assert table.cohesion_Pa[mf] == pytest.approx((43.16 + 49.80) / 2 * MPA)
    assert table.tensile_strength_Pa[mf] == pytest.approx((11.20 + 14.56) / 2 * MPA)
    qq = table.pair_names.index("Q-Q")
    assert table.normal_stiffness_Pa_per_m[qq] == pytest.approx(185300 * GPA_PER_M)
    fq = table.pair_names.index("F-Q")
    assert table.tensile_strength_Pa[fq] == pytest.approx((14.56 + 17.92) / 2 * MPA)
    for name in WEIBULL_CONTACT_PROPERTIES:
        assert getattr(table, name).shape == (6,)
    for name in WEIBULL_GRAIN_PROPERTIES:
        assert getattr(mineral_table(granite), name).shape == (3,)


def test_mixed_pair_override_and_key_order_normalised(granite):
    data = _raw(granite)
    data["contacts"]["Q-F"] = dict(data["contacts"]["F-F"], cohesion_MPa=1.0)
    recipe = validate(RockRecipe, data)
    assert "F-Q" in recipe.contacts and "Q-F" not in recipe.contacts
    assert list(recipe.contacts) == ["M-M", "F-F", "F-Q", "Q-Q"]
    table = contact_table(recipe)
    assert table.cohesion_Pa[table.pair_names.index("F-Q")] == pytest.approx(1.0 * MPA)
    assert recipe.contact("Q-F").cohesion_MPa == 1.0


def test_scda_preset_matches_table5():
    scda = load_scda()
    assert scda.density_kg_m3 == 2600.0
    assert scda.youngs_modulus_GPa == 57.0
    assert scda.poisson_ratio == 0.22
    c = scda.contact
    assert (c.normal_stiffness_GPa_per_m, c.shear_stiffness_GPa_per_m) == (217600.0, 41344.0)
    assert (c.friction_angle_deg, c.cohesion_MPa, c.tensile_strength_MPa) == (30.0, 68.0, 16.0)


def test_pair_index_symmetric_and_matches_names(granite):
    n = len(granite.minerals)
    a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    ids = pair_index(a.ravel(), b.ravel(), n)
    np.testing.assert_array_equal(ids, pair_index(b.ravel(), a.ravel(), n))
    names = granite.pair_names()
    codes = [MINERAL_CODES[m.name] for m in granite.minerals]
    for i, j, pid in zip(a.ravel(), b.ravel(), ids, strict=True):
        lo, hi = min(i, j), max(i, j)
        assert names[pid] == f"{codes[lo]}-{codes[hi]}"
    assert sorted(set(ids.tolist())) == list(range(n * (n + 1) // 2))
    # larger n: a bijection onto 0..n(n+1)/2-1 in canonical order
    n = 7
    expected = [(i, j) for i in range(n) for j in range(i, n)]
    got = pair_index(np.array([p[0] for p in expected]), np.array([p[1] for p in expected]), n)
    np.testing.assert_array_equal(got, np.arange(len(expected)))
    with pytest.raises(ValueError):
        pair_index(np.array([0]), np.array([3]), 3)


def test_unknown_preset_lists_presets():
    with pytest.raises(ConfigError) as info:
        load_recipe("basalt")
    assert "strathbogie-granite" in str(info.value)
    assert info.value.field == "recipe"


def test_toml_round_trip(granite, tmp_path):
    path = tmp_path / "my-granite.toml"
    path.write_text(tomli_w.dumps(granite.model_dump()), encoding="utf-8")
    again = load_recipe(path)
    assert again == granite
    assert load_recipe(str(path)) == granite
    scda_path = tmp_path / "agent.toml"
    scda_path.write_text(tomli_w.dumps(load_scda().model_dump()), encoding="utf-8")
    assert load_scda(scda_path) == load_scda()


# ----------------------------------------------------------------- Weibull


def test_weibull_scale_mode_mean_and_shape():
    spec = WeibullSpec()
    x = weibull_multipliers(np.random.default_rng(1), 100_000, spec)
    expected_mean = spec.scale * math.gamma(1 + 1 / spec.shape)
    rel = abs(x.mean() / expected_mean - 1)
    print(f"mean {x.mean():.5f} vs Gamma(1+1/7) {expected_mean:.5f}: rel err {rel:.2e} (tol 5e-3)")
    assert rel < 5e-3
    shape, _, scale = stats.weibull_min.fit(x, floc=0)
    print(f"fitted shape {shape:.4f} (7 +/- 3 %), scale {scale:.4f} (1 +/- 1 %)")
    assert abs(shape / 7 - 1) < 0.03
    assert abs(scale - 1) < 0.01
    assert x.min() > 0


def test_weibull_mean_mode_has_unit_mean():
    spec = WeibullSpec(scale=2.0, shape=7.0, table_value="mean")
    x = weibull_multipliers(np.random.default_rng(2), (1000, 100), spec)
    assert x.shape == (1000, 100)
    rel = abs(x.mean() - 1)
    print(f"mean-mode mean {x.mean():.5f}: err {rel:.2e} (tol 5e-3)")
    assert rel < 5e-3


def test_weibull_deterministic():
    spec = WeibullSpec()
    a = weibull_multipliers(np.random.default_rng(5), 10, spec)
    b = weibull_multipliers(np.random.default_rng(5), 10, spec)
    np.testing.assert_array_equal(a, b)


def test_bounded_draws_stay_below_their_bound_and_valid_draws_are_unchanged():
    """A wide spread (shape 1.5) would give mica (nu 0.29) grains nu > 0.5: those are
    drawn again. Draws already valid are the plain product, so Table 2 is untouched."""
    wide = WeibullSpec(shape=1.5)
    base = np.full(10_000, 0.29)
    plain = base * weibull_multipliers(np.random.default_rng(3), len(base), wide)
    bounded = weibull_draw(base, np.random.default_rng(3), wide, upper=0.5)
    print(f"\nplain draws >= 0.5: {np.count_nonzero(plain >= 0.5)}; "
          f"bounded max {bounded.max():.4f}")
    assert np.count_nonzero(plain >= 0.5) > 100
    assert bounded.max() < 0.5
    valid = plain < 0.5
    np.testing.assert_array_equal(bounded[valid], plain[valid])
    with pytest.raises(ConfigError, match="weibull.shape"):
        weibull_draw(np.array([5.0]), np.random.default_rng(0), WeibullSpec(), upper=0.5)


def test_a_wide_weibull_spread_still_builds_valid_grains_and_contacts(granite):
    data = granite.model_dump(mode="json")
    data["weibull"]["shape"] = 2.0
    wide = RockRecipe.model_validate(data)
    for seed in range(3):
        a = build_assembly(SpecimenConfig(seed=seed, specimen={"shape": "disk"},
                                          grains={"min_edge_mm": 2.0, "max_edge_mm": 5.0,
                                                  "zone_size_mm": 1.25}), wide)
        assert a.grain_poisson_ratio.max() < 0.5
        assert a.interface_friction_angle.max() < 0.5 * math.pi


# ----------------------------------------------------------------- mineral assignment


@pytest.mark.parametrize("seed", range(10))
def test_assign_minerals_meets_targets(granite, seed):
    rng = np.random.default_rng(seed)
    areas = rng.gamma(shape=4.0, scale=77.0 / 4.0, size=130)  # ~130 grains, mm2
    target = mineral_table(granite).volume_fraction
    mineral = assign_minerals(areas, target, np.random.default_rng(seed + 100))
    assert mineral.shape == (130,)
    realised = np.bincount(mineral, weights=areas, minlength=3) / areas.sum()
    err_pp = np.abs(realised - target).max() * 100
    print(f"seed {seed}: realised {np.round(realised * 100, 2)} % target "
          f"{np.round(target * 100, 2)} %: max err {err_pp:.3f} pp (tol 1.5 pp)")
    assert err_pp < 1.5


def test_assign_minerals_deterministic_and_random(granite):
    areas = np.random.default_rng(0).gamma(4.0, 20.0, size=130)
    target = mineral_table(granite).volume_fraction
    a = assign_minerals(areas, target, np.random.default_rng(7))
    b = assign_minerals(areas, target, np.random.default_rng(7))
    c = assign_minerals(areas, target, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_assign_minerals_zero_target_never_used():
    areas = np.random.default_rng(3).gamma(2.0, 1.0, size=200)
    mineral = assign_minerals(areas, np.array([0.5, 0.0, 0.5]), np.random.default_rng(3))
    assert not np.any(mineral == 1)


# ----------------------------------------------------------------- fissures


@pytest.mark.parametrize("fraction", [0.0, 0.05, 0.15, 0.5])
def test_select_fissures_exact_count_and_eligible_only(fraction):
    n = 1003
    rng = np.random.default_rng(11)
    eligible = rng.random(n) > 0.3
    chosen = select_fissures(n, fraction, eligible, np.random.default_rng(12))
    assert chosen.dtype == bool and chosen.shape == (n,)
    assert chosen.sum() == round(fraction * n)
    assert not np.any(chosen & ~eligible)


def test_select_fissures_not_enough_eligible():
    eligible = np.zeros(100, dtype=bool)
    eligible[:10] = True
    with pytest.raises(ConfigError) as info:
        select_fissures(100, 0.15, eligible, np.random.default_rng(0))
    assert info.value.field == "fissures.fraction"
    assert "15" in str(info.value) and "10" in str(info.value)
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigError):
        select_fissures(100, 1.0, np.ones(100, dtype=bool), np.random.default_rng(0))


# ----------------------------------------------------------------- bad recipes


def test_negative_modulus(granite):
    data = _raw(granite)
    data["minerals"][1]["youngs_modulus_GPa"] = -3.0
    err = _config_error(data)
    assert err.field.endswith("youngs_modulus_GPa")
    assert err.field == "minerals.1.youngs_modulus_GPa"
    assert "> 0" in err.message


def test_fractions_not_summing_to_100(granite):
    data = _raw(granite)
    data["minerals"][0]["volume_percent"] = 13.34
    err = _config_error(data)
    assert err.field == "minerals"
    assert "sum to 100" in err.message and "(got 97.0)" in err.message


def test_unknown_mineral(granite):
    data = _raw(granite)
    data["minerals"][2]["name"] = "granite-x"
    err = _config_error(data)
    assert err.field == "minerals.2.name"
    for allowed in MINERAL_CODES:
        assert allowed in err.message
    assert "granite-x" in err.message


def test_missing_like_pair(granite):
    data = _raw(granite)
    del data["contacts"]["Q-Q"]
    err = _config_error(data)
    assert err.field == "contacts.Q-Q"
    assert "quartz" in err.message


def test_pair_of_absent_mineral(granite):
    data = _raw(granite)
    data["contacts"]["F-X"] = data["contacts"]["F-F"]
    assert _config_error(data).field == "contacts.F-X"
    data = _raw(granite)
    data["minerals"] = [dict(data["minerals"][2], volume_percent=100.0)]
    data["contacts"] = {"Q-Q": data["contacts"]["Q-Q"], "M-Q": data["contacts"]["Q-Q"]}
    err = _config_error(data)
    assert err.field == "contacts.M-Q" and "mica" in err.message


def test_unknown_key(granite):
    data = _raw(granite)
    data["minerals"][0]["hardness"] = 3
    err = _config_error(data)
    assert err.field == "minerals.0.hardness"
    data = _raw(granite)
    data["contacts"]["M-M"]["frction_angle_deg"] = 3
    assert _config_error(data).field == "contacts.M-M.frction_angle_deg"


def test_other_ranges(granite):
    data = _raw(granite)
    data["minerals"][0]["poisson_ratio"] = 0.5
    assert _config_error(data).field == "minerals.0.poisson_ratio"
    data = _raw(granite)
    data["contacts"]["F-F"]["friction_angle_deg"] = 90.0
    assert _config_error(data).field == "contacts.F-F.friction_angle_deg"
    data = _raw(granite)
    data["weibull"]["shape"] = 0.0
    assert _config_error(data).field == "weibull.shape"
    data = _raw(granite)
    data["minerals"].append(dict(data["minerals"][0], volume_percent=0.0))
    assert "unique" in _config_error(data).message
