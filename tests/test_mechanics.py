"""Verification of the explicit grain-contact mechanics (kernels, model, solver).

1. Patch test: a one-mineral rectangle with stiff, unbreakable contacts under a
   uniform traction carries a uniform stress and returns the mineral's E and nu.
2. Single sub-contact: the Coulomb law with tensile cut-off fails at sigma_T in
   tension and at c + sigma_n tan(phi) in shear, then keeps residual friction.
3. Energy balance of a load-unload-reload-to-failure platen test closes.
4. Halving the time step leaves a failure-controlled quasi-static result alone.
5. An unstable time step raises NumericalBlowUp.

Every test prints the observed value next to its tolerance (``pytest -s``).
"""

from __future__ import annotations

import dataclasses
import math
import re
import time

import numpy as np
import pytest
from signed_law import signed_contact_law

from grainfrac import materials
from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.loading.boundary import Loads, Platen, normal_pressure_forces
from grainfrac.physics import kernels
from grainfrac.physics.model import MechanicalModel, build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver, NumericalBlowUp

MPA = 1e6
QUARTZ_E = 27.37e9  # paper Table 2
QUARTZ_NU = 0.21
PATCH_PRESSURE = 10.0 * MPA
PATCH_STIFFNESS_FACTOR = 1000.0

# Q-Q contact of paper Table 2 (SI).
QQ = {
    "kn": 185300.0e9,
    "ks": 35105.0e9,
    "tan_phi": math.tan(math.radians(40.50)),
    "cohesion": 56.44 * MPA,
    "tensile_strength": 17.92 * MPA,
}

# Small Brazilian disk with fine grains: a real peak and post-peak drop, ~1000 nodes.
BTS_SPEC = {
    "seed": 0,
    "specimen": {"shape": "disk", "diameter_mm": 20.0, "thickness_mm": 10.0},
    "grains": {"min_edge_mm": 1.0, "max_edge_mm": 2.5, "zone_size_mm": 0.8},
}
# Platen speed (m/s, each platen). 0.05 m/s is too fast for a 2 % time-step
# convergence of the peak on this specimen (see test 4's docstring); 0.02 is not.
PLATEN_SPEED = 0.02
CHUNK = 200  # steps between platen-force samples


# ---------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------
def _assembly(data: dict, recipe: materials.RockRecipe | None = None) -> GrainAssembly:
    cfg = validate(SpecimenConfig, data)
    return build_assembly(cfg, recipe if recipe is not None else cfg.recipe())


def _patch_loads(assembly: GrainAssembly, model: MechanicalModel) -> Loads:
    """Uniform compression on top and bottom, sides free (uniaxial stress in y)."""
    loads = Loads.free(model.n_nodes)
    for side in ("top", "bottom"):
        loads.external += normal_pressure_forces(assembly.mesh, side, PATCH_PRESSURE)
    return loads


def _bts_platens(assembly: GrainAssembly, model: MechanicalModel) -> tuple[Platen, Platen]:
    """Top platen (side +1) and bottom platen (side -1), touching the disk at rest.

    Each platen is offered every perimeter node of its half; only nodes that pass
    its plane feel it. Penalty stiffness per node: contact scale kn x zone x thickness.
    """
    mesh = assembly.mesh
    per = mesh.node_sets["perimeter"]
    y = mesh.node_xy[per, 1]
    top, bottom = per[y > 0.0], per[y < 0.0]
    k = float(np.median(model.normal_stiffness)) * mesh.zone_size * mesh.thickness
    upper = Platen(top, 1, +1, float(mesh.node_xy[top, 1].max()), -PLATEN_SPEED,
                   np.full(len(top), k))
    lower = Platen(bottom, 1, -1, float(mesh.node_xy[bottom, 1].min()), +PLATEN_SPEED,
                   np.full(len(bottom), k))
    return upper, lower


def _platen_load(upper: Platen, lower: Platen) -> float:
    """Mean compressive force the two platens carry (N)."""
    return 0.5 * (upper.reaction - lower.reaction)


def _set_speed(upper: Platen, lower: Platen, speed: float) -> None:
    """Positive speed closes the platens, negative opens them."""
    upper.velocity = -speed
    lower.velocity = +speed


