"""KGD verification: fluid-driven fracture along a zero-strength plane vs the M-vertex.

The full case (``grainfrac verify kgd``, about 2.5 min on one core) is marked
slow; a smaller, shorter configuration checks in ~20 s that the fracture opens
along the plane only, keeps the fluid and grows with time. Every test prints
what it measured (run ``pytest -s`` to see it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from grainfrac.units import MM
from grainfrac.verification import CASES
from grainfrac.verification import kgd as K

# Small, short version of the case: 200 mm slab, fracture to ~20 mm in 3 ms.
SMOKE = K.KGDConfig(
    width=200 * MM,
    fine_half_length=35 * MM,
    grain_levels=3,
    final_half_length=20 * MM,
    final_opening=15e-6,
    duration=0.003,
    n_steps=300,
    compare_at=(0.5, 1.0),
)


def test_kgd_is_registered():
    assert CASES["kgd"] is K.kgd


def test_m_vertex_reference_is_self_consistent():
    """The scaled M-vertex holds the injected volume and has the quoted well values."""
    ep, mu, q0, t = 30e9, 1e-3, 2e-4, 0.01
    ref = K.m_vertex(t, ep, mu, q0)
    eps = (12 * mu / (ep * t)) ** (1 / 3)
    scale = (ep * q0**3 * t**4 / (12 * mu)) ** (1 / 6)
    assert ref.half_length == pytest.approx(K.GAMMA_M0 * scale)
    assert ref.opening == pytest.approx(K.OMEGA_M0_WELL * eps * scale)
    assert ref.net_pressure == pytest.approx(K.PI_M0_WELL * eps * ep)
    # int w dx over both wings, with Adachi & Detournay's shape scaled to Omega(0).
    shape0 = float(K.m_vertex_opening_shape(0.0))
    half = quad(lambda x: float(K.m_vertex_opening_shape(x / ref.half_length)), 0,
                ref.half_length, limit=200)[0]
    volume = 2 * ref.opening / shape0 * half
    print(f"M-vertex volume / injected = {volume / (q0 * t):.4f} (tolerance 1.5 %)")
    assert volume == pytest.approx(q0 * t, rel=0.015)
    assert float(K.m_vertex_pressure_shape(0.0)) == pytest.approx(0.5449, abs=1e-4)
    assert math.isnan(K.m_vertex(t, ep, mu, q0, x=2 * ref.half_length).opening)


@pytest.fixture(scope="module")
def smoke_run() -> K.KGDRun:
    return K.run_kgd(SMOKE, seed=0, record_every=30)


def test_kgd_smoke_fracture_grows_along_plane_only(smoke_run):
    states = smoke_run.states
    for s in states:
        print(f"t = {s.time * 1e3:5.2f} ms: half length {s.half_length / MM:5.1f} mm "
              f"(left {s.half_length_left / MM:4.1f}, right {s.half_length_right / MM:4.1f}), "
              f"opening at well {s.opening_well * 1e6:5.2f} um, net pressure "
              f"{s.net_pressure_well / 1e6:5.2f} MPa, largest off-plane opening "
              f"{s.max_off_plane_opening * 1e6:.3f} um, fracture/injected volume "
              f"{s.fracture_volume / s.injected_volume:.4f}, borehole widening / injected "
              f"{s.borehole_widening / s.injected_volume:.4f}")
    lengths = np.array([s.half_length for s in states])
    assert np.all(np.diff(lengths) >= 0), "the half length must not shrink"
    mid = next(s for s in states if math.isclose(s.time, 0.5 * SMOKE.duration, rel_tol=1e-3))
    end = states[-1]
    # M-vertex: l(T) / l(T/2) = 2^(2/3) = 1.59.
    assert end.half_length > 1.3 * mid.half_length
    assert end.half_length > 5 * SMOKE.borehole_radius
    # Both wings grow, about equally.
    assert min(end.half_length_left, end.half_length_right) > 0.8 * end.half_length
    # Only the plane opens: no bond breaks and the grain boundaries off the plane stay
    # closed to within 1 % of the fracture opening.
    assert end.n_broken_bonds == 0
    assert end.max_off_plane_opening < 0.01 * end.opening_well
    # The fluid stays in the fracture and the widened borehole (the rest is the
    # fluid's compression).
    assert (end.fracture_volume + end.borehole_widening) / end.injected_volume > 0.98
    # Opening and pressure already near the M-vertex on this coarse, short run.
    ref = smoke_run.reference(end)
    print(f"end: opening {end.opening_well / ref.opening - 1:+.3f}, net pressure "
          f"{end.net_pressure_well / ref.net_pressure - 1:+.3f}, half length "
          f"{end.half_length / ref.half_length - 1:+.3f} relative to the M-vertex")
    assert end.opening_well == pytest.approx(ref.opening, rel=0.15)
    assert end.net_pressure_well == pytest.approx(ref.net_pressure, rel=0.15)


@pytest.fixture(scope="module")
def kgd_rows():
    return K.kgd(seed=0)


@pytest.mark.slow
def test_kgd_matches_m_vertex(kgd_rows):
    """``grainfrac verify kgd``: every compared quantity within 15 %."""
    for row in kgd_rows:
        print(f"{row.quantity:36s} simulated {row.simulated:9.4g} analytical "
              f"{row.analytical:9.4g} error {100 * row.relative_error:5.1f} % "
              f"(tolerance {100 * row.tolerance:.0f} %)")
    assert len(kgd_rows) == 3 * len(K.KGDConfig().compare_at)
    failed = [row.quantity for row in kgd_rows if not row.passed]
    assert not failed, f"outside tolerance: {failed}"
