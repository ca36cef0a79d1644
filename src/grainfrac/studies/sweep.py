"""Parameter sweeps and ensembles on Dask: ``grainfrac sweep SWEEP.toml --out DIR``.

A sweep is a base scenario, the points to run it at and the realisations
(grain structures) per point. ``SWEEP.toml``::

    name = "hs-rate"
    base = "../hs-case2-18mlmin.toml"    # a scenario file (relative to this file) or a [base] table
    realisations = 3                     # realisation r uses seed = the point's seed + r
    # seeds = [0, 7, 11]                 # ... or a listed set of seeds
    combine = "grid"                     # "grid": every combination; "zip": i-th with i-th
    set = { "output.snapshot_every_ms" = 10.0 }   # applied at every point

    [[parameters]]                       # any dotted path into the scenario
    path = "stages.1.rate_ml_per_min"
    values = [18.0, 42.0, 66.0]

    [[parameters]]
    path = "stages.1.duration_ms"
    values = [40.0, 17.1, 10.9]

Instead of ``parameters``, explicit ``[[points]]`` may each name an ``id``, their
own ``base`` and the paths they ``set``. Paths are checked against the scenario
schema and every point's scenario is validated before any compute: an unknown
path or a bad value is one :class:`~grainfrac.errors.ConfigError` naming the
sweep field (``parameters.0.path``, ``parameters.1.values.2``, ``points.3.set``).

Setting ``stress.case`` replaces the base's stress values; setting
``stress.sigma_x_MPa`` / ``sigma_y_MPa`` alone drops the base's case and keeps
its other value. Paths into ``rock`` or an SCDA stage's ``scda`` write the
preset inline first, so ``rock.weibull.shape`` can be varied.

Output directory::

    DIR/runs/<point-id>/r<k>/   one run directory per realisation (grainfrac run layout)
    DIR/runs.csv                one row per run: point, realisation, seed, status, the
                                point's parameter values, wall time, every summary value
    DIR/stats.csv               one row per point and quantity: n, mean, std (ddof 1),
                                95 % Student-t CI
    DIR/runs.parquet, DIR/stats.parquet   the same, only if pyarrow is importable
    DIR/sweep.json              the plan (points, values, seeds) and the last invocation

A run is done when its ``summary.json`` (written atomically, last) is valid
and its ``config.toml`` is the planned scenario; re-running a sweep skips done
runs and resumes a run that has a checkpoint. A finished run of a *different*
scenario at a planned place is an error, never silently reused. The tables
are rebuilt from the run directories alone, so a worker that dies (Dask
reschedules its task; ``retries`` covers exceptions) can neither lose nor
duplicate a row, and the same sweep and seeds always give the same tables.
"""

from __future__ import annotations

import copy
import importlib.util
import itertools
import json
import logging
import math
import os
import re
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, Field, field_validator, model_validator

from grainfrac.analysis import stats
from grainfrac.errors import ConfigError, GrainfracError
from grainfrac.io.config import StrictModel, read_toml, validate
from grainfrac.io.files import write_csv, write_json
from grainfrac.scenario import ScdaStage, Scenario, resolved_dict

# summary.json keys (docs/outputs.md), in table order.
SCALAR_QUANTITIES = (
    "breakdown_pressure_MPa", "breakdown_time_s", "peak_well_pressure_MPa",
    "peak_expansive_pressure_MPa", "injected_volume_ml", "n_grains", "n_elements",
    "n_contacts", "n_cracks", "n_tensile_cracks", "n_shear_cracks", "tensile_shear_ratio",
    "n_radial_fractures", "fracture_extent_mm", "tortuosity", "energy_tensile_J",
    "energy_shear_J", "energy_friction_J", "in_situ_unbalanced_force_ratio",
)
# Dict-valued summary keys whose numeric entries become "<key>.<entry>" quantities.
GROUPED_QUANTITIES = ("contact_fraction_total", "contact_fraction_failed", "energy_balance_J")
# Summary keys that identify or time a run rather than measure it (not in stats.csv:
# wall time differs between identical runs).
_NOT_QUANTITIES = {"grainfrac_version", "scenario", "seed", "wall_time_s", "stages",
                   "stage_times_s"}
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")
_STRESS_VALUES = ("sigma_x_MPa", "sigma_y_MPa")

