"""Planning a sweep: every point's scenario built from the base and its overrides,
checked against the scenario schema and validated before any compute.
"""

from __future__ import annotations

import copy
import itertools
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from grainfrac.errors import ConfigError
from grainfrac.io.config import read_toml, validate
from grainfrac.scenario import ScdaStage, Scenario, resolved_dict
from grainfrac.studies.sweep.config import SweepConfig

__all__ = [
    "PlannedRun",
    "SweepPlan",
    "SweepPoint",
    "apply_overrides",
    "check_path",
    "load_sweep",
    "plan_sweep",
]


_STRESS_VALUES = ("sigma_x_MPa", "sigma_y_MPa", "sigma_z_MPa")


@dataclass(frozen=True, eq=False)
class PlannedRun:
    """One realisation of one point: where it runs and the exact scenario (resolved)."""

    point: str
    realisation: int
    seed: int
    scenario: dict[str, Any]

    @property
    def rel_dir(self) -> str:
        return f"runs/{self.point}/r{self.realisation}"


@dataclass(frozen=True, eq=False)
class SweepPoint:
    """A point of the sweep: its id, the values it sets and its realisations."""

    id: str
    values: dict[str, Any]
    runs: tuple[PlannedRun, ...]
    source: str = ""


@dataclass(frozen=True, eq=False)
class SweepPlan:
    """Everything a sweep will run, validated: points in order, realisations, quantities."""

    name: str
    points: tuple[SweepPoint, ...]
    parameters: tuple[str, ...]
    quantities: tuple[str, ...] | None = None
    retries: int = 2

    @property
    def runs(self) -> list[PlannedRun]:
        return [run for point in self.points for run in point.runs]

    def point(self, point_id: str) -> SweepPoint:
        for p in self.points:
            if p.id == point_id:
                return p
        raise KeyError(point_id)


@dataclass
class _Base:
    data: dict[str, Any]          # what the file or table says
    scenario: Scenario            # validated
    base_dir: Path | None         # for relative rock / SCDA paths
    source: str


def _load_base(source: str | dict[str, Any], base_dir: Path | None, where: str) -> _Base:
    if isinstance(source, dict):
        data, scen_dir, label = copy.deepcopy(source), base_dir, "inline"
    else:
        path = Path(source)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        if not path.is_file():
            raise ConfigError(where, f"scenario file not found: {path}")
        data, scen_dir, label = read_toml(path), path.parent, str(source)
    try:
        scenario = validate(Scenario, data)
        scenario.recipe(scen_dir)
    except ConfigError as exc:
        raise ConfigError(f"{where} ({label}): {exc.field}", exc.message) from None
    return _Base(data, scenario, scen_dir, label)


def _describe_fields(obj: Any) -> str:
    if isinstance(obj, BaseModel):
        return ", ".join(type(obj).model_fields)
    if isinstance(obj, dict):
        return ", ".join(map(str, obj))
    if isinstance(obj, list):
        return f"entries 0..{len(obj) - 1}"
    return "no fields"


def check_path(base: Scenario, path: str, base_dir: Path | None = None) -> list[str]:
    """Check that ``path`` names a field of ``base``; return the prefixes to write inline.

    Raises ``ValueError("unknown scenario field ...")`` naming what the parent has.
    Presets (``rock``, ``stages.N.scda``) are looked through, and their prefixes
    returned, so that the caller can write them inline before setting inside.
    """
    parts = path.split(".")
    obj: Any = base
    inline: list[str] = []
    for i, part in enumerate(parts):
        here = ".".join(parts[:i]) or "the scenario"
        deeper = i < len(parts) - 1
        if isinstance(obj, BaseModel):
            if part not in type(obj).model_fields:
                kind = f" ({obj.kind})" if isinstance(getattr(obj, "kind", None), str) else ""
                raise ValueError(f"unknown scenario field {path!r}: {here}{kind} has "
                                 f"{_describe_fields(obj)}")
            nxt = getattr(obj, part)
            if deeper and isinstance(nxt, str):
                if isinstance(obj, Scenario) and part == "rock":
                    nxt = obj.recipe(base_dir)
                    inline.append(".".join(parts[: i + 1]))
                elif isinstance(obj, ScdaStage) and part == "scda":
                    nxt = obj.material(base_dir)
                    inline.append(".".join(parts[: i + 1]))
            obj = nxt
        elif isinstance(obj, list | tuple):
            if not part.isdigit() or int(part) >= len(obj):
                raise ValueError(f"unknown scenario field {path!r}: {here} has "
                                 f"{_describe_fields(list(obj))}")
            obj = obj[int(part)]
        elif isinstance(obj, dict):
            if part not in obj:
                raise ValueError(f"unknown scenario field {path!r}: {here} has "
                                 f"{_describe_fields(obj)}")
            obj = obj[part]
        else:
            raise ValueError(f"unknown scenario field {path!r}: {here} is a value "
                             f"({obj!r}), not a table")
    return inline


