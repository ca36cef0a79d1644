"""Quasi-static platen loading to failure: the engine of UCS, BTS and NSCB.

Rigid, frictionless platens (penalty contact, :class:`~grainfrac.loading.boundary.Platen`)
close at a constant speed; the load they carry is sampled every few hundred
steps until the specimen has failed (see :class:`~grainfrac.labtests.config.LoadingSpec`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.labtests.config import LoadingSpec
from grainfrac.loading.boundary import Loads, Platen
from grainfrac.physics.model import MechanicalModel, build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import MM

RAMP_SAMPLES = 20  # samples over which the platen speed ramps up from zero


def penalty_stiffness(assembly: GrainAssembly, model: MechanicalModel,
                      nodes: np.ndarray) -> np.ndarray:
    """Per-node platen stiffness (N/m): a grain-contact spring of one zone's area,
    capped at the node's own stiffness bound so the platen never limits the time
    step (a spring as stiff as the node's row at most halves the stable margin,
    which safety 0.5 allows; with 1000x stiffer contacts the uncapped spring
    blew up at step 8)."""
    mesh = assembly.mesh
    k = float(np.median(model.normal_stiffness)) * mesh.zone_size * mesh.thickness
    return np.minimum(k, model.nodal_stiffness[nodes])


def closing_platen(assembly: GrainAssembly, model: MechanicalModel, nodes: np.ndarray,
                   side: int, speed: float) -> Platen:
    """A platen on ``nodes`` along y, touching them at rest, closing at ``speed`` (m/s).

    ``side = +1``: above the specimen, moving down; ``-1``: below, moving up;
    ``speed = 0`` makes a fixed support.
    """
    y = assembly.mesh.node_xy[nodes, 1]
    position = float(y.max() if side > 0 else y.min())
    return Platen(np.asarray(nodes, dtype=np.int64), 1, side, position, -side * speed,
                  penalty_stiffness(assembly, model, nodes))


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
class PlatenTest:
    """A specimen between platens, ready to load.

    ``loading`` are the platens whose closure drives the test (their mean
    reaction is the load); ``supports`` are fixed platens (NSCB rollers).
    ``size`` (m) turns closure into the nominal strain of ``max_strain``.
    """

    assembly: GrainAssembly
    model: MechanicalModel
    solver: MechanicsSolver
    loading: list[Platen]
    size: float
    monitors: dict[str, Callable[[MechanicsSolver], float]] = field(default_factory=dict)

    @classmethod
    def build(cls, assembly: GrainAssembly, place: Callable, size: float,
              monitors: dict[str, Callable[[MechanicsSolver], float]] | None = None,
              ) -> PlatenTest:
        """``place(assembly, model, loads) -> loading platens``; ``place`` may add
        supports and fixed components to ``loads``, the loading platens are added here."""
        model = build_mechanical_model(assembly)
        loads = Loads.free(model.n_nodes)
        loading = place(assembly, model, loads)
        loads.platens.extend(loading)
        solver = MechanicsSolver(model, loads)
        return cls(assembly, model, solver, loading, size, dict(monitors or {}))

    def load(self) -> float:
        """Mean compressive force of the loading platens (N)."""
        return float(np.mean([p.side * p.reaction for p in self.loading]))

    def closure(self, start: list[float]) -> float:
        return float(sum(p.side * (s - p.position) for p, s in zip(self.loading, start,
                                                                    strict=True)))

    def run(self, spec: LoadingSpec, progress: Callable[[LoadingCurve], None] | None = None,
            ) -> tuple[LoadingCurve, str]:
        """Load to failure as ``spec`` (resolved: no unset field) says; return the
        curve and why it stopped."""
        speed = spec.platen_speed_mm_per_s * MM
        start = [p.position for p in self.loading]
        curve = LoadingCurve(extra={name: [] for name in self.monitors})
        s = self.solver
        peak = 0.0
        peak_closure = None
        max_closure = spec.max_strain * self.size
        sample = 0
        while True:
            # A sudden start sends a stress wave that reads as an early peak: ramp up.
            ramp = min(1.0, (sample + 1) / RAMP_SAMPLES)
            for p in self.loading:
                p.velocity = -p.side * speed * ramp
            sample += 1
            s.cycle(spec.sample_steps)
            load, closure = self.load(), self.closure(start)
            curve.time.append(s.time)
            curve.closure.append(closure)
            curve.load.append(load)
            curve.n_cracks.append(len(s.cracks.contact))
            for name, monitor in self.monitors.items():
                curve.extra[name].append(float(monitor(s)))
            if progress is not None:
                progress(curve)
            peak = max(peak, load)
            if load < spec.stop_fraction * peak:
                return curve, f"load fell below {spec.stop_fraction:g} x peak"
            if peak_closure is None:
                index, found = first_peak(curve.load, spec.peak_drop_fraction)
                if found:
                    peak_closure = curve.closure[index]
            elif closure >= spec.post_peak_factor * peak_closure:
                return curve, f"closure reached {spec.post_peak_factor:g} x closure at peak"
            if closure >= max_closure:
                return curve, f"closure reached max_strain {spec.max_strain:g} x size"