def _closure(upper: Platen, lower: Platen, y_top: float, y_bottom: float) -> float:
    return (y_top - upper.position) + (lower.position - y_bottom)


def _print_energy(table: dict[str, float]) -> None:
    for key, value in table.items():
        print(f"    {key:<24}{value: .6e} J")


# ---------------------------------------------------------------------------------
# 1. patch test
# ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def patch():
    """Homogeneous quartz rectangle (UCS section) at equilibrium under 10 MPa uniaxial."""
    recipe = materials.homogeneous_recipe("quartz", stiffness_factor=PATCH_STIFFNESS_FACTOR,
                                          unbreakable=True)
    assembly = _assembly({"specimen": {"shape": "rectangle"}}, recipe)
    model = build_mechanical_model(assembly)
    solver = MechanicsSolver(model, _patch_loads(assembly, model))
    start = time.perf_counter()
    ratio = solver.equilibrate(ratio=1e-6, max_steps=400_000)
    print(f"\npatch: {assembly.n_grains} grains, {model.n_nodes} nodes, "
          f"{len(model.element_nodes)} elements, {model.n_contacts} sub-contacts; "
          f"ratio {ratio:.2e} after {solver.step_count} steps "
          f"({time.perf_counter() - start:.2f} s)")
    return assembly, model, solver, ratio


def test_patch_stress_is_uniform(patch):
    _, model, solver, ratio = patch
    assert ratio < 1e-6
    sxx, syy, sxy = solver.stress[:, 0], solver.stress[:, 1], solver.stress[:, 2]
    dev = np.abs(syy / -PATCH_PRESSURE - 1.0)
    q = np.quantile(dev, [0.5, 0.9, 0.99, 1.0])
    print(f"syy/(-p) - 1: median {q[0]:.2e}, p90 {q[1]:.2e}, p99 {q[2]:.2e}, max {q[3]:.2e} "
          f"(tolerance 2e-2); elements outside: {int(np.sum(dev > 0.02))} of {len(dev)}")
    print(f"max |sxx|/p {np.abs(sxx).max() / PATCH_PRESSURE:.2e}, "
          f"max |sxy|/p {np.abs(sxy).max() / PATCH_PRESSURE:.2e} (tolerance 2e-2)")
    assert dev.max() < 0.02
    assert np.abs(sxx).max() < 0.02 * PATCH_PRESSURE
    assert np.abs(sxy).max() < 0.02 * PATCH_PRESSURE
    # Sub-contacts transmit the same field: traction sigma.n on the face, split into
    # sigma_n (compression positive) and tau = (sigma.n).t. Nodes shared by several
    # sub-contacts (grain-boundary junctions) split their force among them in a
    # statically indeterminate way, so only one-pair sub-contacts are checked.
    n, t = model.contact_normal, model.contact_tangent
    expected_sn = PATCH_PRESSURE * n[:, 1] ** 2
    expected_tau = -PATCH_PRESSURE * n[:, 1] * t[:, 1]
    pairs = np.bincount(model.contact_nodes.ravel(), minlength=model.n_nodes)
    single = np.all(pairs[model.contact_nodes] == 1, axis=1)
    err_sn = np.abs(solver.sigma_n - expected_sn) / PATCH_PRESSURE
    err_tau = np.abs(solver.tau[:, 0] - expected_tau) / PATCH_PRESSURE
    print(f"{int(single.sum())} one-pair sub-contacts: max |sigma_n - p n_y^2| / p "
          f"{err_sn[single].max():.2e}, max |tau - (sigma.n).t| / p {err_tau[single].max():.2e} "
          f"(tolerance 2e-2); {int((~single).sum())} junction sub-contacts (not checked): "
          f"max errors {err_sn[~single].max():.2f}, {err_tau[~single].max():.2f}")
    assert single.sum() > 0.5 * len(single)
    assert err_sn[single].max() < 0.02
    assert err_tau[single].max() < 0.02


