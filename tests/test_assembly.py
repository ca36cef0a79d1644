"""Tests of build_assembly: mineral map, Weibull draws, fissures, determinism, config errors.

Every test measures a property of a real assembly and prints the observed value
next to its tolerance (run ``pytest -s`` to see them).
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
import shapely
import tomli_w

import grainfrac.assembly
from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly, build_specimen
from grainfrac.errors import ConfigError
from grainfrac.io.config import validate
from grainfrac.materials import load_recipe, pair_index

MM = 1e-3
TABLE2_PERCENT = {"mica": 16.34, "feldspar": 32.68, "quartz": 50.98}  # paper Table 2
WEIBULL_MEAN = math.gamma(1.0 + 1.0 / 7.0)  # scale 1, shape 7 (paper Eq. 4)
CLEAR_MM = 15.0



@pytest.fixture(scope="module")
def slab() -> GrainAssembly:
    """The default specimen (seed 0): 100 x 100 mm slab, 10 mm borehole, Strathbogie granite."""
    return build_specimen({})


@pytest.fixture(scope="module")
def fissured(slab) -> dict[float, GrainAssembly]:
    """The default slab with 0 %, 5 % and 15 % fissures outside 15 mm of the well."""
    out = {0.0: slab}
    for fraction in (0.05, 0.15):
        fissures = {"fraction": fraction, "clear_radius_mm": CLEAR_MM}
        out[fraction] = build_specimen({"fissures": fissures})
    return out


@pytest.fixture(scope="module")
def seed1() -> GrainAssembly:
    return build_specimen({"seed": 1})


def _interface_arrays(a: GrainAssembly) -> dict[str, np.ndarray]:
    names = ("pair", "fissure", "normal_stiffness", "shear_stiffness", "friction_angle",
             "cohesion", "tensile_strength")
    out = {f"interface_{n}": getattr(a, f"interface_{n}") for n in names}
    m = a.mesh
    out.update(node_xy=m.node_xy, element_nodes=m.element_nodes, element_grain=m.element_grain,
               grain_mineral=a.grain_mineral, grain_youngs_modulus=a.grain_youngs_modulus,
               interface_grains=m.interface_grains, contact_nodes=m.contact_nodes,
               contact_area=m.contact_area, pipe_nodes=m.pipe_nodes,
               fluid_node_xy=m.fluid_node_xy)
    return out


# ----------------------------------------------------------------- mineral map


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_volume_fractions_match_table2(slab, seed1, seed):
    assembly = {0: slab, 1: seed1}.get(seed) or build_specimen({"seed": seed})
    names = assembly.mineral_table.names
    realised = assembly.volume_fractions() * 100
    target = np.array([TABLE2_PERCENT[n] for n in names])
    # Independent of volume_fractions(): shapely areas of the grain polygons.
    areas = np.array([p.area for p in assembly.mesh.grains.polygons()])
    direct = np.bincount(assembly.grain_mineral, weights=areas, minlength=len(names))
    direct = 100 * direct / areas.sum()
    err = np.abs(realised - target)
    print(f"\n[seed {seed}] grains={assembly.n_grains} realised % "
          + ", ".join(f"{n} {r:.2f} (target {t:.2f})" for n, r, t in
                      zip(names, realised, target, strict=True))
          + f"; max |error|={err.max():.2f} pp (tol 1.5 pp)")
    assert np.abs(direct - realised).max() < 1e-9
    assert err.max() <= 1.5
    assert realised.sum() == pytest.approx(100.0, abs=1e-9)


# ----------------------------------------------------------------- Weibull draws


def test_grain_weibull_multipliers(slab):
    table = slab.mineral_table
    ratios = {
        "youngs_modulus": slab.grain_youngs_modulus / table.youngs_modulus_Pa[slab.grain_mineral],
        "poisson_ratio": slab.grain_poisson_ratio / table.poisson_ratio[slab.grain_mineral],
        "density": slab.grain_density / table.density_kg_m3[slab.grain_mineral],
    }
    print(f"\n[grain Weibull] n={slab.n_grains}, expected mean Gamma(1+1/7)={WEIBULL_MEAN:.4f} "
          "(tol 5 %)")
    for name, x in ratios.items():
        rel = abs(x.mean() / WEIBULL_MEAN - 1)
        print(f"  {name}: mean={x.mean():.4f} (rel. error {rel:.3f}) std={x.std():.4f} "
              f"min={x.min():.3f} max={x.max():.3f}")
        assert rel < 0.05, name
        assert np.all(x > 0)
    # The three properties draw independent multipliers.
    corr = np.corrcoef(np.vstack(list(ratios.values())))
    off = np.abs(corr[np.triu_indices(3, 1)]).max()
    print(f"  max |correlation| between properties={off:.3f} (< 0.3)")
    assert off < 0.3
    # The element view is the grain value.
    assert np.array_equal(slab.element_youngs_modulus,
                          slab.grain_youngs_modulus[slab.mesh.element_grain])


def test_interface_weibull_multipliers(slab):
    m = slab.mesh
    table = slab.contact_table
    names = slab.mineral_table.codes
    # Pair id recomputed from the two grains' minerals, by name.
    pair_names = [
        "-".join(sorted((names[slab.grain_mineral[a]], names[slab.grain_mineral[b]]),
                        key=names.index))
        for a, b in m.interface_grains.tolist()
    ]
    expected_pair = np.array([table.pair_names.index(p) for p in pair_names])
    assert np.array_equal(slab.interface_pair, expected_pair)
    assert np.array_equal(
        slab.interface_pair,
        pair_index(slab.grain_mineral[m.interface_grains[:, 0]],
                   slab.grain_mineral[m.interface_grains[:, 1]], len(names)),
    )
    ok = ~slab.interface_fissure
    fields = {
        "tensile_strength": "tensile_strength_Pa",
        "cohesion": "cohesion_Pa",
        "normal_stiffness": "normal_stiffness_Pa_per_m",
        "shear_stiffness": "shear_stiffness_Pa_per_m",
        "friction_angle": "friction_angle_rad",
    }
    print(f"\n[interface Weibull] n={int(ok.sum())} non-fissured interfaces, pairs used "
          f"{sorted(set(pair_names))}; expected mean {WEIBULL_MEAN:.4f} (tol 5 %)")
    for name, column in fields.items():
        x = getattr(slab, f"interface_{name}")[ok] / getattr(table, column)[slab.interface_pair[ok]]
        rel = abs(x.mean() / WEIBULL_MEAN - 1)
        print(f"  {name}: mean={x.mean():.4f} (rel. error {rel:.3f}) std={x.std():.4f}")
        assert rel < 0.05, name
    # Sub-contacts see their interface's value.
    assert np.array_equal(slab.contact_view("tensile_strength"),
                          slab.interface_tensile_strength[m.contact_interface])


# ----------------------------------------------------------------- fissures


@pytest.mark.parametrize("fraction", [0.05, 0.15])
def test_fissures(fissured, fraction):
    a = fissured[fraction]
    f = a.interface_fissure
    realised = f.mean()
    dist = a.interface_distance_to((0.0, 0.0))
    # Independent distance: shapely distance from the well centre to the shared boundary.
    polys = a.mesh.grains.polygons()
    shared = [shapely.intersection(polys[i].boundary, polys[j].boundary)
              for i, j in a.mesh.interface_grains[f].tolist()]
    dist_shapely = shapely.distance(shapely.Point(0.0, 0.0), shared)
    nearest = dist[f].min() / MM
    print(f"\n[fissures {fraction:g}] {int(f.sum())} of {len(f)} interfaces: realised "
          f"{100 * realised:.2f} % (target {100 * fraction:g} +- 0.5 pp); nearest fissure to "
          f"the well {nearest:.2f} mm (shapely {dist_shapely.min() / MM:.2f}; must be > "
          f"{CLEAR_MM:g}); interfaces within {CLEAR_MM:g} mm: {int((dist <= CLEAR_MM * MM).sum())}")
    assert abs(realised - fraction) <= 0.005
    assert np.all(dist[f] > CLEAR_MM * MM)
    assert np.abs(dist[f] - dist_shapely).max() < 1e-12
    assert np.all(a.interface_cohesion[f] == 0) and np.all(a.interface_tensile_strength[f] == 0)
    assert np.all(a.interface_cohesion[~f] > 0) and np.all(a.interface_tensile_strength[~f] > 0)
    # Fissures keep their stiffness and friction.
    assert np.all(a.interface_normal_stiffness[f] > 0)
    assert np.all(a.interface_friction_angle[f] > 0)


def test_fissure_fraction_keeps_grain_structure(fissured):
    base = fissured[0.0]
    for fraction in (0.05, 0.15):
        a = fissured[fraction]
        same = {
            "node_xy": np.array_equal(a.mesh.node_xy, base.mesh.node_xy),
            "element_nodes": np.array_equal(a.mesh.element_nodes, base.mesh.element_nodes),
            "interface_grains": np.array_equal(a.mesh.interface_grains,
                                               base.mesh.interface_grains),
            "grain_mineral": np.array_equal(a.grain_mineral, base.grain_mineral),
            "grain_youngs_modulus": np.array_equal(a.grain_youngs_modulus,
                                                   base.grain_youngs_modulus),
            "interface_normal_stiffness": np.array_equal(a.interface_normal_stiffness,
                                                         base.interface_normal_stiffness),
            "tensile_strength (non-fissured)": np.array_equal(
                a.interface_tensile_strength[~a.interface_fissure],
                base.interface_tensile_strength[~a.interface_fissure]),
        }
        print(f"\n[fissures 0 vs {fraction:g}] identical: {same}")
        assert all(same.values())
    # The 5 % and 15 % runs pick different fissure sets.
    assert not np.array_equal(fissured[0.05].interface_fissure, fissured[0.15].interface_fissure)


def test_clear_radius_needs_a_borehole():
    with pytest.raises(ConfigError) as info:
        build_specimen({"specimen": {"shape": "disk"},
                "fissures": {"fraction": 0.05, "clear_radius_mm": 5}})
    print(f"\n[disk + clear radius] {info.value}")
    assert info.value.field == "fissures.clear_radius_mm"


# ----------------------------------------------------------------- determinism


def test_same_seed_same_assembly_different_seed_differs(slab, seed1):
    again = build_specimen({"seed": 0})
    a, b, c = _interface_arrays(slab), _interface_arrays(again), _interface_arrays(seed1)
    equal = {k: np.array_equal(a[k], b[k]) for k in a}
    differs = {k: not (a[k].shape == c[k].shape and np.array_equal(a[k], c[k]))
               for k in ("node_xy", "grain_mineral", "interface_grains", "grain_youngs_modulus")}
    print(f"\n[determinism] seed 0 twice identical: {all(equal.values())} "
          f"({sum(equal.values())}/{len(equal)} arrays); seed 1 differs: {differs}")
    assert all(equal.values()), [k for k, v in equal.items() if not v]
    assert all(differs.values())


# ----------------------------------------------------------------- config errors


def _rock(**changes) -> dict:
    """The Strathbogie preset as an inline dict with the first mineral changed."""
    rock = copy.deepcopy(load_recipe("strathbogie-granite").model_dump())
    rock["minerals"][0].update(changes)
    return rock


@pytest.fixture()
def no_compute(monkeypatch):
    """Make any tessellation fail loudly: a ConfigError must come before compute."""

    def _forbidden(*args, **kwargs):
        raise AssertionError("tessellate called before the config was validated")

    monkeypatch.setattr(grainfrac.assembly, "tessellate", _forbidden)


def _pipeline(data: dict) -> GrainAssembly:
    cfg = validate(SpecimenConfig, data)
    return build_assembly(cfg, cfg.recipe())


def _config_error(data: dict) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        _pipeline(data)
    err = info.value
    print(f"\n[config error] {err}")
    assert "\n" not in str(err)
    assert str(err).startswith(f"config error at {err.field}: ")
    return err


def test_no_compute_patch_is_effective(no_compute):
    with pytest.raises(AssertionError, match="tessellate called"):
        _pipeline({})


@pytest.mark.parametrize(
    ("rock", "field_part", "message_part"),
    [
        pytest.param(_rock(youngs_modulus_GPa=-1), "youngs_modulus_GPa", "must be > 0",
                     id="negative-modulus"),
        pytest.param(_rock(volume_percent=20.0), "minerals", "sum to 100", id="fractions-sum"),
        pytest.param(_rock(name="olivine"), "minerals.0.name", "mica, feldspar, quartz",
                     id="unknown-mineral"),
    ],
)
def test_inline_recipe_errors(no_compute, rock, field_part, message_part):
    err = _config_error({"rock": rock})
    assert field_part in err.field
    assert message_part in err.message


@pytest.mark.parametrize(
    ("rock", "field_part", "message_part"),
    [
        (_rock(youngs_modulus_GPa=-1), "minerals.0.youngs_modulus_GPa", "must be > 0"),
        (_rock(volume_percent=20.0), "minerals", "must sum to 100 (got 103.66)"),
        (_rock(name="olivine"), "minerals.0.name", "allowed: mica, feldspar, quartz"),
    ],
    ids=["negative-modulus", "fractions-sum", "unknown-mineral"],
)
def test_recipe_file_errors(no_compute, tmp_path, rock, field_part, message_part):
    path = tmp_path / "rock.toml"
    path.write_bytes(tomli_w.dumps(rock).encode())
    err = _config_error({"rock": str(path)})
    assert field_part in err.field
    assert message_part in err.message


@pytest.mark.parametrize(
    ("data", "field", "message_part"),
    [
        ({"grains": {"min_edge_mm": 9, "max_edge_mm": 8}}, "grains", "< max_edge_mm (8), got 9"),
        ({"grains": {"zone_size_mm": -1}}, "grains.zone_size_mm", "must be > 0"),
        ({"specimen": {"shape": "slab", "borehole_diameter_mm": 60}}, "specimen",
         "< half the smallest side (50 mm), got 60"),
        ({"specimen": {"shape": "cube"}}, "specimen", "'slab', 'disk', 'semi_disk', 'rectangle'"),
        ({"fissures": {"fraction": 1.5}}, "fissures.fraction", "must be < 1"),
        ({"seed": -1}, "seed", "must be >= 0"),
        ({"sead": 1}, "sead", "did you mean 'seed'"),
        ({"grains": {"min_edge": 3}}, "grains.min_edge", "did you mean 'min_edge_mm'"),
        ({"rock": "no-such-rock"}, "", "presets: strathbogie-granite"),
        ({"fissures": {"fraction": 0.1, "clear_radius_mm": 60}}, "",
         "must be < half the smallest side (50 mm)"),
    ],
    ids=["min>max-edge", "zone<0", "borehole-too-big", "unknown-shape", "fissure-fraction",
         "negative-seed", "unknown-key", "unknown-nested-key", "unknown-preset",
         "clear-radius-too-big"],
)
def test_config_errors_before_compute(no_compute, data, field, message_part):
    err = _config_error(data)
    assert err.field.startswith(field)
    assert message_part in err.message



@pytest.mark.parametrize(
    ("data", "field"),
    [
        pytest.param({"rock": "no-such-rock"}, "rock", id="unknown-preset"),
        pytest.param({"fissures": {"fraction": 0.1, "clear_radius_mm": 60}},
                     "fissures.clear_radius_mm", id="clear-radius-too-big"),
    ],
)
def test_config_error_names_the_config_key(no_compute, data, field):
    assert _config_error(data).field == field


def test_clear_radius_without_borehole_fails_before_compute(no_compute):
    _config_error({"specimen": {"shape": "disk"},
                   "fissures": {"fraction": 0.05, "clear_radius_mm": 5}})
