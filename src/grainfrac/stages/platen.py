"""Platen loading: rigid platens close at a constant speed until the specimen fails.

The engine of the UCS, BTS and NSCB lab tests (:mod:`grainfrac.labtests`): the
load the platens carry is sampled every few hundred steps (one chunk per
sample) until it falls below a fraction of its peak, the closure passes a
multiple of the closure at the first peak, or the nominal strain its limit.

A fast approach (``approach_factor`` > 1) first runs the platens that many times
faster, saving the state after every sample, to find where the specimen fails. Once
the first peak is behind it, it goes back to the last state saved before that peak
at a load of at most :data:`REWIND_FRACTION` x the peak, and loads from there at
``speed``; a fast run that reaches the strain limit without a peak starts again. Local
damping does not resist steady motion, so the near-elastic part of the curve does
not depend on the speed; the cracks' stress redistribution near the peak does, and
that part is loaded at ``speed``. The curve and the cracks are those of the path
kept; the steps of the discarded stretch are counted in ``steps_discarded``. It
needs a first peak that the fast run finds less than 1 / REWIND_FRACTION above the
slow one: a sharp failure (Brazilian disc, NSCB beam), not a UCS cylinder, whose 2 %
dip at 96 MPa (3D, seed 0) a run at 8 x the speed never showed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from grainfrac.loading.boundary import Platen
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.stages.world import World

RAMP_SAMPLES = 20  # samples over which the platen speed ramps up from zero
# The fast approach goes back to a state at or below this x the peak it found. At 8 x
# the speed the 3D Brazilian disc (seed 0) peaked 13 % above its fixed-speed peak, so
# 0.75 goes back to about 85 % of the true one; loading at 8 x up to 85 % of it read
# the fixed-speed strength within 0.13 % (decision record 0022).
REWIND_FRACTION = 0.75


@dataclass
class LoadingCurve:
    """Samples of a platen test, SI units.

    ``load`` is the compressive force the loading platen carries (N) and
    ``closure`` how far it has moved towards the specimen (m) (both platens for
    two-platen tests). ``extra`` holds the test's own monitors.
    """

    time: list[float] = field(default_factory=list)
    closure: list[float] = field(default_factory=list)
    load: list[float] = field(default_factory=list)
    n_cracks: list[int] = field(default_factory=list)
    extra: dict[str, list[float]] = field(default_factory=dict)

    def array(self, name: str) -> np.ndarray:
        if name in self.extra:
            return np.asarray(self.extra[name], dtype=float)
        return np.asarray(getattr(self, name), dtype=float)


def first_peak(load: np.ndarray, drop_fraction: float, persist: int = 2) -> tuple[int, bool]:
    """Index of the first peak: the running maximum before the load first stays
    ``drop_fraction`` below it for ``persist`` samples in a row. Returns
    ``(index, found)``; without such a fall it is the overall maximum with
    ``found = False``."""
    load = np.asarray(load, dtype=float)
    if len(load) == 0:
        return 0, False
    below = load < (1.0 - drop_fraction) * np.maximum.accumulate(load)
    run = np.convolve(below.astype(int), np.ones(persist, dtype=int), mode="full")[:len(load)]
    fallen = np.nonzero(run >= persist)[0]
    if len(fallen) == 0:
        return int(np.argmax(load)), False
    end = int(fallen[0]) - persist + 1
    return int(np.argmax(load[:end])), True


@dataclass
class PlatenLoadingState:
    """``peak`` load (N) so far, the closure at the first peak once found, and why
    the loading stopped."""

    start_time: float = 0.0
    samples: int = 0
    peak: float = 0.0
    peak_closure: float | None = None
    stop_reason: str | None = None
    approaching: bool = False
    steps_discarded: int = 0


@dataclass
class PlatenLoading:
    """Close the ``loading`` platens at ``speed`` (m/s), sampling every ``sample_steps``.

    Stops when the load falls below ``stop_fraction`` x its peak, when the
    closure reaches ``post_peak_factor`` x the closure at the first peak (a
    fall of ``peak_drop_fraction``, :func:`first_peak`), or ``max_strain`` x
    ``size`` (m). ``monitors`` are sampled with the load into ``curve.extra``; they
    must read the solver's state alone (a fast approach goes back in time).
    ``approach_factor``: the fast approach (module doc); 1 loads at ``speed`` alone.
    (The lab tests' :class:`~grainfrac.labtests.config.LoadingSpec` in SI.)
    """

    loading: list[Platen]
    size: float
    speed: float
    sample_steps: int
    stop_fraction: float
    peak_drop_fraction: float
    post_peak_factor: float
    max_strain: float
    monitors: dict[str, Callable[[MechanicsSolver], float]] = field(default_factory=dict)
    kind: str = "platen_loading"
    periodic_snapshots: bool = False
    approach_factor: float = 1.0
    state: PlatenLoadingState = field(default_factory=PlatenLoadingState)
    curve: LoadingCurve = field(default_factory=LoadingCurve)
    _start: list[float] = field(default_factory=list, init=False, repr=False)
    # Saved states of the fast approach: (samples on the curve, load, solver state).
    # While approaching, every sample taken is on the curve.
    _saved: list[tuple[int, float, dict]] = field(default_factory=list, init=False,
                                                  repr=False)

    def load(self) -> float:
        """Mean compressive force of the loading platens (N)."""
        return float(np.mean([p.side * p.reaction for p in self.loading]))

    def closure(self) -> float:
        """How far the loading platens have moved towards the specimen (m)."""
        return float(sum(p.side * (s - p.position) for p, s in zip(self.loading, self._start,
                                                                    strict=True)))

    def begin(self, world: World) -> None:
        if self.approach_factor < 1.0:
            raise ValueError(f"approach_factor must be >= 1, got {self.approach_factor:g}")
        self.state.start_time = world.solver.time
        self.state.approaching = self.approach_factor > 1.0
        self._start = [p.position for p in self.loading]
        self.curve = LoadingCurve(extra={name: [] for name in self.monitors})
        self._saved = [(0, 0.0, world.solver.save_state())] if self.state.approaching else []

    def advance(self, world: World) -> None:
        st, s = self.state, world.solver
        # A sudden start sends a stress wave that reads as an early peak: ramp up.
        ramp = min(1.0, (st.samples + 1) / RAMP_SAMPLES)
        speed = self.speed * (self.approach_factor if st.approaching else 1.0)
        for p in self.loading:
            p.velocity = -p.side * speed * ramp
        st.samples += 1
        s.cycle(self.sample_steps)
        self._sample(s)
        if st.approaching:
            if self.finished() or st.peak_closure is not None:  # the peak is behind
                self._rewind(s)
            else:
                self._save(s)

    def _rewind_points(self) -> list[int]:
        """Saved states a rewind may go back to: taken up to the first peak (so far),
        at a load of at most REWIND_FRACTION x its load."""
        load = self.curve.load
        peak, _ = first_peak(load, self.peak_drop_fraction)
        low = REWIND_FRACTION * load[peak]
        return [i for i, (kept, at, _) in enumerate(self._saved)
                if kept <= peak + 1 and at <= low]

    def _save(self, s: MechanicsSolver) -> None:
        """Keep this state; of the older ones keep the start and drop those before the
        last rewind point (the first peak can only rise and move later)."""
        self._saved.append((len(self.curve.load), self.curve.load[-1], s.save_state()))
        del self._saved[1:self._rewind_points()[-1]]

    def _rewind(self, s: MechanicsSolver) -> None:
        """Go back to the last rewind point (the start is always one) and load on from
        there at ``speed``; to the start if the fast run reached the strain limit
        without a peak (it may have carried the specimen past a peak that a slower
        loading shows)."""
        st, curve = self.state, self.curve
        no_peak = st.peak_closure is None and self.closure() >= self.max_strain * self.size
        point = 0 if no_peak else self._rewind_points()[-1]
        kept, _, saved = self._saved[point]
        st.samples = kept
        self._saved = []
        steps = s.step_count
        s.restore_state(saved)
        st.steps_discarded += steps - s.step_count
        for series in (curve.time, curve.closure, curve.load, curve.n_cracks,
                       *curve.extra.values()):
            del series[kept:]
        st.approaching, st.stop_reason, st.peak_closure = False, None, None
        st.peak = max(curve.load, default=0.0)

    def _sample(self, s: MechanicsSolver) -> None:
        st, curve = self.state, self.curve
        load, closure = self.load(), self.closure()
        curve.time.append(s.time)
        curve.closure.append(closure)
        curve.load.append(load)
        curve.n_cracks.append(len(s.cracks.contact))
        for name, monitor in self.monitors.items():
            curve.extra[name].append(float(monitor(s)))
        st.peak = max(st.peak, load)
        if load < self.stop_fraction * st.peak:
            st.stop_reason = f"load fell below {self.stop_fraction:g} x peak"
            return
        if st.peak_closure is None:
            index, found = first_peak(curve.load, self.peak_drop_fraction)
            if found:
                st.peak_closure = curve.closure[index]
        elif closure >= self.post_peak_factor * st.peak_closure:
            st.stop_reason = f"closure reached {self.post_peak_factor:g} x closure at peak"
            return
        if closure >= self.max_strain * self.size:
            st.stop_reason = f"closure reached max_strain {self.max_strain:g} x size"

    def finished(self) -> bool:
        return self.state.stop_reason is not None

    def fraction(self) -> float:
        return min(1.0, self.closure() / (self.max_strain * self.size))