def test_patch_recovers_elastic_constants(patch):
    assembly, model, solver, _ = patch
    mesh = assembly.mesh
    xy, ns, u = mesh.node_xy, mesh.node_sets, solver.u
    height = xy[:, 1].max() - xy[:, 1].min()
    width = xy[:, 0].max() - xy[:, 0].min()
    eps_yy = (u[ns["top"], 1].mean() - u[ns["bottom"], 1].mean()) / height
    eps_xx = (u[ns["right"], 0].mean() - u[ns["left"], 0].mean()) / width
    r = -eps_xx / eps_yy  # plane strain, uniaxial stress: nu / (1 - nu)
    nu = r / (1.0 + r)
    youngs = -PATCH_PRESSURE * (1.0 - nu**2) / eps_yy
    # Contact compliance: one 1/kn per grain boundary crossed, ~ one per grain size.
    kn = float(np.median(model.normal_stiffness))
    grain_size = math.sqrt(float(np.mean(mesh.grains.grain_areas())))
    extra = QUARTZ_E / ((1.0 - QUARTZ_NU**2) * kn * grain_size)
    print(f"contact compliance / grain compliance ~ E/((1-nu^2) kn d) = {extra:.1e} "
          f"(kn {kn:.3e} Pa/m, mean grain size {grain_size * 1e3:.2f} mm)")
    e_err = youngs / QUARTZ_E - 1.0
    nu_err = nu / QUARTZ_NU - 1.0
    print(f"E {youngs / 1e9:.4f} GPa vs {QUARTZ_E / 1e9:.2f} (error {e_err:+.2e}, tol 3e-2); "
          f"nu {nu:.5f} vs {QUARTZ_NU} (error {nu_err:+.2e}, tol 3e-2)")
    assert extra < 1e-3
    assert abs(e_err) < 0.03
    assert abs(nu_err) < 0.03


# ---------------------------------------------------------------------------------
# 2. single contact
# ---------------------------------------------------------------------------------
def _law(u_n, du_s, tau_old, bonded, allow_failure=True):
    """The brittle law (no softening); its first five results."""
    return signed_contact_law(u_n, du_s, tau_old, QQ["kn"], QQ["ks"], QQ["tan_phi"],
                               QQ["cohesion"], QQ["tensile_strength"], bonded, allow_failure,
                               0.0, 0.0, 0.0, 0.0)[:5]


def test_contact_tensile_failure():
    kn, sig_t = QQ["kn"], QQ["tensile_strength"]
    du = 1e-3 * sig_t / kn
    last_intact = 0.0
    for k in range(1, 5000):
        sn, tau, status, w_slip, released = _law(k * du, 0.0, 0.0, True)
        if status != kernels.INTACT:
            break
        assert sn == pytest.approx(-kn * k * du)
        last_intact = -sn
    else:
        pytest.fail("bond never broke in tension")
    u_fail = k * du
    print(f"tension: failed at kn u_n = {kn * u_fail / MPA:.4f} MPa, last carried "
          f"{last_intact / MPA:.4f} MPa, sigma_T {sig_t / MPA:.2f} MPa (tol 1 %); "
          f"status {status} (TENSILE = {kernels.TENSILE})")
    assert status == kernels.TENSILE
    assert abs(kn * u_fail / sig_t - 1.0) < 0.01
    assert abs(last_intact / sig_t - 1.0) < 0.01
    # The broken contact opens stress-free and releases its stored energy.
    assert sn == 0.0 and tau == 0.0 and w_slip == 0.0
    stored = 0.5 * (kn * u_fail) ** 2 / kn
    print(f"released {released:.4f} J/m2 vs stored 0.5 (kn u)^2 / kn = {stored:.4f} J/m2")
    assert released == pytest.approx(stored, rel=1e-12)
    for u_n in (u_fail, 2 * u_fail, 10 * u_fail):
        out = _law(u_n, du, 0.0, False)
        assert out[:3] == (0.0, 0.0, kernels.INTACT), out
    # Re-closed, the broken contact still carries compression (no tension only).
    sn, tau, status, _, _ = _law(-u_fail, 0.0, 0.0, False)
    assert sn == pytest.approx(kn * u_fail) and status == kernels.INTACT
    # With failure switched off the bond stays elastic beyond its strength.
    sn, _, status, _, released = _law(3 * u_fail, 0.0, 0.0, True, False)
    assert sn == pytest.approx(-3 * kn * u_fail) and status == kernels.INTACT


