"""The reproduction report of a study: claims, our numbers with 95 % CIs, figures, verdicts.

Writes, into the study directory, ``report.md`` and a self-contained
``report.html`` (figures embedded as base64 PNG), ``figures/<study>.png``
(mean and 95 % CI per point, each run as a dot) and the verdicts as
``claims.csv`` and ``claims.json``. Everything comes from the sweep results
(the tables rebuilt from run directories) and the claims decided on them.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import grainfrac  # noqa: E402
from grainfrac.io.files import write_csv, write_json, write_text  # noqa: E402
from grainfrac.studies.claims import (  # noqa: E402
    FAILS,
    HOLDS,
    OPEN,
    UNDETERMINED,
    Verdict,
    evaluate,
    fmt,
)
from grainfrac.studies.paper import Study  # noqa: E402
from grainfrac.studies.sweep import SweepResult  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402

PAPER = ("Hybrid SCDA-HS rock pre-conditioning at the grain scale "
         "(paper/hybrid-scda-hs-preconditioning.txt)")
LABELS = {
    "breakdown_pressure_MPa": "breakdown pressure (MPa)",
    "breakdown_drop_1ms_fraction": "pressure lost 1 ms after breakdown (fraction)",
    "peak_expansive_pressure_MPa": "peak expansive pressure (MPa)",
    "n_radial_fractures": "radial fractures",
    "fracture_extent_mm": "fracture extent (mm)",
    "n_cracks": "cracks",
    "tensile_shear_ratio": "T/S ratio",
    "tortuosity": "tortuosity",
    "energy_friction_J": "frictional work (J)",
    "energy_shear_J": "shear energy released (J)",
    "energy_tensile_J": "tensile energy released (J)",
    "n_grains": "grains",
    "contact_fraction_failed.F-Q": "F-Q fraction of failed contacts",
    "contact_fraction_failed.Q-Q": "Q-Q fraction of failed contacts",
}
COLOURS = {HOLDS: "#1a7f37", FAILS: "#cf222e", OPEN: "#9a6700", UNDETERMINED: "#57606a"}


@dataclass
class StudyOutcome:
    """A study's sweep result and the verdicts on its claims."""

    study: Study
    result: SweepResult
    verdicts: list[Verdict]
    figure: Path | None = None


def decide(study: Study, result: SweepResult) -> StudyOutcome:
    """Evaluate every claim of ``study`` on its sweep result."""
    return StudyOutcome(study, result, [evaluate(c, result) for c in study.claims])


