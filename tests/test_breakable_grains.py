"""Breakable grains: every zone a block, grain-interior contacts beside grain boundaries."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from grainfrac.assembly import GrainAssembly, build_specimen
from grainfrac.calibration import CalibrationConfig, calibrate, scaled_recipe
from grainfrac.errors import ConfigError
from grainfrac.geometry.blocks import zone_blocks
from grainfrac.io.config import validate
from grainfrac.materials import RockRecipe, load_recipe, pair_index

INTERIOR = {"tensile_strength_factor": 2.0, "cohesion_factor": 3.0, "stiffness_factor": 1.5,
            "fracture_energy_factor": 0.5}
DISK = {"specimen": {"shape": "disk", "diameter_mm": 38.0},
        "grains": {"min_edge_mm": 2.0, "max_edge_mm": 5.0, "zone_size_mm": 1.25}}


def _rock(weibull: bool = True, **interior) -> dict:
    rock = copy.deepcopy(load_recipe("strathbogie-granite").model_dump())
    rock["intragranular"] = {**INTERIOR, **interior}
    rock["weibull"]["enabled"] = weibull
    for contact in rock["contacts"].values():
        contact["tensile_fracture_energy_J_per_m2"] = 40.0
        contact["shear_fracture_energy_J_per_m2"] = 4.0
    return rock


@pytest.fixture(scope="module")
def grains() -> GrainAssembly:
    return build_specimen({**DISK, "rock": {**_rock(), "intragranular": None}})


@pytest.fixture(scope="module")
def blocks() -> GrainAssembly:
    return build_specimen({**DISK, "rock": _rock()})


def _outer_length(grain_map) -> float:
    """Length of the segments that only one grain (or block) owns: the specimen's outline."""
    ends = np.array([k for k, o in grain_map.segments().items() if len(o) == 1])
    v = grain_map.vertices
    return float(np.hypot(*(v[ends[:, 1]] - v[ends[:, 0]]).T).sum())


def test_the_blocks_tile_the_specimen_and_share_their_faces(grains):
    block_map, block_grain = zone_blocks(grains.mesh)
    assert block_map.n_grains == grains.mesh.n_elements
    assert np.array_equal(block_grain, grains.mesh.element_grain)
    areas = block_map.grain_areas()
    assert np.all(areas > 0)  # counter-clockwise triangles
    assert areas.sum() == pytest.approx(grains.mesh.grains.grain_areas().sum(), rel=1e-12)
    owners = np.array([len(o) for o in block_map.segments().values()])
    assert set(owners) == {1, 2}
    # one owner: exactly the specimen's outline
    boundary = np.array([k for k, o in block_map.segments().items() if len(o) == 1])
    assert np.all(block_map.on_boundary[boundary])
    assert _outer_length(block_map) == pytest.approx(_outer_length(grains.mesh.grains), rel=1e-12)


def test_grain_boundaries_keep_their_properties_and_grains_their_minerals(grains, blocks):
    assert blocks.n_grains == grains.n_grains
    assert np.array_equal(blocks.grain_mineral, grains.grain_mineral[blocks.block_grain])
    inside = blocks.interface_intragranular
    assert 0 < inside.sum() < len(inside)
    ends = blocks.block_grain[blocks.mesh.interface_grains[~inside]]
    index = {tuple(p): i for i, p in enumerate(grains.mesh.interface_grains.tolist())}
    source = np.array([index[(min(a, b), max(a, b))] for a, b in ends.tolist()])
    for name in ("pair", "tensile_strength", "cohesion", "friction_angle", "normal_stiffness",
                 "shear_stiffness", "tensile_fracture_energy"):
        assert np.array_equal(getattr(blocks, f"interface_{name}")[~inside],
                              getattr(grains, f"interface_{name}")[source]), name
    # every grain boundary of the grain-level assembly is still there, in pieces
    assert set(source.tolist()) == set(range(grains.mesh.n_interfaces))
    assert not grains.interface_intragranular.any() and grains.block_grain is None