def _set(data: Any, parts: list[str], value: Any) -> None:
    for part in parts[:-1]:
        if isinstance(data, list):
            data = data[int(part)]
        else:
            nxt = data.get(part)
            if not isinstance(nxt, dict | list):
                nxt = data[part] = {}
            data = nxt
    last = parts[-1]
    if isinstance(data, list):
        data[int(last)] = copy.deepcopy(value)
    else:
        data[last] = copy.deepcopy(value)


def _get(data: Any, parts: list[str]) -> Any:
    for part in parts:
        if isinstance(data, list):
            data = data[int(part)] if part.isdigit() and int(part) < len(data) else None
        elif isinstance(data, dict):
            data = data.get(part)
        else:
            return None
    return data


def apply_overrides(base: _Base, overrides: dict[str, Any]) -> dict[str, Any]:
    """The base's scenario data with ``overrides`` (dotted path -> value) applied."""
    data = copy.deepcopy(base.data)
    for path in overrides:
        for prefix in check_path(base.scenario, path, base.base_dir):
            parts = prefix.split(".")
            if isinstance(_get(data, parts), str | type(None)):
                owner = base.scenario
                if prefix == "rock":
                    material = owner.recipe(base.base_dir)
                else:
                    material = owner.stages[int(parts[1])].material(base.base_dir)
                _set(data, parts, material.model_dump(mode="json"))
    for path, value in overrides.items():
        _set(data, path.split("."), value)
    # The stress is a case or values: setting one side replaces the other.
    sigmas = {k: overrides[f"stress.{k}"] for k in _STRESS_VALUES if f"stress.{k}" in overrides}
    stress = data.get("stress")
    if isinstance(stress, dict) and "stress" not in overrides:
        if "stress.case" in overrides and not sigmas:
            for key in _STRESS_VALUES:
                stress.pop(key, None)
        elif sigmas and "stress.case" not in overrides:
            # The case's values stand for the ones not set (sigma_z acts in 3D only).
            kept = _STRESS_VALUES if base.scenario.dimension == 3 else _STRESS_VALUES[:2]
            resolved = base.scenario.stress.model_dump(include=set(kept))
            data["stress"] = {**resolved, **sigmas}
    return data


def _slug(value: Any) -> str:
    if isinstance(value, float):
        text = f"{value:g}"
    elif isinstance(value, dict | list):
        text = json.dumps(value, sort_keys=True)
    else:
        text = str(value)
    return re.sub(r"[^A-Za-z0-9.]+", "-", text).strip("-.") or "x"


def _axis_points(config: SweepConfig) -> list[tuple[str, dict[str, Any], list[str]]]:
    """(id, overrides, the sweep fields of the overrides) of every grid / zip point."""
    axes = config.parameters
    if not axes:
        return [("base", {}, [])]
    short = [axis.path.rsplit(".", 1)[-1] for axis in axes]
    names = short if len(set(short)) == len(short) else [a.path.replace(".", "-") for a in axes]
    index_sets = (zip(*(range(len(a.values)) for a in axes), strict=True)
                  if config.combine == "zip"
                  else itertools.product(*(range(len(a.values)) for a in axes)))
    points = []
    for idx in index_sets:
        labels, overrides, fields = [], {}, []
        for i, (axis, j) in enumerate(zip(axes, idx, strict=True)):
            value = axis.values[j]
            labels.append(axis.labels[j] if axis.labels else f"{names[i]}-{_slug(value)}")
            overrides[axis.path] = value
            fields.append(f"parameters.{i}.values.{j}")
        pid = "_".join(_slug(label) for label in labels if label) or f"p{len(points)}"
        points.append((pid, overrides, fields))
    return points


