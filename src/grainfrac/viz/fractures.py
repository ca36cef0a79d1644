"""Fracture pattern over the grain map: tensile and shear cracks."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from grainfrac.assembly import GrainAssembly  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402
from grainfrac.viz.specimen import draw_assembly, legend_handles  # noqa: E402

TENSILE_COLOUR = "#1f5fbf"
SHEAR_COLOUR = "#e31a1c"


def draw_cracks(ax, assembly: GrainAssembly, contact: np.ndarray, mode: np.ndarray) -> None:
    """Cracked sub-contacts as short segments along their grain boundary."""
    mesh = assembly.mesh
    half = 0.5 * (mesh.contact_area / mesh.thickness)[:, None] * mesh.contact_tangent
    for code, colour in ((1, TENSILE_COLOUR), (2, SHEAR_COLOUR)):
        c = contact[mode == code]
        if len(c) == 0:
            continue
        a = (mesh.contact_xy[c] - half[c]) * 1e3
        b = (mesh.contact_xy[c] + half[c]) * 1e3
        ax.plot(np.stack((a[:, 0], b[:, 0])), np.stack((a[:, 1], b[:, 1])), color=colour,
                linewidth=2.0, solid_capstyle="round")


def plot_fracture_pattern(assembly: GrainAssembly, contact, mode, path: str | Path, *,
                          title: str | None = None) -> Path:
    """Save a PNG of the cracks (tensile blue, shear red) over the grains."""
    contact = np.asarray(contact, dtype=np.int64)
    mode = np.asarray(mode, dtype=np.int64)
    fig, ax = plt.subplots(figsize=(6.4, 6.0), dpi=150)
    draw_assembly(ax, assembly, title=title)
    draw_cracks(ax, assembly, contact, mode)
    handles = legend_handles(assembly)[:3] + [
        Line2D([], [], color=TENSILE_COLOUR, lw=2, label=f"tensile {int((mode == 1).sum())}"),
        Line2D([], [], color=SHEAR_COLOUR, lw=2, label=f"shear {int((mode == 2).sum())}"),
    ]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              frameon=False)
    return save_png(fig, path, crop=True)  # the legend is outside the axes
