"""Well pressure against time during injection, with the crack count (breakdown curve)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from grainfrac.physics.codes import SIGN_LABEL  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402

PRESSURE_COLOUR = "#2c7bb6"
CRACK_COLOUR = "#d7191c"


def plot_well_pressure(time, pressure, cracks, path: str | Path, *,
                       title: str | None = None) -> Path:
    """Save a PNG of well pressure (MPa) and cumulative cracks against time (ms).

    Parameters
    ----------
    time
        Times (s) since the start of injection.
    pressure
        Well pressures (Pa).
    cracks
        Cumulative number of cracks at each time.
    path
        Output PNG path (written atomically).
    """
    t_ms = np.asarray(time, dtype=float) * 1e3
    p_mpa = np.asarray(pressure, dtype=float) / 1e6
    n = np.asarray(cracks)
    fig, ax = plt.subplots(figsize=(6.0, 4.0), dpi=150)
    ax.plot(t_ms, p_mpa, color=PRESSURE_COLOUR, lw=1.6, label="well pressure")
    if len(p_mpa):
        k = int(np.argmax(p_mpa))
        ax.plot(t_ms[k], p_mpa[k], "o", color=PRESSURE_COLOUR, ms=5)
        ax.annotate(f"peak {p_mpa[k]:.2f} MPa at {t_ms[k]:.2f} ms", (t_ms[k], p_mpa[k]),
                    textcoords="offset points", xytext=(6, 6), fontsize=8)
        ax.set_ylim(top=max(1.15 * p_mpa[k], ax.get_ylim()[1]))
    ax.set_xlabel("time since injection start (ms)")
    ax.set_ylabel(f"well pressure (MPa, {SIGN_LABEL})", color=PRESSURE_COLOUR)
    ax.grid(True, alpha=0.25)
    twin = ax.twinx()
    twin.step(t_ms, n, where="post", color=CRACK_COLOUR, lw=1.2, label="cracks")
    twin.set_ylabel("cracks (cumulative)", color=CRACK_COLOUR)
    twin.set_ylim(bottom=0)
    lines = ax.get_lines()[:1] + twin.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, frameon=False,
              loc="upper left")
    if title:
        ax.set_title(title, fontsize=10)
    return save_png(fig, path)


def plot_stage_history(rows: list[dict], path: str | Path, *, title: str | None = None) -> Path:
    """Save a PNG of expansive and well pressure (MPa) and cracks over all stages.

    ``rows`` are history.csv rows (time_s, stage, well_pressure_MPa,
    expansive_pressure_MPa, n_cracks); stages are shaded and labelled.
    """
    t_ms = np.array([float(r["time_s"]) for r in rows]) * 1e3
    well = np.array([float(r["well_pressure_MPa"]) for r in rows])
    exp = np.array([float(r["expansive_pressure_MPa"]) for r in rows])
    cracks = np.array([int(r["n_cracks"]) for r in rows])
    stages = [r["stage"] for r in rows]
    fig, ax = plt.subplots(figsize=(7.0, 4.0), dpi=150)
    start = 0
    for i in range(1, len(stages) + 1):
        if i == len(stages) or stages[i] != stages[start]:
            lo, hi = t_ms[start], t_ms[i - 1]
            ax.axvspan(lo, hi, color="#0000000c" if len(ax.patches) % 2 else "#00000004")
            ax.text(0.5 * (lo + hi), 1.0, stages[start], transform=ax.get_xaxis_transform(),
                    ha="center", va="bottom", fontsize=7)
            start = i
    if np.any(exp):
        ax.plot(t_ms, exp, color="#1a9641", lw=1.6, label="expansive pressure (SCDA)")
    if np.any(well):
        ax.plot(t_ms, well, color=PRESSURE_COLOUR, lw=1.6, label="well pressure")
    ax.set_xlabel("time (ms)")
    ax.set_ylabel(f"pressure (MPa, {SIGN_LABEL})")
    ax.grid(True, alpha=0.25)
    twin = ax.twinx()
    twin.step(t_ms, cracks, where="post", color=CRACK_COLOUR, lw=1.2, label="cracks")
    twin.set_ylabel("cracks (cumulative)", color=CRACK_COLOUR)
    twin.set_ylim(bottom=0)
    lines = ax.get_lines() + twin.get_lines()
    ax.legend(lines, [ln.get_label() for ln in lines], fontsize=8, frameon=False,
              loc="upper left")
    if title:
        ax.set_title(title, fontsize=10, pad=14)
    return save_png(fig, path)
