"""Field maps of a state: displacement, minor principal stress, fluid pressure in contacts."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402

from grainfrac.assembly import GrainAssembly  # noqa: E402
from grainfrac.physics.codes import SIGN_LABEL  # noqa: E402
from grainfrac.physics.fields import major_principal_stress  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402


def _frame(ax, assembly: GrainAssembly, title: str) -> None:
    lo = assembly.mesh.node_xy.min(axis=0) * 1e3
    hi = assembly.mesh.node_xy.max(axis=0) * 1e3
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(title, fontsize=10)


def _element_map(ax, assembly: GrainAssembly, values: np.ndarray, cmap: str, label: str,
                 vmin=None, vmax=None):
    tri = assembly.mesh.node_xy[assembly.mesh.element_nodes] * 1e3
    coll = PolyCollection(tri, array=values, cmap=cmap, edgecolors="face", linewidths=0.1)
    coll.set_clim(vmin, vmax)
    ax.add_collection(coll)
    plt.colorbar(coll, ax=ax, label=label, shrink=0.85)


def plot_displacement(assembly: GrainAssembly, u: np.ndarray, path: str | Path, *,
                      title: str = "displacement") -> Path:
    """Element-mean displacement magnitude (um)."""
    mag = np.hypot(*u.T)[assembly.mesh.element_nodes].mean(axis=1) * 1e6
    fig, ax = plt.subplots(figsize=(6.0, 5.0), dpi=140)
    _element_map(ax, assembly, mag, "viridis", "displacement magnitude (um)")
    _frame(ax, assembly, title)
    return save_png(fig, path)


def plot_minor_principal_stress(assembly: GrainAssembly, stress: np.ndarray,
                                path: str | Path, *, title: str = "minor principal stress"
                                ) -> Path:
    """Minor principal stress in MPa, compression positive (as paper Fig. 10).

    With compression positive the minor principal stress is the least
    compressive one, i.e. minus the major principal stress of the
    tension-positive convention; tensile zones show as negative values.
    """
    values = -major_principal_stress(stress) / 1e6
    limit = float(np.percentile(np.abs(values), 99)) or 1.0
    fig, ax = plt.subplots(figsize=(6.0, 5.0), dpi=140)
    _element_map(ax, assembly, values, "RdBu_r", f"minor principal stress (MPa, {SIGN_LABEL})",
                 vmin=-limit, vmax=limit)
    _frame(ax, assembly, title)
    return save_png(fig, path)


def plot_contact_pressure(assembly: GrainAssembly, pressure: np.ndarray, path: str | Path, *,
                          title: str = "fluid pressure in grain boundaries") -> Path:
    """Fluid pressure (MPa) along grain boundaries: the leak-off field."""
    mesh = assembly.mesh
    seg = mesh.fluid_node_xy[mesh.pipe_nodes] * 1e3
    ends = mesh.pipe_contacts
    p = 0.5 * (pressure[ends[:, 0]] + pressure[ends[:, 1]]) / 1e6
    fig, ax = plt.subplots(figsize=(6.0, 5.0), dpi=140)
    grains = [mesh.grains.vertices[r] * 1e3 for r in mesh.grains.rings]
    ax.add_collection(PolyCollection(grains, facecolors="#f2f2f2", edgecolors="none"))
    coll = LineCollection(seg, array=p, cmap="plasma", linewidths=1.4)
    coll.set_clim(0.0, max(float(p.max()), 1e-6))
    ax.add_collection(coll)
    plt.colorbar(coll, ax=ax, label=f"fluid pressure (MPa, {SIGN_LABEL})", shrink=0.85)
    _frame(ax, assembly, title)
    return save_png(fig, path)
