"""One mesh record for both dimensions: nodes, simplex cells and sub-contacts.

The 2D grain mesher (:mod:`grainfrac.geometry.meshing`) produces a richer
:class:`~grainfrac.geometry.meshing.GrainMesh` (grain boundaries, the flow
network, named sides); :meth:`GrainMesh.record` reduces it to this record, which
is what the mechanics needs and what a 3D mesher produces directly. Arrays are
SI: ``x[n, d]``, ``cells[m, d + 1]`` (counter-clockwise triangles or right-handed
tetrahedra), cell measures (area x thickness in 2D, volume in 3D), sub-contacts
as node pairs with areas and an orthonormal frame ``[c, d, d]`` (the unit normal
from the first node's grain to the second's, then d - 1 tangents).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainfrac.errors import GeometryError


def tet_volumes(p: np.ndarray) -> np.ndarray:
    """Signed volumes of tetrahedra ``p[m, 4, 3]`` (m3): ``(x1 - x0) x (x2 - x0) . (x3 - x0) / 6``.
    """
    a, b, c = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    # The cross product written out: np.cross costs more than the sum on small arrays.
    return ((a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]) * c[:, 0]
            + (a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]) * c[:, 1]
            + (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) * c[:, 2]) / 6.0


def simplex_measure(x: np.ndarray, cells: np.ndarray, thickness: float = 1.0) -> np.ndarray:
    """Signed measure of simplices (m3): area x thickness in 2D, volume in 3D.

    Positive for counter-clockwise triangles and right-handed tetrahedra.
    """
    p = x[cells]
    if x.shape[1] == 3:
        return tet_volumes(p)
    edges = p[:, 1:] - p[:, :1]
    return 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 1, 0] * edges[:, 0, 1]) * thickness


def contact_frame(normal: np.ndarray) -> np.ndarray:
    """Orthonormal frames ``[c, d, d]`` from unit normals: the normal, then tangents.

    2D: the tangent is the normal rotated by +90 degrees. 3D: the first tangent is
    the normal crossed with the coordinate axis least aligned with it, the second
    ``n x t1`` (right-handed).
    """
    normal = np.asarray(normal, dtype=np.float64)
    c, d = normal.shape
    frame = np.empty((c, d, d))
    frame[:, 0] = normal
    if d == 2:
        frame[:, 1, 0] = -normal[:, 1]
        frame[:, 1, 1] = normal[:, 0]
        return frame
    axis = np.zeros_like(normal)
    axis[np.arange(c), np.argmin(np.abs(normal), axis=1)] = 1.0
    t1 = np.cross(normal, axis)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    frame[:, 1] = t1
    frame[:, 2] = np.cross(normal, t1)
    return frame


@dataclass(frozen=True)
class Mesh:
    """Nodes, cells and sub-contacts of a grain assembly, for either dimension."""

    x: np.ndarray  # (n, d)
    cells: np.ndarray  # (m, d + 1)
    cell_grain: np.ndarray  # (m,)
    cell_measure: np.ndarray  # (m,) m3
    contact_nodes: np.ndarray  # (c, 2)
    contact_area: np.ndarray  # (c,) m2
    contact_frame: np.ndarray  # (c, d, d)
    thickness: float = 1.0  # plane-strain slice (2D); 1 in 3D

    @property
    def dimension(self) -> int:
        return self.x.shape[1]

    @property
    def n_nodes(self) -> int:
        return len(self.x)

    @property
    def n_cells(self) -> int:
        return len(self.cells)

    @property
    def n_contacts(self) -> int:
        return len(self.contact_nodes)

    def problems(self) -> list[str]:
        """What is wrong with the record (empty when it is valid)."""
        d = self.dimension
        out = []
        if d not in (2, 3):
            out.append(f"x has {d} columns; a mesh is 2D or 3D")
            return out
        if self.cells.ndim != 2 or self.cells.shape[1] != d + 1:
            out.append(f"cells have shape {self.cells.shape}; {d}D cells need {d + 1} nodes")
            return out
        if len(self.cells) and (self.cells.min() < 0 or self.cells.max() >= self.n_nodes):
            out.append("cells name nodes that do not exist")
        if len(self.cell_grain) != self.n_cells or len(self.cell_measure) != self.n_cells:
            out.append("cell_grain and cell_measure need one value per cell")
        elif np.any(self.cell_measure <= 0):
            out.append(f"{int(np.sum(self.cell_measure <= 0))} cells have no positive measure "
                       "(inverted or degenerate)")
        c = self.n_contacts
        if self.contact_nodes.shape != (c, 2) or len(self.contact_area) != c:
            out.append("contacts need a node pair and an area each")
        elif c and (self.contact_nodes.min() < 0 or self.contact_nodes.max() >= self.n_nodes):
            out.append("contacts name nodes that do not exist")
        if self.contact_frame.shape != (c, d, d):
            out.append(f"contact_frame has shape {self.contact_frame.shape}, needs {(c, d, d)}")
        elif c:
            gram = np.einsum("cij,ckj->cik", self.contact_frame, self.contact_frame)
            err = float(np.abs(gram - np.eye(d)[None]).max())
            if err > 1e-9:
                out.append(f"contact frames are not orthonormal (worst error {err:.1e})")
        if c and np.any(self.contact_area <= 0):
            out.append("contact areas must be positive")
        return out

    def validated(self) -> Mesh:
        """The record itself if valid; else :class:`GeometryError` listing the problems."""
        problems = self.problems()
        if problems:
            raise GeometryError("invalid mesh: " + "; ".join(problems))
        return self
