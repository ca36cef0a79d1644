"""Contact softening (fracture energy): the work to break a bond is G_I or G_II.

The linear-softening law is piecewise linear, so the work of the traction along
a displacement path to failure must equal the fracture energy up to the
discretisation of the path; the tolerance (0.5 %) covers a 2000-step path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from signed_law import signed_contact_law

from grainfrac.physics import kernels

MPA = 1e6
KN, KS = 185300.0e9, 35105.0e9  # Q-Q, paper Table 2 (Pa/m)
TAN_PHI = math.tan(math.radians(40.5))
COHESION, TENSILE = 56.44 * MPA, 17.92 * MPA
G_I, G_II = 40.0, 400.0  # J/m2


def _law(u_n, du_s, tau, damage, plastic_opening, bonded=True):
    return signed_contact_law(
        u_n, du_s, tau, KN, KS, TAN_PHI, COHESION, TENSILE, bonded, True, damage,
        plastic_opening, 2.0 * G_I / TENSILE, 2.0 * G_II / COHESION)


def _open_to_failure(n_steps: int = 2000):
    """Pull the faces apart in equal steps until the bond breaks; the path's record."""
    u_fail = TENSILE / KN + 2.0 * G_I / TENSILE
    du = 1.05 * u_fail / n_steps
    damage = plastic = 0.0
    work = dissipated = 0.0
    sigma_old = 0.0
    peak = 0.0
    for k in range(1, 2 * n_steps):
        sigma, _, status, _, released, w_soft, damage, plastic = _law(k * du, 0.0, 0.0, damage,
                                                                      plastic)
        work += 0.5 * (sigma_old + sigma) * -du  # traction (tension) times opening
        dissipated += w_soft + released
        peak = max(peak, -sigma)
        sigma_old = sigma
        if status != kernels.INTACT:
            return work, dissipated, peak, status, k * du
    raise AssertionError("the bond never broke")


def test_mode_one_work_to_failure_is_the_fracture_energy():
    work, dissipated, peak, status, u_break = _open_to_failure()
    u_fail = 2.0 * G_I / TENSILE  # all inelastic: the traction is zero at the break
    print(f"\nmode I: work {work:.3f} J/m2, dissipated {dissipated:.3f} J/m2 vs G_I {G_I} "
          f"(tol 0.5 %); peak {peak / MPA:.3f} MPa vs {TENSILE / MPA:.2f}; break at "
          f"{u_break * 1e6:.3f} um vs {u_fail * 1e6:.3f} um")
    assert status == kernels.TENSILE
    assert TENSILE * (1 - 1e-3) < peak <= TENSILE * (1 + 1e-12)  # sampled on the path
    assert work == pytest.approx(G_I, rel=5e-3)
    assert dissipated == pytest.approx(G_I, rel=5e-3)
    assert u_break == pytest.approx(u_fail, rel=2e-3)


def test_mode_two_work_to_failure_is_the_fracture_energy():
    """Pure shear at zero normal stress: the cohesion softens to zero over 2 G_II / c."""
    s_fail = COHESION / KS + 2.0 * G_II / COHESION
    ds = 1.05 * s_fail / 2000
    damage = plastic = tau = 0.0
    work = dissipated = 0.0
    for _ in range(4000):
        tau_old = tau
        _, tau, status, w_slip, released, w_soft, damage, plastic = _law(0.0, ds, tau, damage,
                                                                         plastic)
        work += 0.5 * (tau_old + tau) * ds
        dissipated += w_soft + released + w_slip
        if status != kernels.INTACT:
            break
    print(f"\nmode II: work {work:.2f} J/m2, dissipated {dissipated:.2f} J/m2 vs G_II {G_II} "
          "(tol 0.5 %)")
    assert status == kernels.SHEAR
    assert work == pytest.approx(G_II, rel=5e-3)
    assert dissipated == pytest.approx(G_II, rel=5e-3)


def test_a_softened_bond_unloads_elastically_and_reloads_to_its_reduced_strength():
    # Half-way down the softening branch: u_p = u_f / 2 and sigma = sigma_T / 2.
    u_soft = 0.5 * (2.0 * G_I / TENSILE) + 0.5 * TENSILE / KN
    damage = plastic = 0.0
    for u in np.linspace(0.0, u_soft, 400)[1:]:
        sigma, *_, damage, plastic = _law(u, 0.0, 0.0, damage, plastic)
    assert damage == pytest.approx(0.5, rel=1e-9)
    assert -sigma == pytest.approx(0.5 * TENSILE, rel=1e-9)
    # Unload: elastic with the full stiffness about the inelastic opening, no more damage.
    sigma, _, status, _, _, w_soft, d_after, p_after = _law(plastic, 0.0, 0.0, damage, plastic)
    assert (sigma, status, w_soft, d_after, p_after) == (0.0, kernels.INTACT, 0.0, damage,
                                                         plastic)
    # Pushed shut it carries compression through the inelastic opening.
    sigma, *_ = _law(plastic - 1e-6, 0.0, 0.0, damage, plastic)
    assert sigma == pytest.approx(KN * 1e-6)
    # Reloaded, it is elastic up to (1 - D) sigma_T and softens on beyond it.
    sigma, *_, d_after, _ = _law(plastic + 0.499 * TENSILE / KN, 0.0, 0.0, damage, plastic)
    assert (-sigma, d_after) == (pytest.approx(0.499 * TENSILE), damage)
    sigma, *_, d_after, _ = _law(plastic + 0.6 * TENSILE / KN, 0.0, 0.0, damage, plastic)
    assert -sigma < 0.5 * TENSILE and d_after > damage


def test_zero_fracture_energy_is_the_brittle_law():
    u = 1.001 * TENSILE / KN
    brittle = signed_contact_law(u, 0.0, 0.0, KN, KS, TAN_PHI, COHESION, TENSILE, True, True,
                                  0.0, 0.0, 0.0, 0.0)
    assert brittle[2] == kernels.TENSILE
    assert brittle[0] == 0.0
    # A softening slope steeper than kn (G_I below sigma_T^2 / 2 kn) would snap back:
    # the bond breaks at the peak as a brittle one does.
    snap = signed_contact_law(u, 0.0, 0.0, KN, KS, TAN_PHI, COHESION, TENSILE, True, True,
                               0.0, 0.0, 0.5 * TENSILE / KN, 0.0)
    assert snap[2] == kernels.TENSILE


def test_a_bond_softened_in_tension_that_slips_counts_as_a_tensile_crack():
    u_f = 2.0 * G_I / TENSILE
    damage, plastic = 0.5, 0.5 * u_f  # half-way down the mode-I branch
    u_n = plastic + 0.5 * TENSILE / KN  # carrying (1 - D) sigma_T of tension
    tau = 0.6 * COHESION  # beyond (1 - D) c + sigma_n tan(phi)
    result = signed_contact_law(u_n, 0.0, tau, KN, KS, TAN_PHI, COHESION, TENSILE, True, True,
                                 damage, plastic, u_f, 0.0)
    assert result[2] == kernels.TENSILE
    # The same slip on a brittle bond in tension stays a shear crack.
    brittle = signed_contact_law(0.5 * TENSILE / KN, 0.0, 1.1 * COHESION, KN, KS, TAN_PHI,
                                  COHESION, TENSILE, True, True, 0.0, 0.0, 0.0, 0.0)
    assert brittle[2] == kernels.SHEAR