RUNS_TABLE = "runs.csv"
STATS_TABLE = "stats.csv"
PLAN_FILE = "sweep.json"
FAILED_FILE = "failed.json"


class SweepError(GrainfracError):
    """A sweep cannot start or continue (stale results, unreachable scheduler)."""


# --------------------------------------------------------------------------- schema


def _flatten_set(values: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"stress": {"case": "case1"}}`` and ``{"stress.case": "case1"}`` alike -> dotted paths."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        path = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out.update(_flatten_set(value, path + "."))
        else:
            out[path] = value
    return out


class AxisSpec(StrictModel):
    """One varied parameter: a dotted scenario path and its values."""

    path: str = Field(min_length=1, description="dotted path into the scenario, e.g. stress.case")
    values: list[Any] = Field(min_length=1, description="values, in order")
    labels: list[str] | None = Field(
        None, description="names of the values in point ids (empty: left out of the id)")

    @model_validator(mode="after")
    def _labels(self) -> AxisSpec:
        if self.labels is not None and len(self.labels) != len(self.values):
            raise ValueError(f"labels: need one per value ({len(self.values)}) "
                             f"(got {len(self.labels)})")
        return self


class PointSpec(StrictModel):
    """One explicit sweep point: an id, optionally its own base, and the paths it sets."""

    id: str | None = Field(None, description="point id (directory name)")
    base: str | dict[str, Any] | None = Field(None, description="scenario file or table")
    set: dict[str, Any] = Field(default_factory=dict, description="dotted path -> value")

    @field_validator("set")
    @classmethod
    def _dotted(cls, value: dict[str, Any]) -> dict[str, Any]:
        return _flatten_set(value)


def _known_quantity(name: str) -> bool:
    if name in SCALAR_QUANTITIES:
        return True
    group, _, entry = name.partition(".")
    return group in GROUPED_QUANTITIES and bool(entry)


class SweepConfig(StrictModel):
    """``SWEEP.toml``: a base scenario, the points and the realisations per point."""

    name: str = Field("sweep", description="sweep name")
    base: str | dict[str, Any] = Field(description="scenario file (relative to the sweep "
                                       "file) or an inline scenario table")
    set: dict[str, Any] = Field(default_factory=dict,
                                description="dotted path -> value, applied at every point")
    parameters: list[AxisSpec] = Field(default_factory=list, description="varied parameters")
    combine: Literal["grid", "zip"] = Field("grid", description="grid or zip of parameters")
    points: list[PointSpec] = Field(default_factory=list, description="explicit points")
    realisations: int | None = Field(None, ge=1, le=100_000,
                                     description="realisations per point (default 1)")
    seeds: list[int] | None = Field(None, min_length=1, description="explicit seeds")
    quantities: list[str] | None = Field(
        None, min_length=1, description="summary values to aggregate (default: all)")
    retries: int = Field(2, ge=0, le=100, description="Dask retries of a failing task")

    @field_validator("set")
    @classmethod
    def _dotted(cls, value: dict[str, Any]) -> dict[str, Any]:
        return _flatten_set(value)

    @model_validator(mode="after")
    def _check(self) -> SweepConfig:
        if self.parameters and self.points:
            raise ValueError("points: give parameters or points, not both")
        paths = [axis.path for axis in self.parameters]
        for i, path in enumerate(paths):
            if path in paths[:i]:
                raise ValueError(f"parameters.{i}.path: {path!r} is varied twice")
            if path in self.set:
                raise ValueError(f"parameters.{i}.path: {path!r} is also fixed in set")
        if self.combine == "zip":
            n = len(self.parameters[0].values) if self.parameters else 0
            for i, axis in enumerate(self.parameters):
                if len(axis.values) != n:
                    raise ValueError(f"parameters.{i}.values: combine = \"zip\" needs as many "
                                     f"values as parameters.0 ({n}) (got {len(axis.values)})")
        ids = [p.id for p in self.points if p.id is not None]
        for i, point in enumerate(self.points):
            if point.id is not None and not _ID.match(point.id):
                raise ValueError(f"points.{i}.id: letters, digits, '.', '_' and '-' only, "
                                 f"starting with a letter or digit (got {point.id!r})")
            if point.id is not None and ids.count(point.id) > 1:
                raise ValueError(f"points.{i}.id: {point.id!r} is used twice")
        if self.seeds is not None:
            for i, seed in enumerate(self.seeds):
                if seed < 0:
                    raise ValueError(f"seeds.{i}: must be >= 0 (got {seed})")
                if seed in self.seeds[:i]:
                    raise ValueError(f"seeds.{i}: seed {seed} is listed twice")
            if self.realisations is not None and self.realisations != len(self.seeds):
                raise ValueError(f"realisations: {self.realisations} does not match the "
                                 f"{len(self.seeds)} listed seeds (give one of them)")
        for i, name in enumerate(self.quantities or []):
            if not _known_quantity(name):
                raise ValueError(
                    f"quantities.{i}: unknown quantity {name!r}; known: "
                    + ", ".join(SCALAR_QUANTITIES)
                    + ", or <group>.<entry> of " + ", ".join(GROUPED_QUANTITIES))
        return self

    @property
    def n_realisations(self) -> int:
        return len(self.seeds) if self.seeds is not None else (self.realisations or 1)


