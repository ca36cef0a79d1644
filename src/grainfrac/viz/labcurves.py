"""Load curves of the virtual lab tests (paper Fig. 5): stress-strain, load-displacement."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from grainfrac.viz.saving import save_png  # noqa: E402


def plot_load_curve(x, y, path: str | Path, *, xlabel: str, ylabel: str, title: str,
                    peak_index: int | None = None, peak_label: str | None = None,
                    secondary: tuple[np.ndarray, str] | None = None) -> Path:
    """Save a PNG of one loading curve, the peak marked; ``secondary`` = (y2, label)
    is drawn against the same x on a right-hand axis (e.g. the crack count)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    fig, ax = plt.subplots(figsize=(5.6, 4.0), dpi=150)
    ax.plot(x, y, color="#2c7bb6", lw=1.6)
    if peak_index is not None and len(y):
        ax.plot(x[peak_index], y[peak_index], "o", color="#d7191c", ms=6,
                label=peak_label or "peak")
        ax.legend(fontsize=8, frameon=False, loc="lower right")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.25)
    if secondary is not None:
        ax2 = ax.twinx()
        ax2.plot(x, np.asarray(secondary[0], dtype=float), color="0.55", lw=1.0, ls="--")
        ax2.set_ylabel(secondary[1], color="0.45")
    return save_png(fig, path)
