"""KGD verification, toughness-dominated: fracture along a bonded plane vs the K-vertex.

The reference solution is checked on its own (fast); the full case
(``grainfrac verify kgd-toughness``, 2-3 min on one core) is marked slow. Every test prints what it
measured (run ``pytest -s`` to see it).
"""

from __future__ import annotations

import math

import pytest

from grainfrac.verification import CASES
from grainfrac.verification import kgd_toughness as K


def test_kgd_toughness_is_registered():
    assert CASES["kgd-toughness"] is K.kgd_toughness


@pytest.mark.parametrize("time", [1e-4, 3e-3, 0.05])
def test_k_vertex_holds_volume_and_propagates_at_toughness(time):
    """Uniform pressure, elliptical opening: V = pi l w0 / 2 = Q0 t and p sqrt(pi l) = K_IC."""
    ep, kic, q0 = 28.6e9, 1.3e6, 2e-4
    ref = K.k_vertex(time, ep, kic, q0)
    assert ref.volume == pytest.approx(q0 * time, rel=1e-12)
    assert math.pi * ref.half_length * ref.opening / 2 == pytest.approx(q0 * time, rel=1e-12)
    assert ref.net_pressure * math.sqrt(math.pi * ref.half_length) == pytest.approx(kic,
                                                                                    rel=1e-12)
    assert ref.opening == pytest.approx(4 * ref.net_pressure * ref.half_length / ep, rel=1e-12)
    # Detournay's form, gamma_k0 = 0.9324, with K' = 4 sqrt(2 / pi) K_IC.
    kp = K.toughness_prime(kic)
    assert ref.half_length == pytest.approx(K.GAMMA_K0 * (ep * q0 * time / kp) ** (2 / 3),
                                            rel=1e-12)
    assert K.GAMMA_K0 == pytest.approx(0.9324, abs=1e-4)
    # The opening away from the well is the ellipse; beyond the tip, NaN.
    x = 0.6 * ref.half_length
    assert K.k_vertex(time, ep, kic, q0, x=x).opening == pytest.approx(ref.opening * 0.8,
                                                                        rel=1e-12)
    assert math.isnan(K.k_vertex(time, ep, kic, q0, x=1.01 * ref.half_length).opening)
    # Energy: 2 l G_I equals (p - sigma_0) V, two thirds of the net work 3/2 (p - sigma_0) V.
    fracture = 2 * ref.half_length * kic**2 / ep
    assert fracture == pytest.approx(ref.net_pressure * ref.volume, rel=1e-12)


def test_configuration_is_toughness_dominated():
    """The default case: K_m as configured, >= 4, and G_I = K_IC^2 / E'."""
    config = K.KGDToughnessConfig()
    ep = K.plane_strain_modulus(config)
    mu, q0 = config.viscosity(ep), config.rate_2d(ep)
    km = K.toughness_prime(config.toughness) / (ep**3 * 12 * mu * q0) ** 0.25
    print(f"E' = {ep / 1e9:.2f} GPa, G_I = {config.fracture_energy(ep):.2f} J/m2, "
          f"Q0 = {q0:.3e} m2/s, mu = {mu:.3e} Pa s, K_m = {km:.2f}, "
          f"(K_IC / T)^2 = {(config.toughness / config.tensile_strength)**2 * 1e3:.1f} mm")
    assert km == pytest.approx(config.toughness_number, rel=1e-12)
    assert km >= 4
    assert config.fracture_energy(ep) * ep == pytest.approx(config.toughness**2, rel=1e-12)
    end = K.k_vertex(config.duration, ep, config.toughness, q0)
    assert end.half_length == pytest.approx(config.final_half_length, rel=1e-12)


@pytest.fixture(scope="module")
def toughness_rows():
    return K.kgd_toughness(seed=0)


@pytest.mark.slow
def test_kgd_toughness_matches_k_vertex(toughness_rows):
    """``grainfrac verify kgd-toughness``: every compared quantity within 10 %."""
    for row in toughness_rows:
        print(f"{row.quantity:36s} simulated {row.simulated:9.4g} analytical "
              f"{row.analytical:9.4g} error {100 * row.relative_error:6.1f} % "
              f"(tolerance {100 * row.tolerance:.0f} %)")
    compared = [r for r in toughness_rows if math.isfinite(r.tolerance)]
    assert len(compared) == 3 * len(K.KGDToughnessConfig().compare_at)
    shares = {r.quantity: r.simulated for r in toughness_rows
              if r.quantity.startswith("energy_share_")}
    # The net work on the solid is accounted for: its four shares add up to one.
    solid = ("elastic", "fracture", "damping", "other_mechanics")
    assert sum(shares[f"energy_share_{k}"] for k in solid) == pytest.approx(1.0, abs=1e-9)
    failed = [r.quantity for r in compared if not r.passed]
    assert not failed, f"outside tolerance: {failed}"