def _field_for(exc: ConfigError, overrides: dict[str, Any], fields: list[str]) -> str | None:
    """The sweep field whose value caused ``exc``: the same path, or a sibling of it
    (a check across fields such as ``grains.min_edge_mm < max_edge_mm``)."""
    for path, where in zip(overrides, fields, strict=True):
        if exc.field == path or exc.field.startswith(path + ".") or path.startswith(
                exc.field + "."):
            return where
    parent = exc.field.rpartition(".")[0]
    for path, where in zip(overrides, fields, strict=True):
        if parent and path.rpartition(".")[0] == parent:
            return where
    return None


def plan_sweep(config: SweepConfig | dict[str, Any], base_dir: str | Path | None = None
               ) -> SweepPlan:
    """Validate a sweep completely and list every run; no compute.

    ``base_dir`` is where relative scenario paths are looked up (the sweep
    file's directory). Raises :class:`ConfigError` naming the sweep field.
    """
    if not isinstance(config, SweepConfig):
        config = validate(SweepConfig, config)
    base_dir = Path(base_dir) if base_dir is not None else None
    default = _load_base(config.base, base_dir, "base")
    for path in config.set:
        try:
            check_path(default.scenario, path, default.base_dir)
        except ValueError as exc:
            raise ConfigError(f"set.{path}", str(exc)) from None

    specs: list[tuple[str, dict[str, Any], list[str], _Base]] = []
    if config.points:
        for i, point in enumerate(config.points):
            base = (default if point.base is None
                    else _load_base(point.base, base_dir, f"points.{i}.base"))
            specs.append((point.id or f"p{i}", dict(point.set),
                          [f"points.{i}.set.{p}" for p in point.set], base))
    else:
        for i, axis in enumerate(config.parameters):
            try:
                check_path(default.scenario, axis.path, default.base_dir)
            except ValueError as exc:
                raise ConfigError(f"parameters.{i}.path", str(exc)) from None
        specs = [(pid, ov, fields, default) for pid, ov, fields in _axis_points(config)]

    ids = [s[0] for s in specs]
    for pid in ids:
        if ids.count(pid) > 1:
            raise ConfigError("parameters", f"two points get the id {pid!r}; give labels")

    with_base = bool(config.points) and any(p.base is not None for p in config.points)
    parameters: list[str] = ["base"] if with_base else []
    points: list[SweepPoint] = []
    for pid, overrides, fields, base in specs:
        for path, where in zip(overrides, fields, strict=True):
            if config.points:
                try:
                    check_path(base.scenario, path, base.base_dir)
                except ValueError as exc:
                    raise ConfigError(where, str(exc)) from None
            if path not in parameters:
                parameters.append(path)
        merged = {**config.set, **overrides}
        data = apply_overrides(base, merged)
        if "name" not in merged:
            data["name"] = f"{config.name}-{pid}"
        try:
            scenario = validate(Scenario, data)
            recipe = scenario.recipe(base.base_dir)
            seeds = (list(config.seeds) if config.seeds is not None
                     else [scenario.seed + r for r in range(config.n_realisations)])
            runs = tuple(PlannedRun(pid, k, seed, resolved_dict(scenario.with_seed(seed), recipe,
                                                                  base.base_dir))
                         for k, seed in enumerate(seeds))
        except ConfigError as exc:
            where = _field_for(exc, {**overrides, **config.set},
                               fields + [f"set.{path}" for path in config.set])
            if where is None:
                raise ConfigError(exc.field, f"{exc.message} (sweep point {pid})") from None
            raise ConfigError(where, f"{exc.field}: {exc.message}") from None
        values = {"base": base.source} if with_base else {}
        points.append(SweepPoint(pid, {**values, **overrides}, runs, source=base.source))
    return SweepPlan(config.name, tuple(points), tuple(parameters),
                     tuple(config.quantities) if config.quantities else None, config.retries)


def load_sweep(path: str | Path) -> SweepPlan:
    """Read, validate and plan a sweep TOML file (relative paths beside it)."""
    path = Path(path)
    config = validate(SweepConfig, read_toml(path))
    return plan_sweep(config, path.parent)