# --------------------------------------------------------------------------- plan


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
            sx, sy = base.scenario.stress.resolved()
            data["stress"] = {"sigma_x_MPa": sx, "sigma_y_MPa": sy, **sigmas}
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


# --------------------------------------------------------------------------- run state


def _normal(data: Any) -> Any:
    """A scenario as the current schema sees it: defaults filled, JSON types.

    Comparing validated dumps, not raw files, keeps a run done when a newer
    grainfrac adds a field with a default; a real change still differs.
    """
    try:
        return validate(Scenario, data).model_dump(mode="json")
    except ConfigError:
        return json.loads(json.dumps(data, sort_keys=True))


def _first_difference(a: Any, b: Any, prefix: str = "") -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            found = _first_difference(a.get(key), b.get(key), f"{prefix}{key}.")
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            found = _first_difference(x, y, f"{prefix}{i}.")
            if found:
                return found
        return None
    return None if a == b else prefix.rstrip(".") or "<root>"


def read_summary(run_dir: Path) -> dict[str, Any] | None:
    """The run's summary.json if it is complete and valid, else None."""
    path = Path(run_dir) / "summary.json"
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict) or not {"seed", "n_cracks"} <= summary.keys():
        return None
    return summary


def _stored_config(run_dir: Path) -> dict[str, Any] | None:
    try:
        return read_toml(Path(run_dir) / "config.toml")
    except ConfigError:
        return None


def run_state(run_dir: Path, scenario: dict[str, Any]) -> tuple[str, str | None]:
    """``("done" | "todo" | "stale", detail)`` of one planned run directory.

    ``stale``: a finished run whose config.toml is not the planned scenario
    (``detail`` names the first differing field).
    """
    summary = read_summary(run_dir)
    if summary is None:
        return "todo", None
    stored = _stored_config(run_dir)
    if stored is None:
        return "stale", "config.toml missing or unreadable"
    diff = _first_difference(_normal(stored), _normal(scenario))
    if diff is not None:
        return "stale", f"config.toml differs at {diff}"
    if summary.get("seed") != scenario.get("seed"):
        return "stale", "summary.json has another seed"
    return "done", None


def execute_run(run_dir: str, scenario: dict[str, Any]) -> dict[str, Any]:
    """Run one realisation into ``run_dir`` unless it is done (the Dask task).

    A run with a checkpoint of the same scenario resumes (a resumed run
    retraces an uninterrupted one exactly). A :class:`GrainfracError` (e.g. a
    numerical blow-up) is recorded in ``failed.json`` and returned as data; any
    other exception propagates, so that Dask retries the task.
    """
    from grainfrac.run import checkpoint_path
    from grainfrac.simulation import run_scenario

    out = Path(run_dir)
    if run_state(out, scenario)[0] == "done":
        return {"status": "done", "computed": False}
    sc = validate(Scenario, scenario)
    recipe = sc.recipe()
    stored = _stored_config(out)
    resume = (checkpoint_path(out).is_file() and stored is not None
              and _first_difference(_normal(stored), _normal(scenario)) is None)
    start = time.perf_counter()
    try:
        try:
            run_scenario(sc, recipe, out, resume=resume, overwrite=not resume)
        except GrainfracError:
            if not resume:
                raise
            # The sweep owns its run directories: what a failed resume left is cleared.
            run_scenario(sc, recipe, out, overwrite=True)
    except GrainfracError as exc:
        write_json(out / FAILED_FILE, {"error": str(exc), "type": type(exc).__name__})
        return {"status": "failed", "error": str(exc), "computed": True}
    (out / FAILED_FILE).unlink(missing_ok=True)
    return {"status": "done", "computed": True, "resumed": resume,
            "wall_s": time.perf_counter() - start, "pid": os.getpid()}


