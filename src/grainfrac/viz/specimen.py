"""Picture of a grain assembly: grains coloured by mineral, fissures highlighted."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from grainfrac.assembly import GrainAssembly  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402

# Granite-like colours: dark mica, pink feldspar, pale quartz.
MINERAL_COLOURS = {"mica": "#3b3024", "feldspar": "#e8a98c", "quartz": "#dcdcd4"}
FISSURE_COLOUR = "#d7191c"


def draw_assembly(ax, assembly: GrainAssembly, *, show_mesh: bool = False,
                  title: str | None = None) -> None:
    """Draw grains by mineral, grain boundaries and fissures on ``ax`` (axes in mm)."""
    mesh = assembly.mesh
    grains = mesh.grains
    names = assembly.mineral_table.names
    colours = [MINERAL_COLOURS.get(n, "#999999") for n in names]
    polys = [grains.vertices[r] * 1e3 for r in grains.rings]
    face = [colours[m] for m in assembly.grain_mineral]
    ax.add_collection(PolyCollection(polys, facecolors=face, edgecolors="#555555",
                                     linewidths=0.4))
    if show_mesh:
        tri = mesh.node_xy[mesh.element_nodes] * 1e3
        ax.add_collection(PolyCollection(tri, facecolors="none", edgecolors="#00000022",
                                         linewidths=0.2))
    fiss = assembly.interface_fissure[mesh.pipe_interface]
    if fiss.any():
        seg = mesh.fluid_node_xy[mesh.pipe_nodes[fiss]] * 1e3
        ax.add_collection(LineCollection(seg, colors=FISSURE_COLOUR, linewidths=1.6))
    lo = grains.vertices.min(axis=0) * 1e3
    hi = grains.vertices.max(axis=0) * 1e3
    pad = 0.03 * float(np.max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    if title:
        ax.set_title(title, fontsize=10)


def legend_handles(assembly: GrainAssembly) -> list[Patch]:
    fractions = assembly.volume_fractions()
    handles = [
        Patch(facecolor=MINERAL_COLOURS.get(n, "#999999"), edgecolor="#555555",
              label=f"{n} {100 * f:.1f} %")
        for n, f in zip(assembly.mineral_table.names, fractions, strict=True)
    ]
    if assembly.interface_fissure.any():
        handles.append(Patch(facecolor=FISSURE_COLOUR,
                             label=f"fissures {100 * assembly.interface_fissure.mean():.1f} %"))
    return handles


def plot_assembly(assembly: GrainAssembly, path: str | Path, *, show_mesh: bool = True,
                  title: str | None = None) -> Path:
    """Save a PNG of one assembly."""
    fig, ax = plt.subplots(figsize=(6.4, 6.0), dpi=150)
    draw_assembly(ax, assembly, show_mesh=show_mesh, title=title)
    ax.legend(handles=legend_handles(assembly), loc="upper left", bbox_to_anchor=(1.01, 1.0),
              fontsize=8, frameon=False)
    return save_png(fig, path, crop=True)  # the legend is outside the axes


def plot_gallery(assemblies: list[tuple[str, GrainAssembly]], path: str | Path) -> Path:
    """Save several assemblies side by side (e.g. the four specimen shapes)."""
    fig, axes = plt.subplots(1, len(assemblies), figsize=(4.2 * len(assemblies), 4.4), dpi=130)
    for ax, (title, assembly) in zip(np.atleast_1d(axes), assemblies, strict=True):
        draw_assembly(ax, assembly, show_mesh=False, title=title)
    first = assemblies[0][1]
    fig.legend(handles=legend_handles(first)[:3], loc="lower center", ncol=4, frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return save_png(fig, path, crop=True, fit=False)


# -- 3D ---------------------------------------------------------------------------------
def _mid_section(assembly: GrainAssembly, z: float) -> tuple[list[np.ndarray], list[int]]:
    """Polygons (mm) of the grain pieces cut by the plane at height ``z``, and their minerals."""
    cx = assembly.mesh.grains
    polys, minerals = [], []
    for p in range(cx.n_pieces):
        seg = []
        for f in cx.piece_faces[p]:
            v = cx.vertices[cx.faces[f]]
            a, b = v, np.roll(v, -1, axis=0)
            s = (a[:, 2] - z) * (b[:, 2] - z)
            cross = s < 0
            t = (z - a[cross, 2]) / (b[cross, 2] - a[cross, 2])
            seg.extend(a[cross, :2] + t[:, None] * (b[cross, :2] - a[cross, :2]))
        if len(seg) < 3:
            continue
        pts = np.unique(np.round(np.array(seg), 12), axis=0)
        if len(pts) < 3:
            continue
        c = pts.mean(axis=0)
        pts = pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]
        polys.append(pts * 1e3)
        minerals.append(int(assembly.grain_mineral[cx.piece_grain[p]]))
    return polys, minerals


def plot_assembly3d(assembly: GrainAssembly, path: str | Path, *,
                    title: str | None = None) -> Path:
    """Save a PNG: the specimen's outer faces by mineral (3D view) and a mid-height section
    (grains by mineral, fissured faces crossing it in red)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    mesh = assembly.mesh
    cx = mesh.grains
    names = assembly.mineral_table.names
    colours = [MINERAL_COLOURS.get(n, "#999999") for n in names]
    fig = plt.figure(figsize=(12.5, 5.6), dpi=130)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    surface = np.flatnonzero(cx.face_pieces[:, 1] < 0)
    polys = [cx.vertices[cx.faces[f]] * 1e3 for f in surface]
    face_colour = [colours[assembly.grain_mineral[cx.piece_grain[cx.face_pieces[f, 0]]]]
                   for f in surface]
    ax.add_collection3d(Poly3DCollection(polys, facecolors=face_colour, edgecolors="#444444",
                                         linewidths=0.3))
    lo, hi = cx.solid.lo * 1e3, cx.solid.hi * 1e3
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(hi - lo))
    # As many z ticks as the axis is long against the others (a thin slab's ran into
    # each other).
    nbins = max(1, round(5 * (hi[2] - lo[2]) / float(np.max(hi - lo))))
    ax.zaxis.set_major_locator(MaxNLocator(nbins))
    ax.view_init(elev=28, azim=-58)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title("outer faces and borehole wall" if cx.solid.borehole_radius > 0
                 else "outer faces", fontsize=10)

    ax2 = fig.add_subplot(1, 2, 2)
    # Just off mid-height: the borehole ring's layer faces can lie exactly on it.
    z = 0.5 * (cx.solid.lo[2] + cx.solid.hi[2]) + 0.037 * float(cx.solid.extent[2])
    sec, minerals = _mid_section(assembly, z)
    ax2.add_collection(PolyCollection(sec, facecolors=[colours[m] for m in minerals],
                                      edgecolors="#555555", linewidths=0.4))
    fiss_faces = np.flatnonzero((mesh.face_interface >= 0)
                                & assembly.interface_fissure[np.maximum(mesh.face_interface, 0)])
    segs = []
    for f in fiss_faces:
        v = cx.vertices[cx.faces[f]]
        a, b = v, np.roll(v, -1, axis=0)
        cross = (a[:, 2] - z) * (b[:, 2] - z) < 0
        if cross.sum() == 2:
            t = (z - a[cross, 2]) / (b[cross, 2] - a[cross, 2])
            segs.append((a[cross, :2] + t[:, None] * (b[cross, :2] - a[cross, :2])) * 1e3)
    if segs:
        ax2.add_collection(LineCollection(segs, colors=FISSURE_COLOUR, linewidths=1.4))
    ax2.set_xlim(lo[0], hi[0])
    ax2.set_ylim(lo[1], hi[1])
    ax2.set_aspect("equal")
    ax2.set_xlabel("x (mm)")
    ax2.set_ylabel("y (mm)")
    ax2.set_title(f"section z = {z * 1e3:.1f} mm", fontsize=10)
    ax2.legend(handles=legend_handles(assembly), loc="upper left", bbox_to_anchor=(1.01, 1.0),
               fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    fig.subplots_adjust(wspace=0.3)  # tight_layout does not see the 3D view's z label
    return save_png(fig, path, crop=True, fit=False)
