"""SCDA in 3D: the tetrahedral plug, its free expansion, its pressure on an elastic rock
(Lame) and a short hybrid scenario (charge, drill out, inject) on a small slab."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import meshio
import numpy as np
import pytest

from grainfrac import materials
from grainfrac.assembly import build_specimen
from grainfrac.geometry.mesh import contact_frame, tet_volumes
from grainfrac.geometry.meshing3d import tet_quality
from grainfrac.io.config import validate
from grainfrac.physics import scda
from grainfrac.physics.model import model_from_arrays
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.scenario import Scenario, load_scenario
from grainfrac.simulation import run_scenario
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA

# Seed 0: Qhull leaves flat tetrahedra on the wall facets here, which the fill drops.
SLAB = {"dimension": 3, "seed": 0,
        "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30, "thickness_mm": 8}}


@pytest.fixture(scope="module")
def slab():
    return build_specimen(SLAB)


@pytest.fixture(scope="module")
def fill(slab):
    return scda.scda_fill(slab, materials.load_scda("scda"))


def _lateral_area(slab) -> float:
    solid = slab.mesh.grains.solid
    n = solid.borehole_facets
    return n * 2.0 * solid.borehole_radius * math.sin(math.pi / n) * slab.mesh.borehole_length


def test_plug_tetrahedra_fill_the_faceted_borehole(slab, fill):
    mesh = slab.mesh
    p = fill.node_xy[fill.element_nodes]
    volume = tet_volumes(p)
    exact = mesh.grains.solid.borehole_area * mesh.borehole_length
    quality = tet_quality(p)
    print(f"\n{len(volume)} blocks, volume {volume.sum():.6e} m3 vs prism {exact:.6e} m3 "
          f"(rel. {volume.sum() / exact - 1:.1e}); smallest {volume.min() / mesh.zone_size**3:.3f}"
          f" zone^3, quality min {quality.min():.3f} median {np.median(quality):.3f}")
    assert fill.dimension == 3 and fill.element_nodes.shape[1] == 4
    assert np.all(volume > 0)
    assert volume.sum() == pytest.approx(exact, rel=1e-9)
    assert quality.min() > 0.1  # no slivers: their lattice points were moved
    # Every block on its own four nodes.
    assert np.array_equal(np.sort(fill.element_nodes.ravel()), np.arange(4 * len(volume)))


def test_wall_sub_contacts_pair_coincident_nodes_and_cover_the_wall(slab, fill):
    mesh = slab.mesh
    solid = mesh.grains.solid
    wall_tri = mesh.surface_triangles["borehole"]
    c = mesh.node_x[wall_tri]
    rock_wall_area = 0.5 * np.linalg.norm(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]),
                                          axis=1).sum()
    lateral = _lateral_area(slab)
    print(f"\n{fill.n_wall} wall sub-contacts, area {fill.wall_area.sum():.6e} m2 vs lateral "
          f"{lateral:.6e} m2 (rel. {fill.wall_area.sum() / lateral - 1:.1e}); "
          f"{len(fill.joint_area)} block sub-contacts")
    assert fill.wall_area.sum() == pytest.approx(lateral, rel=1e-9)
    assert rock_wall_area == pytest.approx(lateral, rel=1e-9)
    assert np.all(fill.wall_area > 0)
    # Coincident: the plug's wall corners are the rock's wall points.
    assert np.array_equal(mesh.node_x[fill.wall_rock_node], fill.node_xy[fill.wall_scda_node])
    # Every rock node of the wall is pushed, and only those.
    assert np.array_equal(np.unique(fill.wall_rock_node), np.unique(wall_tri))
    # Normals: unit, horizontal, from the rock into the plug (towards the axis).
    n = fill.wall_normal
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0) and np.all(n[:, 2] == 0.0)
    assert np.all(np.sum(mesh.node_x[fill.wall_rock_node, :2] * n[:, :2], axis=1) < 0)
    # The wall contacts' plug nodes lie on the facet planes (the ends are free).
    x = fill.node_xy[fill.wall_scda_node]
    assert np.allclose(np.max(x @ solid.facet_normals().T, axis=1), solid.apothem,
                       atol=1e-12)


def test_plug_fills_a_borehole_with_refined_wall_zones():
    # 1 mm zones at the wall: 32 facets, and the plug meshed at the wall's zone size.
    slab = build_specimen({**SLAB, "grains": {"wall_zone_size_mm": 1.0}})
    fill = scda.scda_fill(slab, materials.load_scda("scda"))
    mesh = slab.mesh
    assert mesh.grains.solid.borehole_facets == 32
    volume = tet_volumes(fill.node_xy[fill.element_nodes])
    assert np.all(volume > 0)
    assert volume.sum() == pytest.approx(
        mesh.grains.solid.borehole_area * mesh.borehole_length, rel=1e-9)
    assert fill.wall_area.sum() == pytest.approx(_lateral_area(slab), rel=1e-9)
    assert np.array_equal(np.unique(fill.wall_rock_node),
                          np.unique(mesh.surface_triangles["borehole"]))
    edges = np.linalg.norm(np.diff(fill.node_xy[fill.element_nodes], axis=1), axis=2)
    assert np.median(edges) < 1.3e-3


def test_block_sub_contacts_pair_coincident_corners_of_shared_faces(fill):
    a, b = fill.joint_nodes.T
    assert np.array_equal(fill.node_xy[a], fill.node_xy[b])
    assert np.allclose(np.linalg.norm(fill.joint_normal, axis=1), 1.0)
    block_a, block_b = a // 4, b // 4
    assert np.all(block_a != block_b)
    # From the first block into the second.
    centroid = fill.node_xy[fill.element_nodes].mean(axis=1)
    assert np.all(np.sum((centroid[block_b] - centroid[block_a]) * fill.joint_normal,
                         axis=1) > 0)
    # Three corners per shared face, a third of its area each.
    assert len(a) % 3 == 0
    area = fill.joint_area.reshape(-1, 3)
    assert np.all(area == area[:, :1])


def test_the_plug_is_the_same_every_time(slab, fill):
    """A resumed run rebuilds the plug: it must come out identical."""
    again = scda.scda_fill(slab, fill.recipe)
    for name in ("node_xy", "element_nodes", "wall_rock_node", "wall_scda_node", "wall_area",
                 "joint_nodes", "joint_area"):
        assert np.array_equal(getattr(fill, name), getattr(again, name)), name


def _free_plug_solver(fill) -> MechanicsSolver:
    """The plug alone: its blocks and the bonded Table 5 contacts between them."""
    rec = fill.recipe
    e, j, c = len(fill.element_nodes), len(fill.joint_area), rec.contact
    model = model_from_arrays(
        x=fill.node_xy, cells=fill.element_nodes,
        youngs_modulus=np.full(e, rec.youngs_modulus_GPa * GPA),
        poisson_ratio=np.full(e, rec.poisson_ratio), density=np.full(e, rec.density_kg_m3),
        contact_nodes=fill.joint_nodes, contact_frame=contact_frame(fill.joint_normal),
        contact_area=fill.joint_area,
        normal_stiffness=np.full(j, c.normal_stiffness_GPa_per_m * GPA_PER_M),
        shear_stiffness=np.full(j, c.shear_stiffness_GPa_per_m * GPA_PER_M),
        friction_angle=np.full(j, c.friction_angle_deg * DEG),
        cohesion=np.full(j, c.cohesion_MPa * MPA),
        tensile_strength=np.full(j, c.tensile_strength_MPa * MPA),
        bonded=np.ones(j, dtype=bool))
    return MechanicsSolver(model)


def test_free_plug_boundary_moves_out_at_v(fill):
    """Eigenstrain rate v / R with R the facets' distance from the axis: the lateral
    faces of a free plug move out at v. Measured as the mean outward displacement rate
    over the wall faces in steps 2000-4000 (after the start-up transient; the plug's
    free vibration decays slowly, +-1 % per direction over single 1000-step windows
    at this time), and as the
    symmetric part of the plug's affine velocity field (free of the rigid-body drift
    that local damping leaves in a free body)."""
    s = _free_plug_solver(fill)
    v = 5e-3
    scda.set_expansion_velocity(s, np.arange(len(fill.element_nodes)), v, fill.radius)
    outward = -fill.wall_normal
    area = fill.wall_area

    def state():
        return s.u.copy(), s.time

    s.cycle(2000)
    u0, t0 = state()
    s.cycle(2000)
    u1, t1 = state()
    rate = (u1 - u0) / (t1 - t0)
    normal = np.sum(rate[fill.wall_scda_node] * outward, axis=1)
    mean_normal = float(np.sum(normal * area) / area.sum())
    x = fill.node_xy[fill.wall_scda_node]
    r = np.hypot(x[:, 0], x[:, 1])
    radial = np.sum(rate[fill.wall_scda_node, :2] * x[:, :2], axis=1) / r
    design = np.column_stack((np.ones(len(fill.node_xy)), fill.node_xy))
    grad = np.linalg.lstsq(design, rate, rcond=None)[0][1:]  # d v_j / d x_i
    strain_rate = 0.5 * (grad + grad.T) * fill.radius / v  # in units of v / R
    print(f"\noutward velocity of the wall faces / v: mean {mean_normal / v:.4f} (faces "
          f"{normal.min() / v:.3f}-{normal.max() / v:.3f} with the rigid drift); radial "
          f"velocity of the wall corners / v: area mean "
          f"{np.sum(radial * area) / area.sum() / v:.4f}, / (v r / R): mean "
          f"{np.mean(radial / (v * r / fill.radius)):.4f}; strain rate x R / v: diagonal "
          f"{np.diagonal(strain_rate).round(4)}, largest shear "
          f"{np.abs(strain_rate - np.diag(np.diagonal(strain_rate))).max():.1e}")
    assert mean_normal == pytest.approx(v, rel=0.01)
    assert np.mean(radial / (v * r / fill.radius)) == pytest.approx(1.0, rel=0.01)
    assert np.allclose(strain_rate, np.eye(3), atol=0.01)
    assert np.abs(s.stress).max() < 0.1 * MPA  # it swells freely


def test_plug_against_an_elastic_rock_matches_lame():
    """A plug of eigenstrain e* in a homogeneous quartz slab (40 x 40 x 4 mm, free top
    and bottom, smooth wall): compatibility at the wall with the plug and the rock in
    plane stress, the rock a hole in an infinite plate (Lame):

        p = e* / ((1 - nu_s) / E_s + C_joints + (1 + nu_r) / E_r + 1 / (kn R)).

    C_joints is the block contacts' compliance under a uniform stress,
    sum A (n_h^4 / kn + n_h^2 n_z^2 / ks) / (2 V) (n_h the horizontal part of a
    joint normal): the plug is made of blocks, and their Table 5 contacts make it
    ~1.7 x as compliant as its material. Measured: p 0.9 % below this; the finite
    square slab lies between the infinite plate and the thick cylinder of radius
    half the width, which bounds p from below."""
    from grainfrac.verification.elastic3d import homogeneous_slab3d

    width = 40.0
    assembly = homogeneous_slab3d(width, width, 4.0, 10.0, seed=0)
    rec = materials.load_scda("scda")
    plug_fill = scda.scda_fill(assembly, rec)
    s = MechanicsSolver(scda.build_scda_model(assembly, plug_fill))
    mesh = assembly.mesh
    s.allow_failure = False  # the rock stays elastic
    s.bonded[mesh.n_contacts:mesh.n_contacts + plug_fill.n_wall] = False  # smooth wall
    eps = 1e-3
    s.eigenstrain[mesh.n_elements:] = eps
    s.cycle(8000)
    p = scda.expansive_pressure(s, mesh.n_contacts, plug_fill.n_wall)

    e_r = float(np.mean(assembly.grain_youngs_modulus))
    nu_r = float(np.mean(assembly.grain_poisson_ratio))
    e_s, nu_s = rec.youngs_modulus_GPa * GPA, rec.poisson_ratio
    wall = rec.wall_contact_properties()
    kn = wall.normal_stiffness_GPa_per_m * GPA_PER_M
    ks = rec.contact.shear_stiffness_GPa_per_m * GPA_PER_M
    kn_joint = rec.contact.normal_stiffness_GPa_per_m * GPA_PER_M
    a = plug_fill.radius
    n = plug_fill.joint_normal
    nh2 = n[:, 0] ** 2 + n[:, 1] ** 2
    volume = tet_volumes(plug_fill.node_xy[plug_fill.element_nodes]).sum()
    joints = np.sum(plug_fill.joint_area * (nh2**2 / kn_joint + nh2 * n[:, 2] ** 2 / ks)) / (
        2 * volume)
    plug = (1 - nu_s) / e_s + joints
    p_plate = eps / (plug + (1 + nu_r) / e_r + 1 / (kn * a))
    b = width / 2 * 1e-3
    cylinder = ((1 - nu_r) * a**2 + (1 + nu_r) * b**2) / (b**2 - a**2) / e_r
    p_cylinder = eps / (plug + cylinder + 1 / (kn * a))
    # The rock wall's displacement against Lame's, and the wall contact's closure.
    out = -plug_fill.wall_normal
    area = plug_fill.wall_area
    u_rock = np.sum(np.sum(s.u[plug_fill.wall_rock_node] * out, axis=1) * area) / area.sum()
    u_plug = np.sum(np.sum(s.u[mesh.n_nodes + plug_fill.wall_scda_node] * out, axis=1)
                    * area) / area.sum()
    lame = p * a * (1 + nu_r) / e_r
    print(f"\nwall pressure {p / MPA:.3f} MPa; infinite plate {p_plate / MPA:.3f} MPa "
          f"({p / p_plate - 1:+.1%}), thick cylinder b = {b * 1e3:g} mm "
          f"{p_cylinder / MPA:.3f} MPa; block joints add {joints * e_s / (1 - nu_s):.2f} x "
          f"the material's compliance; rock wall displacement / Lame {u_rock / lame:.3f}")
    assert p == pytest.approx(p_plate, rel=0.02)
    assert p_cylinder < p < 1.01 * p_plate
    assert u_rock == pytest.approx(lame, rel=0.05)  # the 3D Lame verification's tolerance
    assert u_plug - u_rock == pytest.approx(p / kn, rel=1e-3)


def test_charging_stops_when_the_expansion_decays_and_drill_out_unloads_the_rock(slab):
    """The stages themselves on an unloaded 3D slab: with b = 1e4 /s and a stop at half
    of f, charging ends on the decay (ln 2 / b = 69 us) short of the peak; drilling out
    swaps the rock's model back and the wall's load goes with the plug."""
    from grainfrac.physics.model import build_mechanical_model
    from grainfrac.scenario import DrillOutStage, ScdaStage
    from grainfrac.stages import DrillOut, ScdaCharge, World

    world = World(slab, MechanicsSolver(build_mechanical_model(slab)))
    spec = validate(ScdaStage, {"decay_rate_per_s": 1e4, "min_velocity_fraction": 0.5})
    charge = ScdaCharge(spec, materials.load_scda("scda"))
    charge.begin(world)
    while not charge.finished():
        charge.advance(world)
    rock = world.n_rock_elements
    loaded = np.abs(world.solver.stress[:rock]).max()
    removed = scda.plug_stored_energy(world.solver, slab.mesh.n_nodes, slab.mesh.n_contacts)
    drill = DrillOut(validate(DrillOutStage, {"relax_steps": 1000, "max_steps": 1000}))
    drill.begin(world)
    while not drill.finished():
        drill.advance(world)
    unloaded = np.abs(world.solver.stress).max()
    print(f"\nstopped: {charge.state.stop_reason} at "
          f"{(drill.state.start_time - charge.state.start_time) * 1e6:.0f} us, "
          f"peak {charge.state.peak_pressure / MPA:.2f} MPa; rock stress {loaded / MPA:.2f} "
          f"-> {unloaded / MPA:.3f} MPa after drilling out; plug energy {removed:.2e} J")
    assert charge.state.stop_reason == "expansion decayed"
    assert 0 < charge.state.peak_pressure < spec.peak_pressure_MPa * MPA
    assert world.model_kind == "rock" and world.solver.model is world.rock_model
    assert world.solver.energies["energy_removed"][0] == pytest.approx(removed)
    assert unloaded < 0.1 * loaded  # measured 4 % after 1000 steps


# --------------------------------------------------------------------------- scenario
HYBRID = {
    "name": "tiny-3d-hybrid", "seed": 1, "dimension": 3,
    "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30, "thickness_mm": 8},
    "stress": {"case": "case2"},
    "stages": [{"kind": "equilibrate"},
               {"kind": "scda", "peak_pressure_MPa": 3.0, "max_duration_ms": 1.0,
                "scda": "scda"},
               {"kind": "drill_out", "relax_steps": 1000},
               {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 0.3,
                "stop_at_boundary": False}],
}


@pytest.fixture(scope="module")
def hybrid(tmp_path_factory):
    out = tmp_path_factory.mktemp("hybrid3d")
    scenario = validate(Scenario, HYBRID)
    return out, run_scenario(scenario, scenario.recipe(), out)


def test_3d_hybrid_charges_drills_out_and_injects(hybrid):
    out, summary = hybrid
    rows = list(csv.DictReader(open(out / "history.csv")))
    charging = [r for r in rows if r["stage"] == "scda"]
    pressure = np.array([float(r["expansive_pressure_MPa"]) for r in charging])
    elapsed = np.array([float(r["time_from_stage_start_s"]) for r in charging])
    books = summary["energy_balance_J"]
    closure = abs(books["residual"]) / books["work_in"]
    print(f"\nexpansive pressure {pressure.round(2).tolist()} MPa over "
          f"{elapsed[-1] * 1e3:.3f} ms, stop: {summary['scda_stop_reason']}; drill-out ratio "
          f"{summary['drill_out_unbalanced_force_ratio']:.1e}; energy residual {closure:.2%}; "
          f"wall time {summary['wall_time_s']:.1f} s")
    assert summary["dimension"] == 3
    assert summary["stages"] == ["equilibrate", "scda", "drill_out", "inject"]
    assert summary["peak_expansive_pressure_MPa"] >= 3.0
    assert summary["scda_stop_reason"] == "peak pressure"
    assert np.all(np.diff(pressure) > 0)  # the pressure rises steadily
    # The plug went in stress-free: the pressure starts from ~0.
    assert pressure[0] < 1.5 * (pressure[1] - pressure[0])
    assert summary["drill_out_unbalanced_force_ratio"] < 1e-5
    after = [float(r["expansive_pressure_MPa"]) for r in rows
             if r["stage"] in ("drill_out", "inject")]
    assert after and all(p == 0.0 for p in after)
    assert summary["injected_volume_ml"] > 0 and summary["peak_well_pressure_MPa"] > 0
    assert books["expansion_work"] > 0 and books["energy_removed"] > 0 and closure < 0.02


def test_3d_plug_snapshots_are_tetrahedra(hybrid):
    out, _ = hybrid
    files = sorted((out / "snapshots").glob("scda_*.vtu"))
    assert files
    plug = meshio.read(files[0])
    assert [block.type for block in plug.cells] == ["tetra"]
    assert plug.points.shape[1] == 3 and plug.point_data["displacement_m"].shape[1] == 3
    assert plug.cell_data["stress_compression_positive_Pa"][0].shape[1] == 6
    assert np.all(plug.cell_data["expansive_pressure_Pa"][0] > 0)


# --------------------------------------------------------------------------- examples
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["hybrid-case2-90mlmin.toml", "scda-case2.toml"])
def test_3d_examples_mirror_the_2d_ones(name):
    three, _ = load_scenario(EXAMPLES / "3d" / name)
    two, _ = load_scenario(EXAMPLES / name)
    assert three.dimension == 3 and two.dimension == 2
    spec = three.specimen
    assert (spec.width_mm, spec.height_mm, spec.thickness_mm) == (100.0, 100.0, 20.0)
    assert three.stages == two.stages
    assert three.stress.case == two.stress.case == "case2"