def test_grain_interiors_take_the_like_pair_times_the_recipe_factors():
    a = build_specimen({**DISK, "rock": _rock(weibull=False)})
    inside = a.interface_intragranular
    mineral = a.grain_mineral[a.mesh.interface_grains[inside, 0]]
    like = pair_index(mineral, mineral, a.mineral_table.n_minerals)
    assert np.array_equal(a.interface_pair[inside], like)
    t = a.contact_table
    for name, table, factor in (
            ("tensile_strength", t.tensile_strength_Pa, 2.0),
            ("cohesion", t.cohesion_Pa, 3.0),
            ("normal_stiffness", t.normal_stiffness_Pa_per_m, 1.5),
            ("shear_stiffness", t.shear_stiffness_Pa_per_m, 1.5),
            ("friction_angle", t.friction_angle_rad, 1.0),
            ("tensile_fracture_energy", t.tensile_fracture_energy_J_per_m2, 0.5),
            ("shear_fracture_energy", t.shear_fracture_energy_J_per_m2, 0.5)):
        np.testing.assert_allclose(getattr(a, f"interface_{name}")[inside], factor * table[like],
                                   rtol=1e-12, err_msg=name)


def test_fissures_stay_on_grain_boundaries():
    a = build_specimen({**DISK, "rock": _rock(), "fissures": {"fraction": 0.2}})
    assert a.interface_fissure.any()
    assert not (a.interface_fissure & a.interface_intragranular).any()


def test_same_seed_same_blocks(blocks):
    again = build_specimen({**DISK, "rock": _rock()})
    for name in ("tensile_strength", "cohesion", "shear_stiffness"):
        assert np.array_equal(getattr(again, f"interface_{name}"),
                              getattr(blocks, f"interface_{name}"))


@pytest.mark.parametrize("field, value, message", [
    ("tensile_strength_factor", 0.0, "must be > 0.0 (got 0.0)"),
    ("cohesion_factor", -1.0, "must be > 0.0 (got -1.0)"),
    ("stiffness_factor", 2000.0, "must be <= 1000"),
])
def test_bad_interior_factors_name_the_field(field, value, message):
    with pytest.raises(ConfigError) as info:
        validate(RockRecipe, _rock(**{field: value}))
    assert f"intragranular.{field}" in str(info.value) and message in str(info.value)


def test_calibration_scales_the_interior_strengths():
    recipe = validate(RockRecipe, _rock())
    scaled = scaled_recipe(recipe, {"grain_tensile_strength": 0.5, "grain_cohesion": 4.0})
    assert scaled.intragranular.tensile_strength_factor == pytest.approx(1.0)
    assert scaled.intragranular.cohesion_factor == pytest.approx(12.0)
    assert scaled.intragranular.stiffness_factor == pytest.approx(1.5)


@pytest.mark.parametrize("asked", [{"factors": {"grain_cohesion": "ucs_MPa"}},
                                   {"factors": ["stiffness"], "start": {"grain_cohesion": 2.0}}])
def test_interior_factors_need_breakable_grains(asked):
    config = validate(CalibrationConfig, {
        "seeds": [0], **asked,
        "targets": {"ucs_MPa": 120.0, "bts_MPa": 6.0, "kic_MPa_sqrt_m": 1.3,
                    "youngs_modulus_GPa": 17.0, "poisson_ratio": 0.24,
                    "permeability_m2": 1e-19}})
    with pytest.raises(ConfigError, match="factors.grain_cohesion: needs breakable grains"):
        calibrate(config, load_recipe("strathbogie-granite"))


def test_example_rock_recipes_are_valid():
    from pathlib import Path

    rocks = sorted((Path(__file__).parents[1] / "examples" / "rocks").glob("*.toml"))
    assert rocks
    for path in rocks:
        assert load_recipe(path).intragranular is not None, path.name


# ---------------------------------------------------------------------------------
# grains are impermeable: intact grain interiors carry no flow
# ---------------------------------------------------------------------------------
RECTANGLE = {"specimen": {"shape": "rectangle", "width_mm": 22.5, "height_mm": 45.0},
             "grains": {"min_edge_mm": 2.0, "max_edge_mm": 5.0, "zone_size_mm": 1.25}}


