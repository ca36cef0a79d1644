"""The fast platen approach of :class:`grainfrac.stages.platen.PlatenLoading` on a stub
specimen whose load rises with the closure and falls past a peak that comes later the
faster the platens move (the rate effect the approach must not carry into the result)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from grainfrac.stages.platen import REWIND_FRACTION, PlatenLoading

DT = 1e-6  # s per step
SPEED = 1e-2  # m/s
STIFFNESS = 1e6  # N/m
PEAK_CLOSURE = 2e-3  # m, at SPEED


def softening_spring(closure: float, speed: float) -> float:
    """Fails at a closure that grows by 5 % for each doubling of the speed, then softens
    to nothing over 1.4 % more closure (at 8 x the speed about two samples: a sample
    past the peak has a low load)."""
    peak = PEAK_CLOSURE * (1 + 0.05 * np.log2(max(speed, SPEED) / SPEED))
    soft = max(0.0, 1.0 - (closure - peak) / (0.014 * peak)) if closure > peak else 1.0
    return STIFFNESS * min(closure, peak) * soft


def locking_spring(closure: float, speed: float) -> float:
    """Dips by 5 % at PEAK_CLOSURE when loaded slowly, then stiffens (a UCS cylinder that
    locks up); loaded fast it never dips."""
    dip = 0.95 if speed <= 2 * SPEED and PEAK_CLOSURE < closure < 1.1 * PEAK_CLOSURE else 1.0
    return STIFFNESS * closure * dip


class StubSpecimen:
    """Two platens closing on ``law(closure, speed)`` (N); a crack a sample past the peak."""

    def __init__(self, law=softening_spring):
        self.law = law
        self.platens = [SimpleNamespace(side=s, position=s * 0.01, velocity=0.0,
                                        reaction=0.0) for s in (+1, -1)]
        self.start = [p.position for p in self.platens]
        self.time, self.step_count = 0.0, 0
        self.cracks = SimpleNamespace(contact=[])

    def cycle(self, n: int) -> None:
        speed = abs(self.platens[0].velocity)
        for p in self.platens:
            p.position += p.velocity * DT * n
        self.time += DT * n
        self.step_count += n
        closure = sum(p.side * (s - p.position)
                      for p, s in zip(self.platens, self.start, strict=True))
        if closure > PEAK_CLOSURE:
            self.cracks.contact.append(len(self.cracks.contact))
        load = self.law(closure, speed)
        for p in self.platens:
            p.reaction = p.side * load

    def save_state(self) -> dict:
        return {"platens": [(p.position, p.reaction) for p in self.platens],
                "time": self.time, "step_count": self.step_count,
                "n_cracks": len(self.cracks.contact)}

    def restore_state(self, saved: dict) -> None:
        for p, (position, reaction) in zip(self.platens, saved["platens"], strict=True):
            p.position, p.reaction = position, reaction
        self.time, self.step_count = saved["time"], saved["step_count"]
        del self.cracks.contact[saved["n_cracks"]:]


def load_to_failure(factor: float, law=softening_spring, max_strain: float = 0.5
                    ) -> tuple[PlatenLoading, StubSpecimen]:
    specimen = StubSpecimen(law)
    stage = PlatenLoading(specimen.platens, size=0.02, speed=SPEED, sample_steps=100,
                          stop_fraction=0.3, peak_drop_fraction=0.02, post_peak_factor=1.5,
                          max_strain=max_strain, approach_factor=factor)
    world = SimpleNamespace(solver=specimen)
    stage.begin(world)
    while not stage.finished():
        stage.advance(world)
    return stage, specimen


def test_the_approach_reads_the_fixed_speed_peak_and_drops_what_it_ran_past():
    """Also: the states saved past the fast peak, where the load is low again, are
    never gone back to (the kept curve would peak at the fast peak)."""
    fixed, _ = load_to_failure(1.0)
    fast, specimen = load_to_failure(8.0)
    assert fixed.state.steps_discarded == 0 and fast.state.steps_discarded > 0
    # The fast run peaked 15 % later; the kept curve peaks where the fixed one does (to
    # one sample's load step, 1e-3).
    assert max(fast.curve.load) == pytest.approx(max(fixed.curve.load), rel=1.5e-3)
    assert max(fast.curve.load) == pytest.approx(STIFFNESS * PEAK_CLOSURE, rel=1.5e-3)
    closure = np.asarray(fast.curve.closure)
    assert np.all(np.diff(closure) > 0) and np.all(np.diff(fast.curve.time) > 0)
    # It went back to a state taken before the fast peak, at most 0.75 x its load.
    step = np.diff(closure)
    back = np.flatnonzero(step > 4 * step[-1])[-1] + 1  # the last sample taken fast
    fast_peak = STIFFNESS * PEAK_CLOSURE * (1 + 0.05 * 3)
    assert 0.6 * fast_peak < fast.curve.load[back] <= REWIND_FRACTION * fast_peak
    assert fast.curve.n_cracks[-1] == len(specimen.cracks.contact)
    assert fixed.state.stop_reason == fast.state.stop_reason
    total = specimen.step_count + fast.state.steps_discarded
    assert total < 0.5 * fixed.curve.time[-1] / DT


def test_a_fast_run_without_a_peak_starts_again_at_the_test_speed():
    """A specimen that dips only when loaded slowly and then locks up: the fast run
    reaches the strain limit (2 x the dip's closure) with no peak, and going back to
    0.75 x its largest load would land past the dip; it starts again instead."""
    limit = 2 * PEAK_CLOSURE / 0.02
    fixed, _ = load_to_failure(1.0, locking_spring, limit)
    fast, specimen = load_to_failure(8.0, locking_spring, limit)
    assert fixed.state.peak_closure == pytest.approx(PEAK_CLOSURE, rel=1e-3)
    assert fast.state.peak_closure == fixed.state.peak_closure
    assert fast.curve.load == fixed.curve.load
    assert fast.state.steps_discarded > 0


def test_an_approach_factor_below_one_is_refused():
    specimen = StubSpecimen()
    stage = PlatenLoading(specimen.platens, size=0.02, speed=SPEED, sample_steps=100,
                          stop_fraction=0.3, peak_drop_fraction=0.02, post_peak_factor=1.5,
                          max_strain=0.5, approach_factor=0.5)
    with pytest.raises(ValueError, match="approach_factor"):
        stage.begin(SimpleNamespace(solver=specimen))
