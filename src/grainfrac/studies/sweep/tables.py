"""The tables of a sweep, rebuilt from its run directories alone: ``runs.csv``,
``stats.csv`` (and Parquet copies), ``sweep.json`` and the :class:`SweepResult`.
"""

from __future__ import annotations

import importlib.util
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from grainfrac.analysis import stats
from grainfrac.io.files import write_csv, write_json
from grainfrac.studies.sweep.config import SCALAR_QUANTITIES
from grainfrac.studies.sweep.plan import SweepPlan
from grainfrac.studies.sweep.runs import FAILED_FILE, read_summary, run_state

__all__ = [
    "PLAN_FILE",
    "RUNS_TABLE",
    "STATS_TABLE",
    "SweepResult",
    "collect",
    "flatten_summary",
    "write_tables",
]


# Summary keys that identify or time a run rather than measure it (not in stats.csv:
# wall time differs between identical runs).
_NOT_QUANTITIES = {"grainfrac_version", "scenario", "seed", "wall_time_s", "stages",
                   "stage_times_s"}


RUNS_TABLE = "runs.csv"
STATS_TABLE = "stats.csv"
PLAN_FILE = "sweep.json"


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
