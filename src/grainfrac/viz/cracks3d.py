"""Figures of the cracks of a 3D run: a 3D view of the cracked grain-face patches and
four cross-sections along the well (paper Fig. 19c).

Colours are those of the 2D fracture figure (:mod:`grainfrac.viz.fractures`):
tensile blue, shear red, so a 2D and a 3D run read the same way.

A cracked sub-contact is drawn as its patch: its third of every face triangle
around its point (:func:`grainfrac.analysis.fractures3d.contact_patches`),
coloured by its own mode. This is exact rather than a vote: the drawn tensile
and shear surfaces are the areas the analysis sums, a half-cracked face shows
as such, and a triangle between a tensile and a shear sub-contact shows both
colours (colouring whole triangles by the majority of their cracked corners
would paint uncracked thirds and hide minorities). A triangle whose three
corners cracked in the same mode is drawn whole (three patch pieces merged
into one polygon with the same area and colour), which cuts the polygon count
about threefold on fully cracked faces. Beyond ``max_polygons`` a fixed random
subset is drawn and the figure says so.
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

from grainfrac.analysis.fractures3d import (  # noqa: E402
    SECTION_FRACTIONS,
    corner_quads,
    cracked_contacts,
    cross_sections,
    fracture_area,
    grain_boundary_section,
    patch_triangles,
)
from grainfrac.assembly import GrainAssembly  # noqa: E402
from grainfrac.geometry.meshing3d import GrainMesh3D  # noqa: E402
from grainfrac.geometry.solids3d import Solid  # noqa: E402
from grainfrac.physics.kernels import SHEAR, TENSILE  # noqa: E402
from grainfrac.viz.fractures import SHEAR_COLOUR, TENSILE_COLOUR  # noqa: E402
from grainfrac.viz.saving import save_png  # noqa: E402

__all__ = [
    "MAX_POLYGONS",
    "crack_polygons",
    "plot_cracks3d",
    "plot_cross_sections",
    "write_crack_figures3d",
]

#: Most polygons drawn in the 3D view (about 1 s of rendering per 5e4).
MAX_POLYGONS = 100_000
VIEW_FIGSIZE = (8.0, 7.0)  # inches: 800 x 700 pixels at DPI
SECTIONS_FIGSIZE = (10.0, 10.0)  # 1000 x 1000
DPI = 100
_MODES = ((TENSILE, "tensile", TENSILE_COLOUR), (SHEAR, "shear", SHEAR_COLOUR))
_GRAIN_BOUNDARY_COLOUR = "#c8c8c8"
_OUTLINE_COLOUR = "#222222"
_BOREHOLE_COLOUR = "#555555"


# --------------------------------------------------------------------------- geometry


def crack_polygons(assembly: GrainAssembly | GrainMesh3D, contact,
                   mode) -> tuple[np.ndarray, np.ndarray]:
    """The polygons that draw the cracked patches, and the mode of each.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).

    Returns
    -------
    polygons : np.ndarray
        (n, 4, 3) corners (m): a patch piece (a third of a face triangle), or a
        whole triangle (last corner repeated) where its three corners cracked
        in the same mode. Their areas by mode are the tensile and shear areas.
    mode : np.ndarray
        (n,) mode code of each polygon.
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    triangles, owner = patch_triangles(mesh, ids)
    corner_mode = np.where(owner >= 0, codes[np.maximum(owner, 0)], -1)
    whole = (owner >= 0).all(axis=1) & (corner_mode[:, 0] == corner_mode[:, 1]) \
        & (corner_mode[:, 1] == corner_mode[:, 2])
    t_idx, k = np.nonzero((owner >= 0) & ~whole[:, None])
    pieces = corner_quads(triangles, t_idx, k)
    full = triangles[whole]
    full = np.concatenate((full, full[:, 2:3]), axis=1)  # a triangle as a 4-gon
    return (np.concatenate((full, pieces)),
            np.concatenate((corner_mode[whole, 0], corner_mode[t_idx, k])))


