"""The static equilibrium solve: its stiffness is the explicit kernels' (2D and 3D), its
equilibrium is dynamic relaxation's, its energy books close, and it refuses loads it
cannot solve."""

from __future__ import annotations

import numpy as np
import pytest

from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.errors import GrainfracError
from grainfrac.io.config import validate
from grainfrac.loading.boundary import Platen, far_field_stress_forces
from grainfrac.materials import homogeneous_recipe
from grainfrac.physics import static_equilibrium
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.stages import Driver, Equilibrate, World
from grainfrac.verification.elastic3d import homogeneous_slab3d


@pytest.fixture(scope="module")
def slab2d():
    """A 40 mm slab with its 10 mm borehole, 4 mm zones, homogeneous quartz."""
    config = validate(SpecimenConfig, {
        "seed": 0, "grains": {"zone_size_mm": 4.0},
        "specimen": {"shape": "slab", "width_mm": 40.0, "height_mm": 40.0}})
    return build_assembly(config, homogeneous_recipe())


@pytest.mark.parametrize("dimension", [2, 3])
def test_stiffness_is_the_kernels_force_response(dimension, slab2d):
    """K u = -f(u) for a random motion of the bonded assembly, to round-off (1e-10 of
    the forces): the matrix the solve inverts is the explicit step's linear law."""
    # 3D: the patch test's 20 mm block of 3 mm zones (16 grains).
    assembly = slab2d if dimension == 2 else homogeneous_slab3d(20.0, 20.0, 20.0, 0.0,
                                                                zone_size_mm=3.0)
    solver = MechanicsSolver(build_mechanical_model(assembly))
    m = solver.model
    rng = np.random.default_rng(1)
    u = rng.normal(scale=1e-7, size=solver.u.shape)
    solver.u[:] = u
    relative = u[m.contact_nodes[:, 1]] - u[m.contact_nodes[:, 0]]
    for t in range(dimension - 1):  # the shear springs as the steps would build them
        solver.tau[:, t] = m.shear_stiffness * np.einsum("ci,ci->c", relative,
                                                         m.contact_frame[:, t + 1])
    force = static_equilibrium.internal_forces(solver).copy()
    k = static_equilibrium.stiffness_matrix(m)
    print(f"\n{dimension}D: {m.n_nodes} nodes, {m.n_contacts} sub-contacts, K nnz {k.nnz}")
    np.testing.assert_allclose(k @ u.ravel(), -force.ravel(), rtol=0,
                               atol=1e-10 * np.abs(force).max())


def _apart_but_rigid(first: MechanicsSolver, second: MechanicsSolver) -> float:
    """Largest difference of two solvers' displacements, after their difference's rigid
    motion is taken out, over the largest displacement of ``second``."""
    difference = (first.u - second.u).ravel()
    rigid = static_equilibrium.rigid_motions(first.model.x, first.model.dimension)
    difference -= rigid @ np.linalg.lstsq(rigid, difference, rcond=None)[0]
    return float(np.abs(difference).max() / np.abs(second.u).max())


def _equilibrated(assembly, method: str, ratio: float = 1e-7) -> MechanicsSolver:
    solver = MechanicsSolver(build_mechanical_model(assembly))
    stage = Equilibrate(2.5e6, 5e6, ratio=ratio, max_steps=400_000, method=method)
    Driver([stage], World(assembly, solver)).execute()
    assert stage.state.converged
    return solver


def test_static_equilibrium_is_dynamic_relaxation_s(slab2d):
    """The 40 mm slab under the Case 2 far field: the static solve meets a 1e-7
    unbalanced-force ratio without a step, and its stresses and (but for a rigid
    motion: the loaded slab is a free body that dynamic relaxation lets drift) its
    displacements are those dynamic relaxation reaches to 1e-7, within 1e-5 of the
    largest (measured 2e-7 and 3e-7)."""
    static = _equilibrated(slab2d, "static")
    explicit = _equilibrated(slab2d, "explicit")
    u_error = _apart_but_rigid(static, explicit)
    stress_error = np.abs(static.stress - explicit.stress).max() / np.abs(explicit.stress).max()
    print(f"\nstatic: {static.step_count} steps, ratio {static.unbalanced_force_ratio():.2e}; "
          f"explicit: {explicit.step_count} steps; displacements {u_error:.2e}, stresses "
          f"{stress_error:.2e} of the largest apart")
    assert static.step_count == 0 and static.unbalanced_force_ratio() < 1e-7
    assert u_error < 1e-5 and stress_error < 1e-5


def test_static_jump_keeps_the_energy_books_closed(slab2d):
    """The loads' work on the jump is what the springs store plus what damping takes:
    the balance's residual stays at round-off (1e-9 of the work in)."""
    solver = _equilibrated(slab2d, "static")
    books = solver.energy_balance()
    print("\n" + ", ".join(f"{k} {v:.4g}" for k, v in books.items()))
    assert books["boundary_work"] > 0.0 and books["damping_work"] > 0.0
    assert abs(books["residual"]) < 1e-9 * books["work_in"]
    # A linear system loaded from rest stores half the loads' work.
    stored = books["grain_strain_energy"] + books["contact_strain_energy"]
    assert stored == pytest.approx(0.5 * books["work_in"], rel=1e-6)