def test_contact_shear_failure_and_residual_friction():
    kn, ks, tan_phi, c = QQ["kn"], QQ["ks"], QQ["tan_phi"], QQ["cohesion"]
    sigma_n = 20.0 * MPA
    u_n = -sigma_n / kn
    peak_expected = c + sigma_n * tan_phi
    residual_expected = sigma_n * tan_phi
    du = 1e-3 * peak_expected / ks
    tau = 0.0
    peak = 0.0
    for _ in range(5000):
        sn, tau_new, status, w_slip, released = _law(u_n, du, tau, True)
        assert sn == pytest.approx(sigma_n)
        if status != kernels.INTACT:
            trial = tau + ks * du
            tau = tau_new
            break
        assert w_slip == 0.0
        tau = tau_new
        peak = max(peak, abs(tau))
    else:
        pytest.fail("bond never broke in shear")
    print(f"shear: peak tau {peak / MPA:.4f} MPa vs c + sn tan(phi) = "
          f"{peak_expected / MPA:.4f} MPa (tol 1 %); status {status} (SHEAR = {kernels.SHEAR})")
    assert status == kernels.SHEAR
    assert abs(peak / peak_expected - 1.0) < 0.01
    assert tau == pytest.approx(residual_expected, rel=1e-12)
    drop = 0.5 * (trial**2 - residual_expected**2) / ks
    print(f"released at failure {released:.2f} J/m2 vs (tau_trial^2 - tau_res^2) / 2ks "
          f"= {drop:.2f} J/m2")
    assert released == pytest.approx(drop, rel=1e-9)
    # Continued shear: residual friction and slip work tau_res x slip.
    n_slip = 2000
    work = 0.0
    for _ in range(n_slip):
        _, tau, status, w_slip, released = _law(u_n, du, tau, False)
        assert status == kernels.INTACT and released == 0.0
        work += w_slip
    slip = n_slip * du
    print(f"residual tau {tau / MPA:.4f} MPa vs sn tan(phi) = {residual_expected / MPA:.4f} MPa "
          f"(tol 1 %); slip work {work:.4f} J/m2 vs tau_res x slip = "
          f"{residual_expected * slip:.4f} J/m2 (tol 1 %)")
    assert abs(tau / residual_expected - 1.0) < 0.01
    assert abs(work / (residual_expected * slip) - 1.0) < 0.01
    # Reversing the shear first unloads elastically (no slip work) to -tau_res.
    elastic_steps = int(2.0 * residual_expected / (ks * du))
    work = 0.0
    for _ in range(elastic_steps):
        _, tau, _, w_slip, _ = _law(u_n, -du, tau, False)
        work += w_slip
    assert work == 0.0 and tau > -residual_expected
    _, tau, _, w_slip, _ = _law(u_n, -2 * du, tau, False)
    assert tau == pytest.approx(-residual_expected) and w_slip > 0.0


def test_solver_uniaxial_pull_breaks_bonds_in_tension():
    """Bonus: a breakable homogeneous rectangle pulled apart through the solver."""
    recipe = materials.homogeneous_recipe("quartz", stiffness_factor=1.0, unbreakable=False)
    assembly = _assembly({"specimen": {"shape": "rectangle"}}, recipe)
    mesh = assembly.mesh
    model = build_mechanical_model(assembly)
    loads = Loads.free(model.n_nodes)
    top, bottom = mesh.node_sets["top"], mesh.node_sets["bottom"]
    loads.fixed[top, 1] = loads.fixed[bottom, 1] = True
    loads.prescribed_velocity[top, 1] = PLATEN_SPEED
    loads.prescribed_velocity[bottom, 1] = -PLATEN_SPEED
    solver = MechanicsSolver(model, loads)
    section = (mesh.node_xy[:, 0].max() - mesh.node_xy[:, 0].min()) * mesh.thickness
    sig_t = float(model.tensile_strength[0])
    peak = 0.0
    worst_tension = worst_shear = 0.0
    for _ in range(300):
        solver.cycle(100)
        stress = -solver.force[top, 1].sum() / section  # support reaction, tension positive
        peak = max(peak, stress)
        b = solver.bonded
        worst_tension = max(worst_tension, float(np.max(-solver.sigma_n[b] /
                                                        model.tensile_strength[b])))
        shear_cap = model.cohesion[b] + solver.sigma_n[b] * model.tan_friction[b]
        worst_shear = max(worst_shear, float(np.max(np.abs(solver.tau[b, 0]) / shear_cap)))
    modes = np.array(solver.cracks.mode)
    broken = ~solver.bonded
    eb = solver.energy_balance()
    print(f"\npull: peak mean stress {peak / MPA:.2f} MPa = {peak / sig_t:.3f} sigma_T; final "
          f"{stress:.2e} Pa; cracks {len(modes)} ({int(np.sum(modes == kernels.TENSILE))} "
          f"tensile); bonded contacts never beyond strength: tension {worst_tension:.4f}, "
          f"shear {worst_shear:.4f} (<= 1); energy residual / work in "
          f"{eb['residual'] / eb['work_in']:+.2e} (dynamic snap, not asserted)")
    assert len(modes) > 0 and np.all(modes == kernels.TENSILE)
    assert 0.5 * sig_t < peak <= 1.0 * sig_t
    assert worst_tension <= 1.0 and worst_shear <= 1.0
    assert np.all(solver.sigma_n[broken] == 0.0) and np.all(solver.tau[broken] == 0.0)
    assert abs(stress) < 1e-3 * peak  # separated: the open cracks carry nothing