# --------------------------------------------------------------------------- dask


class DaskSession:
    """A Dask client made on first use: a LocalCluster, an address, or a given client.

    ``scheduler``: None for a ``distributed.LocalCluster`` (processes, one thread
    each, ``n_workers`` default: the number of cores), an address such as
    ``tcp://host:8786`` for an existing cluster, or a ``distributed.Client``.
    """

    def __init__(self, scheduler: Any = None, n_workers: int | None = None):
        self.scheduler = scheduler
        self.n_workers = n_workers
        self._client: Any = None
        self._owned: list[Any] = []

    @property
    def client(self) -> Any:
        if self._client is None:
            self._client = self._connect()
        return self._client

    def _connect(self) -> Any:
        from distributed import Client, LocalCluster

        if isinstance(self.scheduler, Client):
            return self.scheduler
        if self.scheduler:
            try:
                client = Client(str(self.scheduler), timeout="15s")
            except (OSError, TimeoutError) as exc:
                raise SweepError(f"cannot reach the Dask scheduler at {self.scheduler}: "
                                 f"{exc}") from None
            self._owned.append(client)
            return client
        n = self.n_workers or max(1, os.cpu_count() or 1)
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
        client = Client(cluster)
        self._owned += [client, cluster]
        return client

    def close(self) -> None:
        for thing in self._owned:
            thing.close()
        self._owned.clear()
        self._client = None

    def __enter__(self) -> DaskSession:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@contextmanager
def _session(scheduler: Any, n_workers: int | None) -> Iterator[DaskSession]:
    if isinstance(scheduler, DaskSession):
        yield scheduler
    else:
        with DaskSession(scheduler, n_workers) as session:
            yield session


@dataclass
class SweepProgress:
    """Counts after each finished run (for a progress bar)."""

    sweep: str
    total: int
    skipped: int = 0
    computed: int = 0
    failed: int = 0
    last: str = ""

    @property
    def finished(self) -> int:
        return self.skipped + self.computed + self.failed


@dataclass
class SweepResult:
    """What a sweep invocation did and the tables it wrote."""

    plan: SweepPlan
    out: Path
    runs: list[dict[str, Any]]
    stats: list[dict[str, Any]]
    quantities: list[str]
    skipped: int = 0
    computed: int = 0
    failures: dict[str, str] = field(default_factory=dict)
    wall_time_s: float = 0.0
    files: list[Path] = field(default_factory=list)
    # Finished runs whose summary carries warnings (run_dir -> warnings).
    warnings: dict[str, list[str]] = field(default_factory=dict)

    def stat(self, point: str, quantity: str) -> dict[str, Any]:
        for row in self.stats:
            if row["point"] == point and row["quantity"] == quantity:
                return row
        raise KeyError((point, quantity))

    def values(self, point: str, quantity: str) -> list[Any]:
        """The per-run values of ``quantity`` at ``point`` (None where missing)."""
        return [r.get(quantity) for r in self.runs
                if r["point"] == point and r["status"] == "done"]


