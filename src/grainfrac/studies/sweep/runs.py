"""One run directory of a sweep: whether it is done, stale or to run
(:func:`run_state`), and the Dask task that brings it to done (:func:`execute_run`).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

from grainfrac.errors import ConfigError, GrainfracError
from grainfrac.io.config import read_toml, validate
from grainfrac.io.files import write_json
from grainfrac.scenario import Scenario

__all__ = [
    "FAILED_FILE",
    "execute_run",
    "read_summary",
    "run_state",
]


FAILED_FILE = "failed.json"


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
