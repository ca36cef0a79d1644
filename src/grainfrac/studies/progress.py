"""A rich progress display for sweeps: one bar per sweep, runs done / total."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from grainfrac.studies.sweep import SweepProgress


@contextmanager
def sweep_progress(console: Console | None = None
                   ) -> Iterator[Callable[[SweepProgress], None]]:
    """Yield a callback for ``run_sweep(progress=...)`` that drives a live bar per sweep."""
    columns = (
        TextColumn("[bold]{task.description:<18}[/]"),
        BarColumn(bar_width=24),
        MofNCompleteColumn(),
        TextColumn("runs  {task.fields[detail]}"),
        TimeElapsedColumn(),
        TextColumn("eta"),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, transient=False) as bar:
        tasks: dict[str, int] = {}

        def update(p: SweepProgress) -> None:
            if p.sweep not in tasks:
                tasks[p.sweep] = bar.add_task(p.sweep, total=p.total, detail="")
            detail = f"{p.computed} run, {p.skipped} already done"
            if p.failed:
                detail += f", [red]{p.failed} failed[/]"
            bar.update(tasks[p.sweep], total=p.total, completed=p.finished, detail=detail)

        yield update


# Quantities shown on the terminal after a sweep (all are in stats.csv).
HEADLINE = (
    ("breakdown (MPa)", "breakdown_pressure_MPa", ".2f"),
    ("peak SCDA (MPa)", "peak_expansive_pressure_MPa", ".1f"),
    ("cracks", "n_cracks", ".0f"),
    ("T/S", "tensile_shear_ratio", ".2f"),
    ("radial fractures", "n_radial_fractures", ".1f"),
    ("extent (mm)", "fracture_extent_mm", ".1f"),
    ("friction (J)", "energy_friction_J", ".2e"),
)


def _cell(row: dict, spec: str) -> str:
    import math

    mean, half = row["mean"], row["ci95_half_width"]
    if not math.isfinite(mean):
        return "-"
    text = format(mean, spec)
    if math.isfinite(half):
        text += f" ± {format(half, spec)}"
    return f"{text} (n={row['n']})" if row["n"] != row["n_runs"] else text


def sweep_table(result) -> Table:
    """Mean ± 95 % CI half-width per point of the headline quantities that have data."""
    import math

    shown = [(label, q, spec) for label, q, spec in HEADLINE
             if q in result.quantities and any(
                 r["quantity"] == q and math.isfinite(r["mean"]) for r in result.stats)]
    n_runs = len(result.plan.points[0].runs) if result.plan.points else 0
    table = Table(title=f"{result.plan.name}: mean ± 95 % CI half-width over {n_runs} "
                        "realisation(s) per point")
    table.add_column("point")
    for label, _, _ in shown:
        table.add_column(label, justify="right")
    for point in result.plan.points:
        cells = [_cell(result.stat(point.id, q), spec) for _, q, spec in shown]
        table.add_row(point.id, *cells)
    return table
