"""One 3D sub-contact through the contact kernel: a normal and two tangents.

Opening, shear along each tangent and along a diagonal, Coulomb on |tau| (the
strength does not depend on the direction of slip), the direction of the shear
vector kept through slip, and the work of softening equal to G_I / G_II.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from grainfrac.geometry.mesh import contact_frame
from grainfrac.physics import kernels
from grainfrac.physics.records import Contacts, ContactState, NodeState

MPA = 1e6
KN, KS = 185300.0e9, 35105.0e9  # Q-Q, paper Table 2 (Pa/m)
TAN_PHI = math.tan(math.radians(40.5))
COHESION, TENSILE = 56.44 * MPA, 17.92 * MPA
G_I, G_II = 40.0, 400.0  # J/m2
AREA = 2e-6  # m2
DT = 1e-7  # s
NORMAL = np.array([0.36, -0.48, 0.8])  # unit, oblique to every axis


class Pair:
    """Nodes 0 (fixed) and 1 (driven) joined by one sub-contact."""

    def __init__(self, *, softening: bool):
        self.frame = contact_frame(NORMAL[None, :])
        self.contacts = Contacts(
            np.array([[0, 1]]), self.frame, np.array([AREA]), np.array([KN]), np.array([KS]),
            np.array([TAN_PHI]), np.array([COHESION]), np.array([TENSILE]),
            np.array([2 * G_I / TENSILE if softening else 0.0]),
            np.array([2 * G_II / COHESION if softening else 0.0]))
        self.state = ContactState(np.array([True]), np.zeros(1, np.int64), np.zeros(1),
                                  np.zeros((1, 2)), np.zeros(1), np.zeros(1), np.zeros(1),
                                  np.zeros(1), np.zeros(1))
        self.nodes = NodeState(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
        self.failed = np.zeros(1, np.int64)
        self.work = 0.0  # done on node 1 by whoever drives it (J)

    def move(self, displacement: np.ndarray) -> int:
        """Move node 1 by ``displacement`` in one step; return the number of breaks."""
        self.nodes.v[1] = displacement / DT
        self.nodes.u[1] += displacement
        self.nodes.force[:] = 0.0
        _, n_failed, _, _ = kernels.contact_forces(self.nodes, self.contacts, self.state, DT,
                                                    True, self.failed)
        # The driver balances the contact force on node 1: it does -f . du of work.
        self.work -= float(self.nodes.force[1] @ displacement)
        return n_failed

    @property
    def tau(self) -> np.ndarray:
        """Shear stress vector (Pa) in global coordinates."""
        return self.state.tau[0] @ self.frame[0, 1:]


def test_frame_is_orthonormal_and_right_handed():
    f = contact_frame(np.vstack((NORMAL, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])))
    assert np.allclose(np.einsum("cij,ckj->cik", f, f), np.eye(3)[None], atol=1e-15)
    assert np.allclose(np.linalg.det(f), 1.0)


def test_normal_opening_is_elastic_then_breaks_at_the_tensile_strength():
    pair = Pair(softening=False)
    n = pair.frame[0, 0]
    step = 0.01 * TENSILE / KN
    pair.move(0.5 * TENSILE / KN * n)
    assert pair.state.sigma_n[0] == pytest.approx(-0.5 * TENSILE, rel=1e-12)
    # The force on the moving node pulls it back along -n: -sigma_T/2 A n.
    assert np.allclose(pair.nodes.force[1], -0.5 * TENSILE * AREA * n, rtol=1e-12)
    assert np.allclose(pair.nodes.force[0], -pair.nodes.force[1], rtol=1e-15)
    broke = 0
    while not broke:
        broke = pair.move(step * n)
    u_n = pair.nodes.u[1] @ n
    assert pair.state.status[0] == kernels.TENSILE
    assert KN * u_n == pytest.approx(TENSILE, rel=0.011)
    assert pair.state.sigma_n[0] == 0.0 and np.all(pair.state.tau[0] == 0.0)


@pytest.mark.parametrize("direction", ["t1", "t2", "diagonal"])
def test_coulomb_on_the_shear_magnitude_in_any_direction(direction):
    """Under 5 MPa compression, a brittle bond slips at c + sigma_n tan(phi) whatever the
    direction; afterwards friction holds sigma_n tan(phi) along the same direction."""
    pair = Pair(softening=False)
    n, t1, t2 = pair.frame[0]
    along = {"t1": t1, "t2": t2, "diagonal": (t1 + t2) / math.sqrt(2)}[direction]
    sigma = 5.0 * MPA
    pair.move(-sigma / KN * n)
    assert pair.state.sigma_n[0] == pytest.approx(sigma, rel=1e-12)
    strength = COHESION + sigma * TAN_PHI
    step = 1e-3 * strength / KS
    peak = 0.0
    for _ in range(2000):
        if pair.move(step * along):
            break
        tau = pair.tau
        peak = max(peak, float(np.linalg.norm(tau)))
        # Elastic: tau = ks * slip, along the slip.
        assert np.allclose(tau / np.linalg.norm(tau), along, atol=1e-12)
    else:
        raise AssertionError("the bond never slipped")
    print(f"\n{direction}: peak |tau| {peak / MPA:.4f} MPa vs c + sigma tan(phi) "
          f"{strength / MPA:.4f} MPa (tol 0.1 %)")
    assert pair.state.status[0] == kernels.SHEAR
    assert peak == pytest.approx(strength, rel=1e-3)
    pair.move(step * along)
    residual = pair.tau
    assert np.linalg.norm(residual) == pytest.approx(sigma * TAN_PHI, rel=1e-12)
    assert np.allclose(residual / np.linalg.norm(residual), along, atol=1e-12)


def test_softening_work_is_the_fracture_energy_in_mode_one_and_mode_two():
    """Pulling apart until the bond breaks costs G_I per unit area; sliding along a
    diagonal of the face (no normal stress) costs G_II; both within 0.5 %."""
    results = {}
    for mode, fracture_energy, strength, stiffness in (("I", G_I, TENSILE, KN),
                                                       ("II", G_II, COHESION, KS)):
        pair = Pair(softening=True)
        n, t1, t2 = pair.frame[0]
        along = n if mode == "I" else (t1 - 2.0 * t2) / math.sqrt(5.0)
        to_fail = strength / stiffness + 2 * fracture_energy / strength
        step = to_fail / 4000
        for _ in range(8000):
            if pair.move(step * along):
                break
        else:
            raise AssertionError(f"mode {mode}: the bond never broke")
        per_area = pair.work / AREA
        results[mode] = per_area
        print(f"\nmode {mode}: work {per_area:.3f} J/m2 vs G {fracture_energy} (tol 0.5 %), "
              f"bond energy booked {pair.state.released[0] / AREA:.3f} J/m2")
        assert per_area == pytest.approx(fracture_energy, rel=5e-3)
        assert pair.state.released[0] / AREA == pytest.approx(fracture_energy, rel=5e-3)
    assert results["II"] > results["I"]