def run_sweeps(jobs: Sequence[tuple[SweepPlan, str | Path]], *, scheduler: Any = None,
               n_workers: int | None = None,
               progress: Callable[[SweepProgress], None] | None = None) -> list[SweepResult]:
    """Run several planned sweeps on one Dask cluster (all runs submitted together).

    Done runs are skipped without starting a cluster; a stale run directory
    is a :class:`SweepError` before any compute. Tables are written per sweep.
    """
    if n_workers is not None and n_workers < 1:
        # A local cluster of no workers never runs a task: the sweep would wait forever.
        raise SweepError(f"n_workers: must be >= 1 (got {n_workers})")
    start = time.perf_counter()
    outs = [Path(out) for _, out in jobs]
    todo: list[tuple[int, PlannedRun]] = []
    counters = [SweepProgress(plan.name, len(plan.runs)) for plan, _ in jobs]
    for j, ((plan, _), out) in enumerate(zip(jobs, outs, strict=True)):
        for run in plan.runs:
            state, detail = run_state(out / run.rel_dir, run.scenario)
            if state == "stale":
                raise SweepError(
                    f"{out / run.rel_dir} holds a finished run of another scenario ({detail}); "
                    "remove it or choose another --out")
            if state == "done":
                counters[j].skipped += 1
            else:
                todo.append((j, run))
        _write_plan(plan, out, None)
    if progress:
        for c in counters:
            progress(c)
    failures: list[dict[str, str]] = [{} for _ in jobs]
    if todo:
        from distributed import as_completed

        with _session(scheduler, n_workers or min(len(todo), os.cpu_count() or 1)) as session:
            client = session.client
            token = uuid.uuid4().hex[:8]
            futures = {}
            for j, run in todo:
                key = f"grainfrac-run-{jobs[j][0].name}-{run.point}-r{run.realisation}-{token}"
                fut = client.submit(execute_run, str(outs[j] / run.rel_dir), run.scenario,
                                    key=key, retries=jobs[j][0].retries, pure=False)
                futures[fut] = (j, run)
            for fut in as_completed(futures):
                j, run = futures[fut]
                try:
                    result = fut.result()
                except Exception as exc:  # a bug or a worker that kept dying: keep going
                    result = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
                    write_json(outs[j] / run.rel_dir / FAILED_FILE,
                               {"error": result["error"], "type": type(exc).__name__})
                counter = counters[j]
                if result["status"] == "done":
                    if result.get("computed"):
                        counter.computed += 1
                    else:
                        counter.skipped += 1
                else:
                    counter.failed += 1
                    failures[j][run.rel_dir] = result.get("error", "")
                counter.last = run.rel_dir
                if progress:
                    progress(counter)
                fut.release()
    results = []
    wall = time.perf_counter() - start
    for j, ((plan, _), out) in enumerate(zip(jobs, outs, strict=True)):
        result = collect(plan, out)
        result.skipped, result.computed = counters[j].skipped, counters[j].computed
        result.failures, result.wall_time_s = failures[j], wall
        result.files = write_tables(result)
        _write_plan(plan, out, result)
        results.append(result)
    return results


def run_sweep(plan: SweepPlan, out: str | Path, *, scheduler: Any = None,
              n_workers: int | None = None,
              progress: Callable[[SweepProgress], None] | None = None) -> SweepResult:
    """Run a planned sweep into ``out`` on Dask and write its tables; see the module doc."""
    return run_sweeps([(plan, out)], scheduler=scheduler, n_workers=n_workers,
                      progress=progress)[0]


# --------------------------------------------------------------------------- tables


def _is_number(value: Any) -> bool:
    return value is None or (isinstance(value, int | float) and not isinstance(value, bool))


def flatten_summary(summary: dict[str, Any]) -> dict[str, Any]:
    """Numeric summary values as quantities: scalars by name, dict entries as ``key.entry``."""
    out: dict[str, Any] = {}
    for key, value in summary.items():
        if key in _NOT_QUANTITIES:
            continue
        if isinstance(value, dict):
            for entry, v in value.items():
                if _is_number(v):
                    out[f"{key}.{entry}"] = v
        elif _is_number(value):
            out[key] = value
    return out


def _order_quantities(found: list[str]) -> list[str]:
    """Every scalar summary key (even with no finished run yet), then grouped entries."""
    return list(SCALAR_QUANTITIES) + [q for q in found if q not in SCALAR_QUANTITIES]


def _cell(value: Any) -> Any:
    if isinstance(value, dict | list):
        return json.dumps(value, sort_keys=True)
    return value


