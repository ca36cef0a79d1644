"""Scenario files: examples validate, resolved configs round-trip, bad input fails early.

Fast: nothing here builds an assembly or runs a solver.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import pytest
import tomli_w

from grainfrac.assembly import SpecimenConfig
from grainfrac.errors import ConfigError
from grainfrac.io.config import validate
from grainfrac.loading.insitu import STRESS_CASES
from grainfrac.materials import RockRecipe, ScdaRecipe, load_recipe
from grainfrac.physics.flow import FluidProperties
from grainfrac.scenario import (
    STAGE_KINDS,
    InjectStage,
    InSituStress,
    ScdaStage,
    Scenario,
    default_inject_duration_ms,
    hs_only,
    hybrid,
    load_scenario,
    resolved_dict,
    write_resolved,
)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
EXAMPLE_FILES = sorted(EXAMPLES.glob("*.toml")) + sorted((EXAMPLES / "3d").glob("*.toml"))
EXPECTED_EXAMPLES = (
    [f"scda-case{i}.toml" for i in range(1, 5)]
    + [f"hs-case{i}-18mlmin.toml" for i in range(1, 5)]
    + ["hs-only-case2-90mlmin.toml", "hybrid-case2-90mlmin.toml",
       "hybrid-case2-90mlmin-fissures15.toml"]
)

EQ = {"kind": "equilibrate"}
INJECT = {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 8.0}
SCDA = {"kind": "scda"}
DRILL = {"kind": "drill_out"}


def _has_none(value) -> bool:
    if value is None:
        return True
    if isinstance(value, dict):
        return any(_has_none(v) for v in value.values())
    if isinstance(value, list | tuple):
        return any(_has_none(v) for v in value)
    return False


# ----------------------------------------------------------------------------- examples


def test_expected_examples_exist():
    names = {p.name for p in EXAMPLE_FILES}
    missing = sorted(set(EXPECTED_EXAMPLES) - names)
    assert not missing, missing


@pytest.mark.parametrize("path", EXAMPLE_FILES, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_example_validates_and_round_trips(path, tmp_path):
    scenario, recipe = load_scenario(path)
    assert isinstance(recipe, RockRecipe)
    assert path.read_text(encoding="utf-8").startswith("# "), "comment header citing the paper"
    assert "Fig." in path.read_text(encoding="utf-8").split("\nname")[0]
    assert scenario.stages[0].kind == "equilibrate"
    written = write_resolved(tmp_path / "config.toml", scenario, recipe)
    again, recipe2 = load_scenario(written)
    assert again == scenario.resolved(recipe)
    assert recipe2 == recipe
    assert resolved_dict(again, recipe2) == resolved_dict(scenario, recipe)


def test_examples_match_paper_designs():
    for i in range(1, 5):
        case = f"case{i}"
        scda, _ = load_scenario(EXAMPLES / f"scda-{case}.toml")
        assert scda.stage_kinds == ("equilibrate", "scda")
        assert scda.stress.resolved() == STRESS_CASES[case][:2]
        assert scda.stages[1].peak_pressure_MPa == 45.0
        hs, _ = load_scenario(EXAMPLES / f"hs-{case}-18mlmin.toml")
        assert hs.stage_kinds == ("equilibrate", "inject")
        assert hs.stages[1].rate_ml_per_min == 18.0
        assert hs.stages[1].duration_ms == default_inject_duration_ms(18.0)
        assert hs.stress.case == case
    hs90, _ = load_scenario(EXAMPLES / "hs-only-case2-90mlmin.toml")
    hyb, _ = load_scenario(EXAMPLES / "hybrid-case2-90mlmin.toml")
    fis, _ = load_scenario(EXAMPLES / "hybrid-case2-90mlmin-fissures15.toml")
    assert hs90.stage_kinds == ("equilibrate", "inject")
    assert hyb.stage_kinds == fis.stage_kinds == ("equilibrate", "scda", "drill_out", "inject")
    assert fis.fissures.fraction == 0.15 and fis.fissures.clear_radius_mm == 10.0
    # The presets are the same designs as the example files.
    assert hs_only().stages == hs90.stages
    assert hybrid().stages == hyb.stages
    assert hybrid(fissures={"fraction": 0.15, "clear_radius_mm": 10.0}).fissures == fis.fissures


# ----------------------------------------------------------------------------- defaults


def test_defaults_round_trip(tmp_path):
    scenario = validate(Scenario, {"stages": [EQ]})
    assert scenario.stress.case == "case2"
    assert scenario.stress.resolved() == (2.5, 5.0)
    assert scenario.fluid.permeable_sides == ["left", "right", "top", "bottom"]
    recipe = scenario.recipe()
    data = resolved_dict(scenario, recipe)
    assert not _has_none(data)
    assert data["stress"] == {"case": "case2", "sigma_x_MPa": 2.5, "sigma_y_MPa": 5.0,
                              "sigma_z_MPa": 1.0}
    assert isinstance(data["rock"], dict) and data["rock"]["name"] == "strathbogie-granite"
    again = validate(Scenario, tomllib.loads(tomli_w.dumps(data)))
    assert again == scenario.resolved(recipe)
    assert again.specimen_config() == validate(SpecimenConfig, {"rock": data["rock"]})
    # Writing through the atomic writer gives the same file content.
    path = write_resolved(tmp_path / "config.toml", scenario, recipe)
    assert tomllib.loads(path.read_text(encoding="utf-8")) == data


def test_resolved_dict_has_no_none_and_resolves_stress():
    scenario = validate(Scenario, {
        "stress": {"sigma_x_MPa": 3.0, "sigma_y_MPa": 7.5},
        "stages": [EQ, SCDA, DRILL, {"kind": "inject", "rate_ml_per_min": 18.0,
                                     "volume_ml": 0.01}],
    })
    data = resolved_dict(scenario, scenario.recipe())
    assert not _has_none(data)
    assert data["stress"] == {"sigma_x_MPa": 3.0, "sigma_y_MPa": 7.5}  # case None: omitted
    assert "duration_ms" not in data["stages"][3]
    assert isinstance(data["stages"][1]["scda"], dict)  # SCDA material inline (Table 5)
    assert data["stages"][1]["scda"]["youngs_modulus_GPa"] == 57.0
    again = validate(Scenario, tomllib.loads(tomli_w.dumps(data)))
    assert again.stress.case is None and again.stress.resolved() == (3.0, 7.5)
    assert again == scenario.resolved(scenario.recipe())


def test_stress_cases_and_values():
    for case, (sx, sy, _) in STRESS_CASES.items():
        assert InSituStress(case=case).resolved() == (sx, sy)
    assert InSituStress(sigma_x_MPa=1.5, sigma_y_MPa=2.0).case is None
    # A case with matching values (a resolved file) is accepted as is.
    assert InSituStress(case="case4", sigma_x_MPa=1.0, sigma_y_MPa=5.0).resolved() == (1.0, 5.0)
    assert InSituStress().resolved_Pa() == (2.5e6, 5.0e6)


def test_si_views():
    scenario = hybrid()
    fluid = scenario.fluid.properties()
    assert fluid == FluidProperties()
    assert scenario.fluid.well_compressibility == pytest.approx(1 / 2.0e9)
    assert scenario.fluid.fixed_pressures() == dict.fromkeys(("left", "right", "top", "bottom"),
                                                             0.0)
    inject = scenario.stages[-1]
    assert isinstance(inject, InjectStage)
    assert inject.rate == pytest.approx(1.5e-6)
    assert inject.planned_duration_s == pytest.approx(12e-3)
    limited = InjectStage(rate_ml_per_min=60.0, duration_ms=100.0, volume_ml=0.005)
    assert limited.planned_duration_s == pytest.approx(0.005e-6 / 1e-6)  # 5 ms by volume
    scda = scenario.stages[1]
    assert isinstance(scda, ScdaStage)
    assert isinstance(scda.material(), ScdaRecipe)
    assert scda.velocity(0.0) == pytest.approx(5e-3)  # default f = 5 mm/s
    assert scda.velocity(0.05) == pytest.approx(5e-3 * 2.718281828 ** -1)


def test_presets():
    hs = hs_only()
    hy = hybrid()
    assert hs.stage_kinds == ("equilibrate", "inject")
    assert hy.stage_kinds == ("equilibrate", "scda", "drill_out", "inject")
    assert hs.stages[-1].rate_ml_per_min == hy.stages[-1].rate_ml_per_min == 90.0
    assert hs.stages[-1].duration_ms == hy.stages[-1].duration_ms == 12.0
    assert default_inject_duration_ms(18.0) == pytest.approx(60.0)
    assert hs_only(18.0, "case4").stages[-1].duration_ms == pytest.approx(60.0)
    assert hs_only(18.0, "case4").stress.resolved() == (1.0, 5.0)
    assert hybrid(duration_ms=10.0, seed=3).stages[-1].duration_ms == 10.0
    assert hybrid(seed=3).seed == 3 == hy.with_seed(3).seed
    with pytest.raises(ConfigError) as err:
        hs_only(-5.0)
    assert err.value.field == "rate_ml_per_min"


def test_load_resolves_paths_relative_to_file(tmp_path, monkeypatch):
    (tmp_path / "materials").mkdir()
    rock = load_recipe("strathbogie-granite").model_dump(mode="json")
    (tmp_path / "materials" / "rock.toml").write_text(tomli_w.dumps(rock))
    scda = ScdaStage().material().model_dump(mode="json")
    scda["youngs_modulus_GPa"] = 40.0
    (tmp_path / "materials" / "scda-soft.toml").write_text(tomli_w.dumps(scda))
    (tmp_path / "run.toml").write_text(tomli_w.dumps({
        "rock": "materials/rock.toml",
        "stages": [EQ, {"kind": "scda", "scda": "materials/scda-soft.toml"}],
    }))
    monkeypatch.chdir(tmp_path.parent)
    scenario, recipe = load_scenario(tmp_path / "run.toml")
    assert recipe.name == "strathbogie-granite"
    assert Path(scenario.stages[1].scda).is_absolute()
    assert scenario.stages[1].material().youngs_modulus_GPa == 40.0
    data = resolved_dict(scenario, recipe)
    assert data["stages"][1]["scda"]["youngs_modulus_GPa"] == 40.0


# ----------------------------------------------------------------------------- bad input

BAD = {
    "unknown stage": (
        {"stages": [EQ, {"kind": "frack"}]},
        "stages.1.kind", ["unknown stage 'frack'", "equilibrate, scda, drill_out, inject"],
    ),
    "missing kind": ({"stages": [EQ, {"rate_ml_per_min": 5.0}]}, "stages.1.kind", ["allowed"]),
    "negative rate": (
        {"stages": [EQ, {**INJECT, "rate_ml_per_min": -18.0}]},
        "stages.1.rate_ml_per_min", ["> 0"],
    ),
    "missing rate": (
        {"stages": [EQ, {"kind": "inject", "duration_ms": 8.0}]},
        "stages.1.rate_ml_per_min", ["required"],
    ),
    "no duration nor volume": (
        {"stages": [EQ, {"kind": "inject", "rate_ml_per_min": 18.0}]},
        "stages.1.duration_ms", ["volume_ml"],
    ),
    "peak pressure 0": (
        {"stages": [EQ, {"kind": "scda", "peak_pressure_MPa": 0.0}]},
        "stages.1.peak_pressure_MPa", ["> 0"],
    ),
    "unknown stage key": (
        {"stages": [EQ, {"kind": "scda", "peak_MPa": 45.0}]}, "stages.1.peak_MPa",
        ["unknown key 'peak_MPa'", "did you mean 'peak_pressure_MPa'?"],
    ),
    "inject before equilibrate": (
        {"stages": [INJECT, EQ]}, "stages.0.kind", ["inject must come after equilibrate"],
    ),
    "second equilibrate": ({"stages": [EQ, INJECT, EQ]}, "stages.2.kind", ["first stage"]),
    "inject right after scda": (
        {"stages": [EQ, SCDA, INJECT]}, "stages.2.kind", ["inject must come after drill_out"],
    ),
    "drill_out without scda": (
        {"stages": [EQ, DRILL, INJECT]}, "stages.1.kind", ["drill_out must come after an scda"],
    ),
    "two scda stages": ({"stages": [EQ, SCDA, DRILL, SCDA]}, "stages.3.kind", ["only one scda"]),
    "scda after inject": ({"stages": [EQ, INJECT, SCDA]}, "stages.2.kind", ["before any inject"]),
    "scda on a disk": (
        {"specimen": {"shape": "disk"}, "stages": [EQ, SCDA]}, "stages.1.kind", ["borehole"],
    ),
    "inject without borehole": (
        {"specimen": {"shape": "slab", "borehole_diameter_mm": 0.0}, "stages": [EQ, INJECT]},
        "specimen.borehole_diameter_mm", ["> 0"],
    ),
    "equilibrate on a disk": (
        {"specimen": {"shape": "disk"}, "stages": [EQ]}, "specimen.shape",
        ["slab, rectangle or hollow cylinder"],
    ),
    "both case and values in stress": (
        {"stress": {"case": "case1", "sigma_x_MPa": 2.0, "sigma_y_MPa": 4.0}, "stages": [EQ]},
        "stress", ["not both"],
    ),
    "one stress value": ({"stress": {"sigma_x_MPa": 2.0}, "stages": [EQ]},
                         "stress.sigma_y_MPa", ["required"]),
    "unknown stress case": ({"stress": {"case": "case5"}, "stages": [EQ]}, "stress.case", []),
    "negative stress": ({"stress": {"sigma_x_MPa": -1.0, "sigma_y_MPa": 1.0}, "stages": [EQ]},
                        "stress.sigma_x_MPa", [">= 0"]),
    "bad permeable side": (
        {"fluid": {"permeable_sides": ["left", "front"]}, "stages": [EQ]},
        "fluid.permeable_sides", ["'front'", "left, right, top, bottom"],
    ),
    "borehole is not a permeable side": (
        {"fluid": {"permeable_sides": ["borehole"]}, "stages": [EQ]}, "fluid.permeable_sides", [],
    ),
    "a_res > a0": (
        {"fluid": {"residual_aperture_m": 5e-7}, "stages": [EQ]},
        "fluid.residual_aperture_m", ["initial_aperture_m"],
    ),
    "a0 >= a_max": (
        {"fluid": {"initial_aperture_m": 3e-5}, "stages": [EQ]},
        "fluid.initial_aperture_m", ["maximum_aperture_m"],
    ),
    "zero viscosity": ({"fluid": {"viscosity_Pa_s": 0.0}, "stages": [EQ]},
                       "fluid.viscosity_Pa_s", ["> 0"]),
    "drill-out step limit below its minimum": (
        {"stages": [EQ, SCDA, {"kind": "drill_out", "relax_steps": 5000, "max_steps": 1000}]},
        "stages.2.max_steps", [">= relax_steps (5000)"],
    ),
    "no stages": ({"stages": []}, "stages", []),
    "stages missing": ({}, "stages", ["required"]),
    "clear radius too large": (
        {"fissures": {"fraction": 0.15, "clear_radius_mm": 60.0}, "stages": [EQ]},
        "fissures.clear_radius_mm", [],
    ),
    "unknown top-level key": ({"stages": [EQ], "injection": {}}, "injection",
                              ["unknown key 'injection'", "allowed: dimension, fissures"]),
    "unknown rock preset": ({"rock": "basalt", "stages": [EQ]}, "rock", ["basalt"]),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_scenario_fails_with_named_field(case, tmp_path):
    data, field, fragments = BAD[case]
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps(copy.deepcopy(data)))
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    message = str(err.value)
    print(f"\n{case}: {message}")
    assert "\n" not in message
    assert err.value.field == field
    assert message.startswith(f"config error at {field}: ")
    for fragment in fragments:
        assert fragment in err.value.message


def test_unknown_scda_preset_is_named(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(tomli_w.dumps({"stages": [EQ, {"kind": "scda", "scda": "gypsum"}]}))
    with pytest.raises(ConfigError) as err:
        load_scenario(path)
    assert err.value.field == "stages.1.scda"
    assert "gypsum" in err.value.message


def test_stage_kinds_listed():
    assert STAGE_KINDS == ("equilibrate", "scda", "drill_out", "inject")


def test_broken_residual_aperture_option():
    from grainfrac.errors import ConfigError
    from grainfrac.io.config import validate as _validate

    base = {"stages": [{"kind": "equilibrate"}]}
    sc = _validate(Scenario, {**base, "fluid": {"broken_residual_aperture_m": 2e-6}})
    assert sc.fluid.properties().broken_residual_aperture == 2e-6
    assert _validate(Scenario, base).fluid.properties().broken_residual_aperture is None
    with pytest.raises(ConfigError) as info:
        _validate(Scenario, {**base, "fluid": {"broken_residual_aperture_m": 1e-3}})
    assert info.value.field == "fluid.broken_residual_aperture_m"


def test_rock_initial_aperture_is_used_unless_the_fluid_sets_one():
    """A calibrated recipe carries a0 (hydraulic.initial_aperture_m); scenarios use it."""
    from grainfrac import materials
    from grainfrac.scenario import hs_only

    rock = materials.load_recipe("strathbogie-granite").model_copy(
        update={"hydraulic": materials.HydraulicSpec(initial_aperture_m=1.5e-7)})
    scenario = hs_only(rock=rock)
    props = scenario.fluid.properties(rock.hydraulic.initial_aperture_m)
    assert props.initial_aperture == 1.5e-7
    assert props.residual_aperture == 1.5e-7  # an unset a_res follows a0 down
    resolved = scenario.resolved(rock)
    assert resolved.fluid.initial_aperture_m == 1.5e-7
    explicit = hs_only(rock=rock, fluid={"initial_aperture_m": 2.5e-7})
    assert explicit.fluid.properties(1.5e-7).initial_aperture == 2.5e-7
