"""Scenario files: reading and validating ``SCENARIO.toml`` with its materials, and
writing the resolved scenario (``config.toml`` of a run directory).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grainfrac import materials
from grainfrac.errors import ConfigError
from grainfrac.io.config import read_toml, validate
from grainfrac.io.files import write_toml
from grainfrac.scenario.config import Scenario, _scda_material
from grainfrac.scenario.stages import ScdaStage

__all__ = [
    "load_scenario",
    "resolved_dict",
    "write_resolved",
]


def load_scenario(path: str | Path) -> tuple[Scenario, materials.RockRecipe]:
    """Read and validate a scenario TOML file and resolve its rock recipe.

    The rock and SCDA materials given as paths are resolved relative to the
    file; SCDA paths are returned absolute so the scenario no longer depends on
    the file's directory. Every material is loaded here, so a bad one fails
    before any compute.
    """
    path = Path(path)
    base = path.parent
    scenario = validate(Scenario, read_toml(path))
    try:
        recipe = scenario.recipe(base)
    except ConfigError as exc:
        if exc.field == "rock" or exc.field.startswith("rock."):
            raise
        # A recipe file's own problem (missing, not UTF-8...): say which field named it.
        raise ConfigError("rock", f"{exc.field}: {exc.message}") from None
    stages = []
    for i, stage in enumerate(scenario.stages):
        if isinstance(stage, ScdaStage):
            _scda_material(stage, i, base)  # fails early on a bad material
            if isinstance(stage.scda, str):
                candidate = Path(stage.scda)
                if not candidate.is_absolute() and (base / candidate).is_file():
                    stage = stage.model_copy(update={"scda": str((base / candidate).resolve())})
        stages.append(stage)
    if stages != scenario.stages:
        scenario = scenario.model_copy(update={"stages": stages})
    return scenario, recipe


def _drop_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _drop_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list | tuple):
        return [_drop_none(v) for v in value]
    return value


def resolved_dict(
    scenario: Scenario, recipe: materials.RockRecipe, base_dir: Path | None = None
) -> dict[str, Any]:
    """The scenario with every default filled in, as plain data for ``config.toml``.

    The rock recipe and SCDA materials are written inline; the stress has both
    its case (if any) and its values. Keys whose value is None are left out
    (TOML has no null); loading the result gives the same scenario.
    """
    full = scenario.resolved(recipe, base_dir)
    return _drop_none(full.model_dump(mode="json"))


def write_resolved(
    path: str | Path, scenario: Scenario, recipe: materials.RockRecipe,
    base_dir: Path | None = None,
) -> Path:
    """Write the resolved scenario (``config.toml`` of a run directory), atomically."""
    return write_toml(path, resolved_dict(scenario, recipe, base_dir))