# ---------------------------------------------------------------------------------
# 3. energy balance
# ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def bts_assembly() -> GrainAssembly:
    return _assembly(BTS_SPEC)


def _softening_recipe(g_tensile: float, g_shear: float) -> materials.RockRecipe:
    """Table 2 with fracture energies (J/m2) on every contact pair."""
    recipe = materials.load_recipe("strathbogie-granite")
    contacts = {name: props.model_copy(update={"tensile_fracture_energy_J_per_m2": g_tensile,
                                               "shear_fracture_energy_J_per_m2": g_shear})
                for name, props in recipe.contacts.items()}
    return recipe.model_copy(update={"contacts": contacts})


@pytest.mark.parametrize("contacts", ["brittle", "softening"])
def test_energy_balance_load_unload_fail(bts_assembly, contacts):
    """Work in = stored + damping + friction + bond energy, brittle or softening bonds.

    Softening bonds (G_I 20, G_II 200 J/m2) dissipate their fracture energy as they
    soften; that work is booked with the bond energy.
    """
    if contacts == "softening":
        bts_assembly = _assembly(BTS_SPEC, _softening_recipe(20.0, 200.0))
    model = build_mechanical_model(bts_assembly)
    upper, lower = _bts_platens(bts_assembly, model)
    y_top, y_bottom = upper.position, lower.position
    loads = Loads.free(model.n_nodes)
    loads.platens = [upper, lower]
    solver = MechanicsSolver(model, loads)
    gross_in = 0.0
    last_work = 0.0

    def advance():
        nonlocal gross_in, last_work
        solver.cycle(CHUNK)
        work = solver.energies["platen_work"][0] + solver.energies["boundary_work"][0]
        gross_in += max(work - last_work, 0.0)
        last_work = work

    print(f"\nBTS disk: {bts_assembly.n_grains} grains, {model.n_nodes} nodes, "
          f"{model.n_contacts} sub-contacts, dt {model.dt:.3e} s, platens "
          f"{PLATEN_SPEED} m/s each, stiffness {upper.stiffness[0]:.3e} N/m per node")
    start = time.perf_counter()
    ke_ratios = []
    # Load to 40 um closure (about half the peak load), unload to 5 um, reload to failure.
    for name, speed, target in (("load", PLATEN_SPEED, 40e-6), ("unload", -PLATEN_SPEED, 5e-6)):
        _set_speed(upper, lower, speed)
        while (_closure(upper, lower, y_top, y_bottom) - target) * np.sign(speed) < 0:
            advance()
        eb = solver.energy_balance()
        ke_ratios.append(eb["kinetic_energy"] / gross_in)
        print(f"  after {name}: closure {_closure(upper, lower, y_top, y_bottom) * 1e6:.1f} um, "
              f"force {_platen_load(upper, lower):.1f} N, cracks {len(solver.cracks.contact)}, "
              f"kinetic / work in {ke_ratios[-1]:.2e} (tol 1e-3)")
    _set_speed(upper, lower, PLATEN_SPEED)
    peak = 0.0
    while solver.step_count < 400_000:
        advance()
        force = _platen_load(upper, lower)
        peak = max(peak, force)
        if force < 0.5 * peak:
            break
    eb = solver.energy_balance()
    print(f"  reload to failure: peak {peak:.1f} N, now {force:.1f} N, cracks "
          f"{len(solver.cracks.contact)}, {solver.step_count} steps "
          f"({time.perf_counter() - start:.2f} s)")
    _print_energy(eb)
    rel = abs(eb["residual"]) / gross_in
    print(f"  gross positive work in {gross_in:.6e} J; |residual| / gross work in "
          f"{rel:.2e} (tolerance 2e-2)")
    assert force < 0.5 * peak, "the disk did not fail"
    assert len(solver.cracks.contact) > 10
    assert max(ke_ratios) < 1e-3
    assert rel < 0.02