def plot_study(outcome: StudyOutcome, path: Path) -> Path:
    """Mean and 95 % CI per point (bars) and every run (dots), one panel per quantity."""
    study, result = outcome.study, outcome.result
    quantities = [q for q in study.figure_quantities if q in result.quantities]
    n = max(len(quantities), 1)
    cols = min(n, 2)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.4 * rows), squeeze=False,
                             dpi=110)
    points = [p.id for p in result.plan.points]
    x = np.arange(len(points))
    for ax, q in zip(axes.flat, quantities, strict=False):
        means, halves = [], []
        for p in points:
            row = result.stat(p, q)
            means.append(row["mean"])
            halves.append(row["ci95_half_width"] if math.isfinite(row["ci95_half_width"])
                          else 0.0)
        means_a = np.asarray(means, dtype=float)
        ok = np.isfinite(means_a)
        ax.bar(x[ok], means_a[ok], color="#b6d4fe", edgecolor="#0a58ca", width=0.6,
               yerr=np.asarray(halves)[ok], capsize=5, error_kw={"elinewidth": 1.2},
               label="mean ± 95 % CI")
        for i, p in enumerate(points):
            vals = [float(v) for v in result.values(p, q)
                    if v is not None and math.isfinite(float(v))]
            ax.plot(np.full(len(vals), x[i]), vals, "o", color="#212529", ms=3.5, alpha=0.7,
                    label="runs" if i == 0 and vals else None)
        for i in np.flatnonzero(~ok):
            ax.text(x[i], 0.0, "null in\nall runs", ha="center", va="bottom", fontsize=8,
                    color="#57606a")
        ax.set_xticks(x, points, rotation=20 if len(points) > 3 else 0, fontsize=8)
        ax.set_ylabel(LABELS.get(q, q), fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    for ax in list(axes.flat)[len(quantities):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7, loc="best")
    n_runs = len(result.plan.points[0].runs) if result.plan.points else 0
    fig.suptitle(f"{study.title}\n({study.reference}; {n_runs} realisation(s) per point)",
                 fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save_png(fig, path)


def _point_table(outcome: StudyOutcome) -> tuple[list[str], list[list[str]]]:
    result = outcome.result
    quantities = [q for q in outcome.study.figure_quantities if q in result.quantities]
    header = ["point", "runs"] + [LABELS.get(q, q) for q in quantities]
    rows = []
    for point in result.plan.points:
        cells = [point.id]
        done = sum(1 for r in result.runs if r["point"] == point.id and r["status"] == "done")
        cells.append(f"{done}/{len(point.runs)}")
        for q in quantities:
            s = result.stat(point.id, q)
            if not math.isfinite(s["mean"]):
                cells.append("null")
                continue
            text = fmt(s["mean"])
            if math.isfinite(s["ci95_half_width"]):
                text += f" ± {fmt(s['ci95_half_width'], 2)}"
            if s["n"] != s["n_runs"]:
                text += f" (n={s['n']})"
            cells.append(text)
        rows.append(cells)
    return header, rows


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    def esc(cell: str) -> str:
        return str(cell).replace("|", "\\|")

    lines = ["| " + " | ".join(esc(h) for h in header) + " |",
             "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(esc(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


RULES = (
    "Each claim is decided from a two-sided 95 % confidence interval (Student t): "
    "**holds** when the whole interval lies on the claimed side, **does not hold** when it "
    "lies wholly on the other side, **inconclusive** when it straddles the boundary, and "
    "**undetermined** when no interval can be made (the quantity is null/NaN in every run "
    "of a point, with the reason, or fewer than two valid runs per point). Differences "
    "between points that ran the same seeds (same grain structures) use the paired "
    "per-seed difference; otherwise Welch's interval. Trends use the least-squares slope "
    "over all runs. Points are means over realisations; ± is the 95 % CI half-width."
)


def _summary_table(outcomes: Sequence[StudyOutcome]
                   ) -> tuple[list[str], list[list[str]], set[int]]:
    """The claims table: one row per claim, its estimate and verdict in each dimension
    run side by side (a claim tested in 2D and in 3D shares one row). Returns the
    header, the rows and the columns that hold verdicts."""
    dims = sorted({o.study.dimension for o in outcomes}) or [2]
    both = len(dims) > 1
    header = ["study", "claim", "paper"]
    for d in dims:
        header += [f"ours ({d}D)", f"verdict ({d}D)"] if both else ["ours", "verdict"]
    rows: dict[str, list[str]] = {}
    for o in outcomes:
        col = 3 + 2 * dims.index(o.study.dimension)
        for v in o.verdicts:
            row = rows.setdefault(v.claim.id, [o.study.family, v.claim.text, v.claim.paper]
                                  + ["not run"] * (2 * len(dims)))
            row[col:col + 2] = [v.estimate, v.verdict]
    return header, list(rows.values()), {4 + 2 * i for i in range(len(dims))}


def _flagged(outcome: StudyOutcome) -> str:
    """The runs whose summary carries warnings (their values are still counted)."""
    w = outcome.result.warnings
    return (f"Runs with warnings ({len(w)} of {len(outcome.result.runs)}; counted): "
            + "; ".join(f"{k}: {' '.join(v)}" for k, v in w.items()))


def write_markdown(outcomes: Sequence[StudyOutcome], path: Path, header: str) -> Path:
    """``report.md``: claims table, decision rules, then one section per study."""
    parts = [f"# Reproduction report\n\n{header}\n", "## Claims\n",
             _md_table(*_summary_table(outcomes)[:2]), "", f"{RULES}\n"]
    for o in outcomes:
        s = o.study
        parts += [f"## {s.title}\n", f"*{s.reference}; {s.dimension}D.* {s.description}\n"]
        parts += [f"Note: {note}\n" for note in s.notes]
        parts += [_md_table(*_point_table(o)), ""]
        if o.figure is not None:
            parts.append(f"![{s.name}]({o.figure.relative_to(path.parent).as_posix()})\n")
        for v in o.verdicts:
            parts.append(f"- **{v.verdict}** — {v.claim.text} (`{v.claim.quantity}`). "
                         f"Paper: {v.claim.paper}. Ours: {v.estimate}. {v.reason}.")
        if not o.verdicts:
            parts.append("No claim of the paper is decided in this study.")
        if o.result.failures:
            parts.append("\nFailed runs: " + "; ".join(
                f"{k}: {e}" for k, e in o.result.failures.items()))
        if o.result.warnings:
            parts.append("\n" + _flagged(o))
        parts.append("")
    return write_text(path, "\n".join(parts) + "\n")


_CSS = """
body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#1f2328;line-height:1.45}
table{border-collapse:collapse;margin:0.8em 0;font-size:0.9em}
td,th{border:1px solid #d0d7de;padding:4px 8px;text-align:left;vertical-align:top}
th{background:#f6f8fa}.v{font-weight:600;white-space:nowrap}
img{max-width:100%;border:1px solid #d0d7de}.note{color:#57606a}
"""


def _html_table(header: list[str], rows: list[list[str]],
                verdict_cols: set[int] = frozenset()) -> str:
    out = ["<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>"]
    for row in rows:
        cells = []
        for i, cell in enumerate(row):
            if i in verdict_cols:
                colour = COLOURS.get(cell, "#1f2328")
                cells.append(f'<td class="v" style="color:{colour}">{html.escape(cell)}</td>')
            else:
                cells.append(f"<td>{html.escape(str(cell))}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    return "".join(out) + "</table>"


def write_html(outcomes: Sequence[StudyOutcome], path: Path, header: str) -> Path:
    """``report.html``: the markdown report's content, figures embedded (no network)."""
    body = [f"<h1>Reproduction report</h1><p>{html.escape(header)}</p><h2>Claims</h2>",
            _html_table(*_summary_table(outcomes)),
            f"<p class=note>{html.escape(RULES).replace('**', '')}</p>"]
    for o in outcomes:
        s = o.study
        body.append(f'<h2 id="{s.name}">{html.escape(s.title)}</h2>'
                    f"<p><em>{html.escape(s.reference)}; {s.dimension}D.</em> "
                    f"{html.escape(s.description)}</p>")
        body += [f"<p class=note>Note: {html.escape(n)}</p>" for n in s.notes]
        body.append(_html_table(*_point_table(o)))
        if o.figure is not None and o.figure.is_file():
            data = base64.b64encode(o.figure.read_bytes()).decode("ascii")
            body.append(f'<p><img alt="{s.name}" src="data:image/png;base64,{data}"></p>')
        if o.verdicts:
            rows = [[v.claim.text, v.claim.paper, v.estimate, v.verdict, v.reason]
                    for v in o.verdicts]
            body.append(_html_table(["claim", "paper", "ours", "verdict", "why"], rows,
                                    verdict_cols={3}))
        else:
            body.append("<p>No claim of the paper is decided in this study.</p>")
        if o.result.failures:
            body.append("<p class=note>Failed runs: " + html.escape("; ".join(
                f"{k}: {e}" for k, e in o.result.failures.items())) + "</p>")
        if o.result.warnings:
            body.append(f"<p class=note>{html.escape(_flagged(o))}</p>")
    page = ("<!doctype html><html><head><meta charset=utf-8><title>grainfrac reproduction "
            f"report</title><style>{_CSS}</style></head><body>{''.join(body)}</body></html>")
    return write_text(path, page)


def build_reproduction_report(outcomes: Sequence[StudyOutcome], out: str | Path, *,
                              realisations: int, wall_time_s: float | None = None
                              ) -> list[Path]:
    """Figures, claims.csv/json, report.md and report.html in ``out``."""
    out = Path(out)
    for o in outcomes:
        o.figure = plot_study(o, out / "figures" / f"{o.study.name}.png")
    n_runs = sum(len(o.result.runs) for o in outcomes)
    header = (f"{PAPER}. grainfrac {grainfrac.__version__}; {realisations} realisation(s) "
              f"per point (seeds = each scenario's seed + 0..{realisations - 1}); "
              f"{n_runs} runs in {len(outcomes)} studies")
    run_time = sum(r["wall_time_s"] or 0.0 for o in outcomes for r in o.result.runs)
    header += f"; summed run time {run_time:.0f} s"
    if wall_time_s is not None:
        computed = sum(o.result.computed for o in outcomes)
        header += (f"; this invocation computed {computed} run(s) in {wall_time_s:.0f} s "
                   "(the others were done already)" if computed < n_runs else
                   f"; this invocation computed them in {wall_time_s:.0f} s")
    header += "."
    rows = [v.as_row(o.study.name) for o in outcomes for v in o.verdicts]
    columns = ["study", "claim", "quantity", "statement", "paper", "verdict", "estimate",
               "ci95_low", "ci95_high", "reason"]
    files = [write_csv(out / "claims.csv", [{c: ("" if r[c] is None else r[c]) for c in columns}
                                            for r in rows], columns),
             write_json(out / "claims.json", rows),
             write_markdown(outcomes, out / "report.md", header),
             write_html(outcomes, out / "report.html", header)]
    return [o.figure for o in outcomes if o.figure is not None] + files


__all__ = ["StudyOutcome", "build_reproduction_report", "decide", "plot_study",
           "write_html", "write_markdown"]
