"""3D Brazilian disc between platens: the energy books of a load-unload-reload-to-failure
test close, and halving the time step leaves the peak load alone (3D counterparts of
tests 3 and 4 of ``test_mechanics.py``).

The disc (D 20 x T 8 mm, grains 2-5 mm, 1.5 mm zones, Table 2 rock, seed 0: 14 grains,
6185 tetrahedra) is loaded by the 3D lab test's platens
(:func:`~grainfrac.labtests.mechanical3d.bts_test3d`) at 0.02 m/s each. Measured: peak
4544.6 N at 153 um closure, 620 cracks, residual of the books 0.13 % of the gross work
in after the load-unload-reload cycle; with dt / 2 the peak moved by 2.4e-5.
"""

from __future__ import annotations

import numpy as np
import pytest

from grainfrac.assembly import build_specimen
from grainfrac.labtests.mechanical3d import bts_test3d

DISC = {"dimension": 3, "seed": 0,
        "specimen": {"shape": "disk", "diameter_mm": 20.0, "thickness_mm": 8.0},
        "grains": {"min_edge_mm": 2.0, "max_edge_mm": 5.0, "zone_size_mm": 1.5}}
SPEED = 0.02  # m/s, each platen
CHUNK = 200  # steps between samples at the default safety 0.5


@pytest.fixture(scope="module")
def disc():
    return build_specimen(DISC)


class Drive:
    """The disc's two loading platens at a signed closing speed; closure, load and the
    gross positive work put in (the books' yardstick)."""

    def __init__(self, assembly, safety: float = 0.5):
        self.test = bts_test3d(assembly, safety=safety)
        self.solver = self.test.solver
        self.upper, self.lower = self.test.loading
        self.start = (self.upper.position, self.lower.position)
        self.chunk = int(round(CHUNK * 0.5 / safety))  # the same time between samples
        self.gross_in = 0.0
        self._last_work = 0.0

    def speed(self, v: float) -> None:
        """Positive closes the platens, negative opens them."""
        self.upper.velocity = -self.upper.side * v
        self.lower.velocity = -self.lower.side * v

    def closure(self) -> float:
        return (self.start[0] - self.upper.position) + (self.lower.position - self.start[1])

    def load(self) -> float:
        return 0.5 * (self.upper.reaction - self.lower.reaction)

    def advance(self) -> None:
        self.solver.cycle(self.chunk)
        e = self.solver.energies
        work = float(e["platen_work"][0] + e["boundary_work"][0])
        self.gross_in += max(work - self._last_work, 0.0)
        self._last_work = work

    def to_failure(self, drop: float) -> float:
        """Close until the load falls below ``drop`` x its peak; return the peak (N)."""
        self.speed(SPEED)
        peak = 0.0
        while self.solver.step_count < 1_000_000:
            self.advance()
            peak = max(peak, self.load())
            if self.load() < drop * peak:
                return peak
        raise AssertionError("the disc did not fail")


@pytest.mark.slow  # 15 s; the default suite measured 9:44 of its 10 min with it
def test_energy_books_of_a_3d_load_unload_fail_test_close(disc):
    drive = Drive(disc)
    kinetic = []
    # Load to 80 um closure (about half the peak's 153 um), unload to 10 um, reload to failure.
    for speed, target in ((SPEED, 80e-6), (-SPEED, 10e-6)):
        drive.speed(speed)
        while (drive.closure() - target) * np.sign(speed) < 0:
            drive.advance()
        kinetic.append(drive.solver.kinetic_energy() / drive.gross_in)
        print(f"\nclosure {drive.closure() * 1e6:.1f} um, load {drive.load():.1f} N, "
              f"cracks {len(drive.solver.cracks.contact)}, kinetic / work in {kinetic[-1]:.1e}")
    peak = drive.to_failure(0.5)
    books = drive.solver.energy_balance()
    for key, value in books.items():
        print(f"  {key:<24}{value: .6e} J")
    rel = abs(books["residual"]) / drive.gross_in
    print(f"peak {peak:.1f} N, {len(drive.solver.cracks.contact)} cracks; |residual| / gross "
          f"work in {rel:.2e} (tolerance 1e-2)")
    assert len(drive.solver.cracks.contact) > 100
    assert max(kinetic) < 1e-3
    assert rel < 0.01


@pytest.mark.slow  # 45 s
def test_halving_the_time_step_keeps_the_3d_peak_load(disc):
    peaks = [Drive(disc, safety).to_failure(0.7) for safety in (0.5, 0.25)]
    change = abs(peaks[1] - peaks[0]) / peaks[0]
    print(f"\npeak load {peaks[0]:.2f} N (dt), {peaks[1]:.2f} N (dt / 2): {change:.2e} "
          f"(tolerance 1e-2)")
    assert change < 0.01