def collect(plan: SweepPlan, out: str | Path) -> SweepResult:
    """Rebuild the per-run and statistics tables from the run directories alone."""
    out = Path(out)
    runs: list[dict[str, Any]] = []
    found: list[str] = []
    warnings: dict[str, list[str]] = {}
    for point in plan.points:
        for run in point.runs:
            run_dir = out / run.rel_dir
            row: dict[str, Any] = {"point": point.id, "realisation": run.realisation,
                                   "seed": run.seed}
            state = run_state(run_dir, run.scenario)[0]
            summary = read_summary(run_dir) if state == "done" else None
            if summary is not None:
                row["status"] = "done"
            elif state == "stale":
                row["status"] = "stale"
            elif (run_dir / FAILED_FILE).is_file():
                row["status"] = "failed"
            else:
                row["status"] = "missing"
            row.update({p: _cell(point.values.get(p)) for p in plan.parameters})
            row["wall_time_s"] = summary.get("wall_time_s") if summary else None
            row["run_dir"] = run.rel_dir
            if summary is not None:
                if summary.get("warnings"):
                    warnings[run.rel_dir] = list(summary["warnings"])
                values = flatten_summary(summary)
                for q in values:
                    if q not in found:
                        found.append(q)
                row.update(values)
            runs.append(row)
    quantities = list(plan.quantities) if plan.quantities else _order_quantities(found)
    table: list[dict[str, Any]] = []
    for point in plan.points:
        done = [r for r in runs if r["point"] == point.id and r["status"] == "done"]
        for q in quantities:
            s = stats.summarise(r.get(q) for r in done)
            table.append({
                "point": point.id, **{p: _cell(point.values.get(p)) for p in plan.parameters},
                "quantity": q, "n_runs": len(done), "n": s.n, "mean": s.mean, "std": s.std,
                "ci95_low": s.ci_low, "ci95_high": s.ci_high,
                "ci95_half_width": s.ci_half_width,
            })
    return SweepResult(plan, out, runs, table, quantities, warnings=warnings)


def _csv_value(value: Any) -> Any:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    return value


def write_tables(result: SweepResult) -> list[Path]:
    """Write runs.csv and stats.csv (and .parquet where pyarrow is importable)."""
    plan, out = result.plan, result.out
    run_cols = ["point", "realisation", "seed", "status", *plan.parameters, "wall_time_s",
                "run_dir", *result.quantities]
    stat_cols = ["point", *plan.parameters, "quantity", "n_runs", "n", "mean", "std",
                 "ci95_low", "ci95_high", "ci95_half_width"]
    runs = [{c: _csv_value(r.get(c)) for c in run_cols} for r in result.runs]
    table = [{c: _csv_value(r.get(c)) for c in stat_cols} for r in result.stats]
    files = [write_csv(out / RUNS_TABLE, runs, run_cols),
             write_csv(out / STATS_TABLE, table, stat_cols)]
    if importlib.util.find_spec("pyarrow") is not None:
        files += _write_parquet(out, result, run_cols, stat_cols)
    return files


def _write_parquet(out: Path, result: SweepResult, run_cols: list[str],
                   stat_cols: list[str]) -> list[Path]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from grainfrac.io.files import write_atomic

    def column(rows: list[dict[str, Any]], name: str) -> list[Any]:
        values = [r.get(name) for r in rows]
        kinds = {type(v) for v in values if v is not None}
        if kinds <= {int, float} and float in kinds:
            return [None if v is None else float(v) for v in values]
        if len(kinds) > 1:
            return [None if v is None else str(v) for v in values]
        return values

    files = []
    for name, rows, cols in (("runs.parquet", result.runs, run_cols),
                             ("stats.parquet", result.stats, stat_cols)):
        table = pa.table({c: column(rows, c) for c in cols})
        files.append(write_atomic(out / name, lambda p, t=table: pq.write_table(t, p)))
    return files


def _write_plan(plan: SweepPlan, out: Path, result: SweepResult | None) -> None:
    data: dict[str, Any] = {
        "name": plan.name,
        "parameters": list(plan.parameters),
        "points": [{"id": p.id, "values": p.values,
                    "runs": [{"realisation": r.realisation, "seed": r.seed, "dir": r.rel_dir}
                             for r in p.runs]} for p in plan.points],
        "tables": {"runs": RUNS_TABLE, "stats": STATS_TABLE},
    }
    previous = out / PLAN_FILE
    if result is None and previous.is_file():
        try:
            data["last_invocation"] = json.loads(previous.read_text())["last_invocation"]
        except (ValueError, KeyError):
            pass
    if result is not None:
        data["last_invocation"] = {
            "skipped": result.skipped, "computed": result.computed,
            "failed": len(result.failures), "failures": result.failures,
            "wall_time_s": result.wall_time_s,
            "complete": all(r["status"] == "done" for r in result.runs),
        }
    write_json(previous, data)


__all__ = [
    "AxisSpec", "DaskSession", "PlannedRun", "PointSpec", "SweepConfig", "SweepError",
    "SweepPlan", "SweepPoint", "SweepProgress", "SweepResult", "apply_overrides", "check_path",
    "collect", "execute_run", "flatten_summary", "load_sweep", "plan_sweep", "read_summary",
    "run_state", "run_sweep", "run_sweeps", "write_tables",
]
