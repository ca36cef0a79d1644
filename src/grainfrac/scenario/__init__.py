"""Scenario files: specimen, in-situ stress, fluid and the sequence of stages of a run.

A scenario is what ``grainfrac run SCENARIO.toml`` executes: the specimen part
(the same ``seed``, ``rock``, ``specimen``, ``grains`` and ``fissures`` as a
specimen file, see :class:`grainfrac.assembly.SpecimenConfig`), the in-situ
stress (paper Table 6), the fluid (paper Table 4) and a list of stages:

``equilibrate``
    apply the far-field stresses and equilibrate (always the first stage);
``scda``
    charge the borehole with SCDA expanding at ``v = f exp(-b t)`` (paper
    Eq. 9, Table 5) until the expansive pressure reaches its peak or ``v``
    decays below ``min_velocity_fraction x f``;
``drill_out``
    remove the SCDA from the borehole and let the rock relax;
``inject``
    inject fluid at a constant rate into the well (XLOT: injection continues
    past breakdown) for ``duration_ms`` and/or until ``volume_ml`` is injected.

The paper's designs are ``[equilibrate, scda]`` (SCDA charging, Sect. 5.1),
``[equilibrate, inject]`` (HS, Sect. 5.2-5.6) and
``[equilibrate, scda, drill_out, inject]`` (the hybrid method, Sect. 6).

Units are the field's (MPa, mm, ml/min, ms); in-situ stresses are compressive
magnitudes as in the paper. Every problem is reported before any compute as a
one-line :class:`~grainfrac.errors.ConfigError` naming the field, e.g.
``config error at stages.1.kind: inject must come after drill_out ...``.

Example::

    scenario, recipe = load_scenario("examples/hybrid-case2-90mlmin.toml")
    assembly = build_assembly(scenario.specimen_config(), recipe)

The package's modules, one job each:

* ``scenario.config``: the :class:`Scenario` and its checks across sections;
* ``scenario.stress``, ``scenario.fluid``, ``scenario.numerics``,
  ``scenario.output``: one section of a scenario each;
* ``scenario.stages``: the stage schemas and the default injection design;
* ``scenario.sizes``: the size checks made before anything is built;
* ``scenario.files``: loading ``SCENARIO.toml``, writing the resolved ``config.toml``;
* ``scenario.presets``: the paper's designs (:func:`hs_only`, :func:`hybrid`).

Every public name is importable from ``grainfrac.scenario`` itself.
"""

from __future__ import annotations

from grainfrac.scenario.config import Scenario
from grainfrac.scenario.files import load_scenario, resolved_dict, write_resolved
from grainfrac.scenario.fluid import SPECIMEN_SIDES, FluidSpec
from grainfrac.scenario.numerics import NumericsSpec as NumericsSpec
from grainfrac.scenario.output import MAX_CHECKPOINT_EVERY_STEPS as MAX_CHECKPOINT_EVERY_STEPS
from grainfrac.scenario.output import OutputSpec
from grainfrac.scenario.presets import hs_only, hybrid
from grainfrac.scenario.sizes import BOREHOLE_MIN_ZONES as BOREHOLE_MIN_ZONES
from grainfrac.scenario.sizes import ELEMENTS_PER_ZONE_AREA as ELEMENTS_PER_ZONE_AREA
from grainfrac.scenario.sizes import MAX_ELEMENTS as MAX_ELEMENTS
from grainfrac.scenario.sizes import MAX_ELEMENTS_3D as MAX_ELEMENTS_3D
from grainfrac.scenario.sizes import TETS_PER_ZONE_VOLUME as TETS_PER_ZONE_VOLUME
from grainfrac.scenario.sizes import check_size, estimated_elements
from grainfrac.scenario.stages import (
    BOREHOLE_STAGES,
    DEFAULT_INJECT_DURATION_MS,
    DEFAULT_RATE_ML_PER_MIN,
    STAGE_KINDS,
    STAGE_MODELS,
    DrillOutStage,
    EquilibrateStage,
    InjectStage,
    ScdaStage,
    Stage,
    default_inject_duration_ms,
)
from grainfrac.scenario.stages import MAX_STAGE_MS as MAX_STAGE_MS
from grainfrac.scenario.stress import InSituStress
from grainfrac.scenario.stress import StressCase as StressCase

__all__ = [
    "BOREHOLE_STAGES", "DEFAULT_INJECT_DURATION_MS", "DEFAULT_RATE_ML_PER_MIN",
    "SPECIMEN_SIDES", "STAGE_KINDS", "STAGE_MODELS", "DrillOutStage", "EquilibrateStage",
    "FluidSpec", "InSituStress", "InjectStage", "OutputSpec", "Scenario", "ScdaStage", "Stage",
    "check_size", "default_inject_duration_ms", "estimated_elements", "hs_only", "hybrid",
    "load_scenario", "resolved_dict", "write_resolved",
]