def _box_edges(lo: np.ndarray, hi: np.ndarray, far: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(12, 2, 3) edges of the box, and True for the three that meet at corner ``far``.

    Corners are named by one bit per axis (0: ``lo``, 1: ``hi``); an edge joins
    two corners that differ in one bit.
    """
    bits = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)])
    pairs = [(i, j) for i in range(8) for j in range(i + 1, 8)
             if np.count_nonzero(bits[i] != bits[j]) == 1]
    corner = np.where(bits == 1, hi, lo)
    edges = np.array([(corner[i], corner[j]) for i, j in pairs], dtype=float)
    at_far = np.array([np.array_equal(bits[i], far) or np.array_equal(bits[j], far)
                       for i, j in pairs])
    return edges, at_far


def _borehole_ring(solid: Solid) -> np.ndarray:
    """(n + 1, 2) the wall's facet vertices (on the nominal circle), closed (m)."""
    n = solid.borehole_facets
    phi = np.arange(n + 1) * 2 * math.pi / n
    return solid.borehole_radius * np.column_stack((np.cos(phi), np.sin(phi)))


def _view_vector(elev: float, azim: float) -> np.ndarray:
    """Unit vector from the scene towards the viewer (matplotlib's elev/azim)."""
    e, a = math.radians(elev), math.radians(azim)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def _shaded(polygons: np.ndarray, colours: np.ndarray, light: np.ndarray) -> np.ndarray:
    """Colours dimmed by the angle between each polygon and the light, lit on both sides.

    A crack is a thin surface seen from either side and the face triangles have
    no common orientation, so the brightness uses ``|n . light|``. The hue is
    kept, so the modes stay told apart by colour.
    """
    n = np.cross(polygons[:, 1] - polygons[:, 0], polygons[:, 2] - polygons[:, 0])
    norm = np.linalg.norm(n, axis=1)
    cos = np.abs(n @ light) / np.where(norm > 0, norm, 1.0)
    return colours * (0.55 + 0.45 * cos)[:, None]


def _fraction_label(f: float) -> str:
    q = Fraction(f).limit_denominator(64)
    return f"{q.numerator}/{q.denominator}" if abs(float(q) - f) < 1e-9 else f"{f:.3g}"


def _mode_handles(codes: np.ndarray, area: dict[str, float | None] | None,
                  patch: bool) -> list:
    """Legend entries for the modes present only, so a colour absent from the cracks
    is absent from the figure; with ``area``, the number of cracks and their area."""
    handles = []
    for code, name, colour in _MODES:
        n = int(np.count_nonzero(codes == code))
        if n == 0:
            continue
        label = name
        if area is not None:
            label += f": {n} sub-contacts, {area[f'{name}_area_m2'] * 1e6:.1f} mm$^2$"
        handles.append(Patch(facecolor=colour, label=label) if patch
                       else Line2D([], [], color=colour, lw=2.0, label=label))
    return handles


# --------------------------------------------------------------------------- 3D view


def plot_cracks3d(assembly: GrainAssembly | GrainMesh3D, contact, mode, path: str | Path, *,
                  title: str | None = None, elev: float = 28.0, azim: float = -58.0,
                  max_polygons: int = MAX_POLYGONS,
                  sections: tuple[float, ...] = SECTION_FRACTIONS) -> Path:
    """Save a PNG of the cracked grain-face patches in 3D (tensile blue, shear red).

    The specimen box and the borehole are drawn as outlines, the heights of the
    cross-sections of :func:`plot_cross_sections` as dashed rectangles. Axes in mm.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).
    path : str or Path
        PNG to write (800 x 700 pixels).
    title : str, optional
        Title above the view.
    elev, azim : float, optional
        View direction (degrees), as matplotlib's ``view_init``.
    max_polygons : int, optional
        Most polygons drawn; beyond it a fixed random subset is drawn.
    sections : tuple of float, optional
        Heights (fractions of the specimen height) marked as dashed rectangles;
        empty for none.

    Returns
    -------
    Path
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    if max_polygons < 1:
        raise ValueError(f"max_polygons must be >= 1 (got {max_polygons})")
    solid = mesh.grains.solid
    lo, hi = solid.lo * 1e3, solid.hi * 1e3
    polygons, poly_mode = crack_polygons(mesh, ids, codes)
    note = ""
    if len(polygons) > max_polygons:
        keep = np.sort(np.random.default_rng(0).choice(len(polygons), max_polygons,
                                                       replace=False))
        note = f" (drawn: {max_polygons} of {len(polygons)} patch pieces)"
        polygons, poly_mode = polygons[keep], poly_mode[keep]

    fig = plt.figure(figsize=VIEW_FIGSIZE, dpi=DPI)
    ax = fig.add_subplot(projection="3d")
    # The 3D axes leave wide margins by default; give the box the figure.
    fig.subplots_adjust(left=0.0, right=0.94, bottom=0.07, top=0.96)
    ax.view_init(elev=elev, azim=azim)
    # Depth order is set by hand: hidden box edges, then the cracks (one
    # collection, its polygons sorted by depth), then the outlines in front.
    ax.computed_zorder = False
    eye = _view_vector(elev, azim)
    # The box corner farthest from the viewer: its three edges are hidden.
    edges, hidden = _box_edges(lo, hi, (eye < 0).astype(int))
    ax.add_collection3d(Line3DCollection(edges[hidden], colors=_OUTLINE_COLOUR,
                                         linewidths=0.6, linestyles="dashed", zorder=1))
    if len(polygons):
        base = np.array([to_rgb(TENSILE_COLOUR if m == TENSILE else SHEAR_COLOUR)
                         for m in (TENSILE, SHEAR)])[(poly_mode == SHEAR).astype(int)]
        light = eye + np.array([-0.3, 0.3, 0.6])
        face = _shaded(polygons, base, light / np.linalg.norm(light))
        # Edges in the face colour close the hairline seams between pieces.
        ax.add_collection3d(Poly3DCollection(polygons * 1e3, facecolors=face, edgecolors=face,
                                             linewidths=0.25, zorder=2))
    ax.add_collection3d(Line3DCollection(edges[~hidden], colors=_OUTLINE_COLOUR,
                                         linewidths=1.0, zorder=4))
    if solid.has_borehole:
        ring = _borehole_ring(solid) * 1e3
        rims = [np.column_stack((ring, np.full(len(ring), z))) for z in (lo[2], hi[2])]
        walls = np.stack((rims[0][:-1], rims[1][:-1]), axis=1)
        ax.add_collection3d(Line3DCollection(rims + list(walls), colors=_BOREHOLE_COLOUR,
                                             linewidths=0.7, zorder=3))
    for f in sections:
        z = lo[2] + f * (hi[2] - lo[2])
        rect = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]],
                         [lo[0], lo[1]]])
        ax.add_collection3d(Line3DCollection([np.column_stack((rect, np.full(5, z)))],
                                             colors="#888888", linewidths=0.5,
                                             linestyles=(0, (4, 3)), zorder=3))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    # zoom above 1 would let the box out of the axes, which clip what leaves them.
    ax.set_box_aspect(hi - lo)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_pane_color((1.0, 1.0, 1.0, 0.0))
    heading = title if title is not None else "Cracked grain-face patches"
    if ids.size == 0:
        heading += ": no cracks"
    ax.set_title(heading + note, fontsize=10)
    handles = _mode_handles(codes, fracture_area(mesh, ids, codes), patch=True)
    if handles:
        fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9,
                   frameon=False)
    return save_png(fig, path, fit=False)  # uncropped: the figure's own pixel size


# --------------------------------------------------------------------------- sections


def plot_cross_sections(assembly: GrainAssembly | GrainMesh3D, contact, mode,
                        path: str | Path, *, fractions: tuple[float, ...] = SECTION_FRACTIONS,
                        title: str | None = None) -> Path:
    """Save a PNG of cross-sections z = const along the well (paper Fig. 19c).

    One x-y panel per plane: the grain boundaries cut by it (grey), the
    specimen outline, the borehole and the traces of the cracked patches
    (tensile blue, shear red). Axes in mm.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).
    path : str or Path
        PNG to write (1000 x 1000 pixels).
    fractions : tuple of float, optional
        Plane heights as fractions of the specimen height; default 1/8, 3/8,
        5/8, 7/8.
    title : str, optional
        Title above the panels.

    Returns
    -------
    Path
    """
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    cuts = cross_sections(mesh, ids, codes, fractions)
    solid = mesh.grains.solid
    lo, hi = solid.lo * 1e3, solid.hi * 1e3
    ncols = 1 if len(cuts) == 1 else 2
    nrows = math.ceil(len(cuts) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=SECTIONS_FIGSIZE, dpi=DPI, squeeze=False)
    pad = 0.03 * float(np.max(hi[:2] - lo[:2]))
    for ax, cut in zip(axes.ravel(), cuts, strict=False):
        grain = grain_boundary_section(mesh, cut.z) * 1e3
        ax.add_collection(LineCollection(grain, colors=_GRAIN_BOUNDARY_COLOUR, linewidths=0.6))
        ax.plot([lo[0], hi[0], hi[0], lo[0], lo[0]], [lo[1], lo[1], hi[1], hi[1], lo[1]],
                color=_OUTLINE_COLOUR, lw=1.0)
        if solid.has_borehole:
            ring = _borehole_ring(solid) * 1e3
            ax.fill(ring[:, 0], ring[:, 1], facecolor="white", edgecolor=_OUTLINE_COLOUR,
                    lw=1.0, zorder=3)
        for code, _, colour in _MODES:
            seg = cut.segments[cut.mode == code] * 1e3
            if len(seg):
                ax.add_collection(LineCollection(seg, colors=colour, linewidths=2.0,
                                                 capstyle="round", zorder=2))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_title(f"z = {cut.z * 1e3:.1f} mm ({_fraction_label(cut.fraction)} of the "
                     f"height): {cut.n_cracks} cracked sub-contacts cut", fontsize=9)
    for ax in axes.ravel()[len(cuts):]:
        ax.set_axis_off()
    handles = [Line2D([], [], color=_GRAIN_BOUNDARY_COLOUR, lw=1.0, label="grain boundaries")]
    handles += _mode_handles(np.concatenate([c.mode for c in cuts]) if cuts else codes[:0],
                             None, patch=False)
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9,
               frameon=False)
    heading = title if title is not None else "Cross-sections along the well"
    fig.suptitle(heading + ("" if ids.size else ": no cracks"), fontsize=11)
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    return save_png(fig, path, fit=False)  # uncropped: the figure's own pixel size


# --------------------------------------------------------------------------- both


def write_crack_figures3d(assembly: GrainAssembly | GrainMesh3D, contact, mode,
                          directory: str | Path, *, title: str | None = None
                          ) -> dict[str, Path]:
    """Write the 3D view and the cross-sections of a 3D crack set into ``directory``.

    Parameters
    ----------
    assembly : GrainAssembly or GrainMesh3D
        A 3D assembly.
    contact : array_like of int
        Cracked sub-contact ids.
    mode : array_like
        Failure mode per crack (codes or names).
    directory : str or Path
        Created if missing.
    title : str, optional
        Title of both figures.

    Returns
    -------
    dict
        ``{"fractures3d": Path, "fracture_sections": Path}``, the PNGs written.
    """
    # Checked once here so that a bad input writes neither figure.
    mesh, ids, codes = cracked_contacts(assembly, contact, mode)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    return {
        "fractures3d": plot_cracks3d(mesh, ids, codes, directory / "fractures3d.png",
                                     title=title),
        "fracture_sections": plot_cross_sections(mesh, ids, codes,
                                                 directory / "fracture_sections.png",
                                                 title=title),
    }