def test_iterative_solve_gives_the_factorised_equilibrium(slab2d, monkeypatch):
    """The AMG-preconditioned conjugate gradients (used from ``ITERATIVE_MIN_DOFS``) reach
    the factorisation's displacements, but for a rigid motion, within 1e-8 of the
    largest."""
    direct = _equilibrated(slab2d, "static")
    monkeypatch.setattr(static_equilibrium, "ITERATIVE_MIN_DOFS", 0)
    iterative = _equilibrated(slab2d, "static")
    apart = _apart_but_rigid(iterative, direct)
    print(f"\niterative against direct: {apart:.2e} of the largest displacement")
    assert apart < 1e-8 and iterative.step_count == 0


def test_loads_it_cannot_solve_are_refused_before_any_change(slab2d):
    solver = MechanicsSolver(build_mechanical_model(slab2d))
    solver.loads.external[:] = far_field_stress_forces(slab2d.mesh, 2.5e6, 5e6)
    solver.loads.fixed[0, 0] = True
    solver.loads.prescribed_velocity[0, 0] = 1e-3
    with pytest.raises(GrainfracError, match="supports at rest"):
        static_equilibrium.settle(solver)
    solver.loads.prescribed_velocity[0, 0] = 0.0
    solver.loads.platens.append(Platen(nodes=np.array([0]), axis=1, side=1.0,
                                       position=0.0, velocity=0.0,
                                       stiffness=np.array([1e9])))
    with pytest.raises(GrainfracError, match="platens"):
        static_equilibrium.settle(solver)
    assert not solver.u.any()


@pytest.mark.parametrize("fissures", [0.0, 0.15])
def test_a_static_equilibrate_stage_settles_the_in_situ_stress(fissures, tmp_path):
    """``method = "static"`` in a scenario: Table 2 rock under Case 2 settles without an
    explicit step, with or without 15 % of its grain boundaries unbonded fissures
    (Case 2 closes them and friction holds them: the springs the solve takes them for
    are their equilibrium; measured ratio 2e-14), where dynamic relaxation takes
    hundreds of steps."""
    from grainfrac.scenario import Scenario
    from grainfrac.simulation import run_scenario

    steps = {}
    for method in ("static", "explicit"):
        scenario = validate(Scenario, {
            "name": "static", "seed": 1, "stress": {"case": "case2"},
            "specimen": {"shape": "slab", "width_mm": 30.0, "height_mm": 30.0,
                         "borehole_diameter_mm": 6.0},
            "fissures": {"fraction": fissures, "clear_radius_mm": 0.0},
            "stages": [{"kind": "equilibrate", "method": method}]})
        summary = run_scenario(scenario, scenario.recipe(), tmp_path / method)
        history = np.genfromtxt(tmp_path / method / "history.csv", delimiter=",",
                                names=True, dtype=None, encoding="utf-8")
        steps[method] = int(np.atleast_1d(history["step"])[-1])
        assert summary["in_situ_unbalanced_force_ratio"] < 1e-5
        assert summary["warnings"] == []
    print(f"\nfissures {fissures:.0%}: explicit steps after the static solve "
          f"{steps['static']}, from rest {steps['explicit']}")
    assert steps["static"] == 0 < steps["explicit"]


def test_fissures_the_solve_opens_are_settled_by_the_explicit_steps(slab2d, monkeypatch):
    """Unbonded grain boundaries within two radii of the well under a far field of 0.5
    / 5 MPa, whose hoop stress pulls the wall apart at 90 deg: the solve takes them as
    springs, the law opens those in tension, and the explicit steps that follow reach
    the 1e-5 ratio, in fewer steps than dynamic relaxation from rest."""
    mesh = slab2d.mesh
    centre, radius = np.zeros(2), mesh.grains.outline.borehole_radius
    at = mesh.node_xy[mesh.contact_nodes[:, 0]] - centre
    near = np.hypot(at[:, 0], at[:, 1]) < 2.0 * radius
    solved = []
    settle = static_equilibrium.settle
    monkeypatch.setattr(static_equilibrium, "settle",
                        lambda solver: solved.append(settle(solver)) or solved[-1])
    steps = {}
    for method in ("static", "explicit"):
        solver = MechanicsSolver(build_mechanical_model(slab2d))
        solver.bonded[near] = False
        stage = Equilibrate(0.5e6, 5e6, ratio=1e-5, max_steps=400_000, method=method)
        Driver([stage], World(slab2d, solver)).execute()
        assert stage.state.converged
        steps[method] = solver.step_count
        opened = np.count_nonzero(near & (solver.sigma_n == 0.0))
    print(f"\n{near.sum()} unbonded sub-contacts, {opened} open; ratio after the solve "
          f"{solved[0]:.2e}; steps after it {steps['static']}, from rest "
          f"{steps['explicit']}")
    assert len(solved) == 1 and solved[0] > 1e-5 and opened > 0
    assert 0 < steps["static"] < steps["explicit"]


def test_an_unknown_method_is_refused_by_name():
    with pytest.raises(ValueError, match="explicit, static.*'implicit'"):
        Equilibrate(1e6, 1e6, ratio=1e-5, max_steps=10, method="implicit")


def test_in_situ_initialisation_takes_the_static_solve(slab2d):
    from grainfrac.loading.insitu import initialise_in_situ

    solver = MechanicsSolver(build_mechanical_model(slab2d))
    result = initialise_in_situ(solver, slab2d.mesh, 2.5e6, 5e6, method="static")
    assert result.converged and result.steps == 0 and solver.allow_failure
    with pytest.raises(ValueError, match="'relaxed'"):
        initialise_in_situ(solver, slab2d.mesh, 2.5e6, 5e6, method="relaxed")