def test_intact_grain_interiors_leave_the_permeability_of_the_grain_boundaries():
    """The constant-head test on breakable grains with their interiors sealed gives the
    permeability of the same grain structure with whole grains (same seed), to 1e-8:
    the fluid flows along the grain boundaries alone, as in the paper's model. Open
    interiors would conduct too (measured: 9.4 x the permeability at a0 = 100 nm)."""
    from grainfrac.verification.hydraulic import measure_permeability

    whole = build_specimen({**RECTANGLE, "rock": {**_rock(), "intragranular": None}})
    cut = build_specimen({**RECTANGLE, "rock": _rock()})
    a0 = 1.0e-7
    k_whole = measure_permeability(whole.mesh, a0)["permeability_m2"]
    k_sealed = measure_permeability(cut.mesh, a0, sealed=cut.contact_intragranular)
    k_open = measure_permeability(cut.mesh, a0)
    assert k_sealed["permeability_m2"] == pytest.approx(k_whole, rel=1e-8)
    assert k_sealed["outflow_m3_s"] == pytest.approx(k_sealed["flow_rate_m3_s"], rel=1e-6)
    assert k_open["permeability_m2"] > 3.0 * k_whole


def test_a_cracked_grain_interior_conducts(blocks):
    """flow.conducting shuts the pipes of intact sealed faces and opens a face's pipes
    again once one of its sub-contacts has broken."""
    from grainfrac.physics import flow

    mesh = blocks.mesh
    sealed = blocks.contact_intragranular
    every = flow.build_flow_network(mesh, well=False, sealed=sealed)
    bonded = np.ones(mesh.n_contacts, dtype=bool)
    intact = flow.conducting(every, bonded)
    ends = mesh.pipe_contacts[intact.pipe_index]
    assert not (sealed[ends[:, 0]] & sealed[ends[:, 1]]).any()
    assert len(intact.pipe_index) < len(every.pipe_index)
    assert np.array_equal(flow.conducting(every).pipe_index, intact.pipe_index)

    pipe = np.flatnonzero(np.isin(every.pipe_index, intact.pipe_index, invert=True))[0]
    bonded[mesh.pipe_contacts[every.pipe_index[pipe], 0]] = False
    cracked = flow.conducting(every, bonded)
    assert every.pipe_index[pipe] in cracked.pipe_index
    assert len(cracked.pipe_index) > len(intact.pipe_index)
    # whole grains: nothing is sealed and every pipe conducts
    plain = flow.build_flow_network(mesh, well=False, sealed=np.zeros(mesh.n_contacts, bool))
    assert plain.sealed is None and flow.conducting(plain, bonded) is plain


def test_injection_into_breakable_grains_follows_the_bonds_of_the_grain_interiors():
    """The coupled solver lets fluid through a grain interior once it has cracked: its
    conducting pipes follow the mechanics' bond states (a face broken by hand joins
    them at the next step), and the fluid volume balance still closes."""
    from grainfrac.assembly import SpecimenConfig, build_assembly
    from grainfrac.loading.insitu import STRESS_CASES, initialise_in_situ
    from grainfrac.physics import flow
    from grainfrac.physics.coupled import HydroMechanicalSolver
    from grainfrac.physics.model import build_mechanical_model
    from grainfrac.physics.solver import MechanicsSolver
    from grainfrac.units import MPA

    slab = {"shape": "slab", "width_mm": 30.0, "height_mm": 30.0}
    config = validate(SpecimenConfig, {"seed": 1, "specimen": slab, "rock": _rock()})
    assembly = build_assembly(config, config.recipe())
    mesh = assembly.mesh
    mechanics = MechanicsSolver(build_mechanical_model(assembly))
    sx, sy, _ = STRESS_CASES["case2"]
    initialise_in_situ(mechanics, mesh, sx * MPA, sy * MPA)
    network = flow.build_flow_network(mesh, well=True, sealed=assembly.contact_intragranular,
                                      permeable_sides=dict.fromkeys(("left", "right"), 0.0))
    solver = HydroMechanicalSolver(assembly, mechanics, network, flow.FluidProperties())
    n = mesh.n_contacts
    assert np.array_equal(solver.network.pipe_index,
                          flow.conducting(network, mechanics.bonded[:n]).pipe_index)
    shut = np.flatnonzero(~np.isin(network.pipe_index, solver.network.pipe_index))
    assert len(shut) > 0
    face = mesh.contact_interface[mesh.pipe_contacts[network.pipe_index[shut[0]], 0]]
    mechanics.bonded[np.flatnonzero(mesh.contact_interface == face)] = False
    free = ~network.fixed
    held = solver.state.stored(free)
    for _ in range(20):
        solver.advance(1.0e-5, 1.0e-7)
    assert network.pipe_index[shut[0]] in solver.network.pipe_index
    s = solver.state
    assert s.injected > 0 and s.stored(free) - held == pytest.approx(s.injected - s.outflow,
                                                                      rel=1e-9)
