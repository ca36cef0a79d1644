"""Stages as objects, run by one driver.

A run is a list of stages (:class:`~grainfrac.stages.base.Stage`: begin,
advance, finished, state) that a :class:`~grainfrac.stages.driver.Driver`
executes on a :class:`~grainfrac.stages.world.World`. A scenario's stages
come from its configuration (:func:`from_scenario`); lab tests and the
verification cases build theirs directly.
"""

from __future__ import annotations

from pathlib import Path

from grainfrac.scenario import Scenario
from grainfrac.stages.base import Stage
from grainfrac.stages.drill_out import DrillOut
from grainfrac.stages.driver import Driver, DriverState, Hooks
from grainfrac.stages.equilibrate import Equilibrate
from grainfrac.stages.inject import Inject
from grainfrac.stages.platen import PlatenLoading
from grainfrac.stages.scda import ScdaCharge
from grainfrac.stages.world import World


def from_scenario(scenario: Scenario, base_dir: Path | None = None) -> list[Stage]:
    """The stage objects of ``scenario.stages``, in order."""
    sigma_x, sigma_y = scenario.stress.resolved_Pa()
    sigma_z = scenario.stress.sigma_z_Pa if scenario.dimension == 3 else 0.0

    def equilibrate(spec):
        return Equilibrate(sigma_x, sigma_y, ratio=spec.unbalanced_ratio,
                           max_steps=spec.max_steps, sigma_z=sigma_z, method=spec.method)

    build = {
        "equilibrate": equilibrate,
        "scda": lambda spec: ScdaCharge(spec, spec.material(base_dir)),
        "drill_out": DrillOut,
        "inject": lambda spec: Inject(spec, scenario.fluid),
    }
    return [build[spec.kind](spec) for spec in scenario.stages]


__all__ = ["DrillOut", "Driver", "DriverState", "Equilibrate", "Hooks", "Inject",
           "PlatenLoading", "ScdaCharge", "Stage", "World", "from_scenario"]