# ---------------------------------------------------------------------------------
# 4. time-step convergence
# ---------------------------------------------------------------------------------
def _bts_peak(assembly: GrainAssembly, safety: float) -> tuple[float, float, int, int]:
    """Drive the platens at PLATEN_SPEED until the load falls below 70 % of its peak."""
    model = build_mechanical_model(assembly, safety=safety)
    upper, lower = _bts_platens(assembly, model)
    loads = Loads.free(model.n_nodes)
    loads.platens = [upper, lower]
    solver = MechanicsSolver(model, loads)
    chunk = int(round(CHUNK * 0.5 / safety))  # same physical time between samples
    peak = 0.0
    peak_time = 0.0
    while solver.step_count < 1_000_000:
        solver.cycle(chunk)
        force = _platen_load(upper, lower)
        if force > peak:
            peak, peak_time = force, solver.time
        if force < 0.7 * peak:
            break
    return peak, peak_time, len(solver.cracks.contact), solver.step_count


def test_halving_time_step_keeps_peak_load(bts_assembly):
    """Peak platen load of the Brazilian disk with dt and dt / 2 (same masses, same speed).

    Mass scaling sets masses from dt / safety, so both models have the same
    masses and only the step differs. At 0.05 m/s this seed's peak moved by
    2.8 % (a different failure cascade); at 0.02 m/s it moves by ~0.1 %.
    """
    start = time.perf_counter()
    runs = {s: _bts_peak(bts_assembly, s) for s in (0.5, 0.25)}
    for s, (peak, t_peak, cracks, steps) in runs.items():
        print(f"\nsafety {s}: peak {peak:.2f} N at closure {2 * PLATEN_SPEED * t_peak * 1e6:.1f} "
              f"um, {cracks} cracks at stop, {steps} steps")
    change = runs[0.25][0] / runs[0.5][0] - 1.0
    print(f"peak change on halving dt {change:+.2e} (tolerance 2e-2); "
          f"{time.perf_counter() - start:.2f} s")
    assert abs(change) < 0.02


# ---------------------------------------------------------------------------------
# 5. blow-up detection
# ---------------------------------------------------------------------------------
def test_unstable_step_raises_blow_up_at_the_step(patch):
    """A step four times too large is caught where the velocities run away."""
    assembly = patch[0]
    stable = build_mechanical_model(assembly)
    model = dataclasses.replace(stable, dt=4.0 * stable.dt)
    solver = MechanicsSolver(model, _patch_loads(assembly, model))
    start = time.perf_counter()
    with pytest.raises(NumericalBlowUp, match=r"step \d+") as info:
        solver.cycle(100_000)
    step = int(re.search(r"step (\d+)", str(info.value)).group(1))
    print(f"\n4 x dt: '{info.value}' after {time.perf_counter() - start:.3f} s "
          f"(stopped at step {step} of 100000; the limit is {solver.velocity_limit} m/s)")
    assert step < 2000 and solver.step_count == step
    assert np.abs(solver.v).max() > solver.velocity_limit


@pytest.mark.parametrize("safety", [0.75, 0.9])
def test_safety_beyond_damped_limit_is_refused(patch, safety):
    """Local damping alpha = 0.8 makes 1/sqrt(1.8) = 0.745 the stability limit (measured:
    0.74 stable, 0.75 runaway), so such models are refused before stepping."""
    model = build_mechanical_model(patch[0], safety=safety)
    with pytest.raises(ValueError, match="safety"):
        MechanicsSolver(model)
