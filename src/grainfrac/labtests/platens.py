"""Specimens between platens: the set-up of UCS, BTS and NSCB.

Rigid, frictionless platens (penalty contact, :class:`~grainfrac.loading.boundary.Platen`)
are placed on the specimen here; the loading itself is the
:class:`~grainfrac.stages.platen.PlatenLoading` stage, run by the driver
(see :class:`~grainfrac.labtests.config.LoadingSpec`).
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
from grainfrac.stages.driver import Driver, Hooks
from grainfrac.stages.platen import LoadingCurve, PlatenLoading
from grainfrac.stages.world import World
from grainfrac.units import MM


def penalty_stiffness(assembly: GrainAssembly, model: MechanicalModel,
                      nodes: np.ndarray) -> np.ndarray:
    """Per-node platen stiffness (N/m): a grain-contact spring of one zone's area,
    capped at the node's own stiffness bound so the platen never limits the time
    step (a spring as stiff as the node's row at most halves the stable margin,
    which safety 0.5 allows; with 1000x stiffer contacts the uncapped spring
    blew up at step 8)."""
    mesh = assembly.mesh
    # One zone's contact area: a zone edge x the unit thickness in 2D, a zone face in 3D.
    area = mesh.zone_size * (mesh.thickness if mesh.dimension == 2 else mesh.zone_size)
    k = float(np.median(model.normal_stiffness)) * area
    return np.minimum(k, model.nodal_stiffness[nodes])


def closing_platen(assembly: GrainAssembly, model: MechanicalModel, nodes: np.ndarray,
                   side: int, speed: float, axis: int = 1) -> Platen:
    """A platen on ``nodes`` along ``axis`` (default y), touching them at rest, closing
    at ``speed`` (m/s).

    ``side = +1``: on the positive side of the specimen, moving towards negative
    ``axis``; ``-1``: the opposite; ``speed = 0`` makes a fixed support.
    """
    x = assembly.mesh.node_x[nodes, axis]
    position = float(x.max() if side > 0 else x.min())
    return Platen(np.asarray(nodes, dtype=np.int64), axis, side, position, -side * speed,
                  penalty_stiffness(assembly, model, nodes))


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
              safety: float = 0.5) -> PlatenTest:
        """``place(assembly, model, loads) -> loading platens``; ``place`` may add
        supports and fixed components to ``loads``, the loading platens are added here.
        ``safety``: the time step's fraction of the critical step (the masses do not
        depend on it, so halving it halves the step alone)."""
        model = build_mechanical_model(assembly, safety=safety)
        loads = Loads.free(model.n_nodes, model.dimension)
        loading = place(assembly, model, loads)
        loads.platens.extend(loading)
        solver = MechanicsSolver(model, loads)
        return cls(assembly, model, solver, loading, size, dict(monitors or {}))

    def loading_stage(self, spec: LoadingSpec) -> PlatenLoading:
        """The platen-loading stage of this test as ``spec`` (resolved: no unset field) says."""
        return PlatenLoading(
            self.loading, self.size, speed=spec.platen_speed_mm_per_s * MM,
            sample_steps=spec.sample_steps, stop_fraction=spec.stop_fraction,
            peak_drop_fraction=spec.peak_drop_fraction, post_peak_factor=spec.post_peak_factor,
            max_strain=spec.max_strain, monitors=self.monitors,
            approach_factor=spec.approach_speed_factor)

    def run(self, spec: LoadingSpec, progress: Callable[[LoadingCurve], None] | None = None,
            ) -> tuple[LoadingCurve, str, int]:
        """Load to failure on the driver; return the curve, why it stopped and the steps
        a fast approach discarded. ``progress(curve)`` is called after every sample."""
        stage = self.loading_stage(spec)
        Driver([stage], World(self.assembly, self.solver), _CurveProgress(progress)).execute()
        return stage.curve, stage.state.stop_reason, stage.state.steps_discarded


class _CurveProgress(Hooks):
    def __init__(self, progress: Callable[[LoadingCurve], None] | None):
        self.progress = progress

    def after_chunk(self, stage: PlatenLoading) -> None:
        if self.progress is not None:
            self.progress(stage.curve)
