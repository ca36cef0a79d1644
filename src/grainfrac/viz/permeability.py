"""Intact permeability against the initial grain-boundary aperture (paper Fig. 6d)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from grainfrac.viz.saving import save_png  # noqa: E402

EXPERIMENT_COLOUR = "#d7191c"
MODEL_COLOUR = "#2c7bb6"


def plot_permeability(curve: dict, path: str | Path, *, title: str | None = None) -> Path:
    """Save a log-log PNG of permeability (m2) against ``a0`` (m).

    ``curve`` is what :func:`grainfrac.verification.hydraulic.permeability_curve`
    returns: per aperture, one value per seed (dots), their mean (line) and the
    experimental value (horizontal line, Kumari et al. 2018).
    """
    a0 = np.asarray(curve["initial_aperture_m"], dtype=float)
    table = np.asarray(curve["permeability_m2"], dtype=float).reshape(len(a0), -1)
    seeds = curve.get("seeds", list(range(table.shape[1])))
    fig, ax = plt.subplots(figsize=(5.6, 4.2), dpi=150)
    ax.loglog(np.repeat(a0, table.shape[1]), table.ravel(), "o", ms=4, color=MODEL_COLOUR,
              alpha=0.45, label="assemblies (seeds " + ", ".join(map(str, seeds)) + ")")
    # Without mechanics the conductances go as a0^3 and nothing else changes: slope 3.
    ax.loglog(a0, table.mean(axis=1), "-", color=MODEL_COLOUR, lw=1.6,
              label=r"mean ($k \propto a_0^3$)")
    experimental = curve.get("experimental_m2")
    if experimental:
        ax.axhline(experimental, color=EXPERIMENT_COLOUR, ls="--", lw=1.2,
                   label=f"experiment {experimental:.2g} m$^2$ (Kumari et al. 2018)")
    ax.set_xlabel(r"initial aperture $a_0$ (m)")
    ax.set_ylabel(r"permeability $k$ (m$^2$)")
    ax.set_title(title or "Constant-head test, intact assembly (8 MPa / 0 MPa)", fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    return save_png(fig, path)
