"""``grainfrac verify penny``: the penny-shaped hydraulic fracture in 3D (slow: about 75 s
at 4 mm zones; the verification case itself runs at 1 mm).

What holds at 4 mm zones with the case's iterated step (measured on seed 0): the
opening at the injection point within 15 % of the M-vertex at 1, 2 and 4 ms (-13.3 /
-14.6 / -13.3 %), the net pressure at half the radius within 10 % at 2 ms (+0.6 %), the
fluid volume balance to round-off, no open dry rim ahead of the fluid, off the plane no
faces apart by more than twice the case's tolerance (1.6 %; their elastic relief from
the confinement reaches 13 % of the opening), and the fluid's books within 5 %
of the pumped energy (-0.1 % at 4 ms; -2.3 % with the plain step, -20.5 % with voids that
stay at the 3 um floor while the confinement's 10 um closure is undone,
``closure_storage`` off). What does not: the radius, +19.8 / +11.9 / +5.3 % at these
coarse zones (the case's rows are at 1 mm).
"""

from __future__ import annotations

import pytest

from grainfrac.units import MM
from grainfrac.verification import CASES
from grainfrac.verification.penny import (
    BOOKS_TOLERANCE,
    OFF_PLANE_FRACTION,
    OPENING_TOLERANCE,
    PennyConfig,
    penny_run,
)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def coarse():
    return penny_run(PennyConfig(zone_size=4 * MM))


def test_case_is_registered():
    assert "penny" in CASES


def test_opening_at_the_well_follows_the_m_vertex(coarse):
    ref = coarse.reference
    for s in coarse.states:
        expected = float(ref.opening_at_well(s.time))
        assert s.opening_well == pytest.approx(expected, rel=OPENING_TOLERANCE)


def test_net_pressure_at_half_radius_at_2ms(coarse):
    s = coarse.states[list(coarse.config.times).index(2e-3)]
    expected = float(coarse.reference.pressure_at_half_radius(s.time))
    assert s.pressure_half_radius == pytest.approx(expected, rel=0.10)


def test_fluid_volume_balance_closes(coarse):
    for s in coarse.states:
        assert s.stored_gain == pytest.approx(s.injected, rel=1e-9)


def test_the_fluid_energy_books_close(coarse):
    """pumped = work on the grains + viscous + stored, within the case's tolerance: the
    plane's voids follow its faces through the confinement's closure (a void held at
    its floor while the pressure lifted the faces made 20 % of the pumped energy)."""
    books = coarse.states[-1].energy
    assert books["on_grains"] > 0.5 * books["pumped"] and books["viscous"] > 0.0
    assert abs(books["residual"]) < BOOKS_TOLERANCE * books["pumped"]


def test_the_fracture_is_wet_to_its_tip_and_grows(coarse):
    radii = [s.radius for s in coarse.states]
    assert all(s.dry_rim < 0.05 * s.radius for s in coarse.states)
    assert radii == sorted(radii) and radii[0] > coarse.config.starter_crack_diameter / 2


def test_nothing_opens_off_the_plane(coarse):
    """Off-plane faces stay pressed together: their largest separation is a small
    fraction of the opening at the well, though the confinement's relief moves them.
    At these 4 mm zones the bonded vertical faces that meet the open plane come apart
    by up to 1.6 % and the relief reaches 13 % (measured, seed 0, iterated step; within
    ``OFF_PLANE_FRACTION`` at the case's 1 and 2 mm zones), so the test allows twice
    the case's tolerance."""
    ratio = max(s.max_off_plane_opening / s.opening_well for s in coarse.states)
    relief = max(s.off_plane_relief for s in coarse.states) / coarse.states[-1].opening_well
    print(f"\noff the plane: separation / opening at the well {ratio:.4f}, relief {relief:.3f}")
    for s in coarse.states:
        assert 0.0 <= s.max_off_plane_opening < 2 * OFF_PLANE_FRACTION * s.opening_well
    assert relief > 0.05
