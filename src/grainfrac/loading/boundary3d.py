"""Boundary loads of 3D assemblies as nodal forces, from the surface triangles.

A 3D mesh (:class:`~grainfrac.geometry.meshing3d.GrainMesh3D`) lists, for each
named side (``x-``, ``x+``, ``y-``, ``y+``, ``z-``, ``z+``, ``borehole``; a cylinder's
``lateral``, the NSCB's ``base``, ``arc`` and ``notch``), the
triangles of the grain faces lying on it (``surface_triangles``, node ids).
On a linear triangle the consistent nodal load of a uniform traction ``t`` is
``t A / 3`` at each corner (the integral of each linear shape function over the
triangle is A/3), so a uniform traction is applied exactly.

Sign convention as in :mod:`grainfrac.loading.boundary`: stresses and
pressures at the user edge are compressive magnitudes (paper Table 6), and a
compressive stress ``s`` on a surface with outward normal ``n`` (out of the
rock) is the traction ``-s n``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from grainfrac.geometry.solids3d import BOREHOLE, LATERAL

if TYPE_CHECKING:  # loads are plain arrays; the mesher is needed only to build them
    from grainfrac.geometry.meshing3d import GrainMesh3D

#: Outward normals (out of the rock) of the box sides.
SIDE_NORMALS = {
    "x-": (-1.0, 0.0, 0.0), "x+": (1.0, 0.0, 0.0),
    "y-": (0.0, -1.0, 0.0), "y+": (0.0, 1.0, 0.0),
    "z-": (0.0, 0.0, -1.0), "z+": (0.0, 0.0, 1.0),
}


def surface_triangles(mesh: GrainMesh3D, side: str) -> tuple[np.ndarray, np.ndarray,
                                                              np.ndarray]:
    """Triangles of a named side: node ids ``(t, 3)``, areas ``(t,)`` (m2) and unit outward
    normals ``(t, 3)`` (out of the rock).

    The normal is that of the triangle's plane, oriented away from the rock: along the
    side's normal for a box side, towards the borehole axis for the borehole wall, and
    for the other sides of 3D solids the way that leaves the solid (the mesher's winding
    is not relied on).
    """
    if side not in mesh.surface_triangles:
        raise KeyError(f"no surface {side!r}; the mesh has {', '.join(mesh.surface_triangles)}")
    tri = mesh.surface_triangles[side]
    p = mesh.node_x[tri]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    normal = cross / twice[:, None]
    if side == BOREHOLE:
        # Out of the rock is into the hole: against the radial direction from the z axis.
        centroid = p.mean(axis=1)
        out = -np.column_stack((centroid[:, 0], centroid[:, 1], np.zeros(len(tri))))
    elif side in SIDE_NORMALS:
        out = np.broadcast_to(np.asarray(SIDE_NORMALS[side]), normal.shape)
    else:
        # The other sides of the 3D solids (a cylinder's lateral surface, the NSCB arc,
        # base and notch): a point just off the triangle along its outward normal
        # leaves the solid (1 um: far above round-off, far below a zone).
        solid = mesh.grains.solid
        probe = p.mean(axis=1) + 1e-6 * normal
        out = np.where(solid.inside(probe)[:, None], -normal, normal)
    normal *= np.sign(np.einsum("ij,ij->i", normal, out))[:, None]
    return tri, 0.5 * twice, normal


def _spread(mesh: GrainMesh3D, tri: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Nodal forces ``(n, 3)``: a third of each triangle's force ``(t, 3)`` to each corner."""
    out = np.zeros((mesh.n_nodes, 3))
    for k in range(3):
        np.add.at(out, tri[:, k], force / 3.0)
    return out


def side_traction_forces3d(mesh: GrainMesh3D, side: str, traction) -> np.ndarray:
    """Nodal forces (N) of a uniform traction vector (Pa) on a named side.

    ``F_a = sum over the side's triangles T touching node a of t A_T / 3``.
    """
    tri, area, _ = surface_triangles(mesh, side)
    return _spread(mesh, tri, area[:, None] * np.asarray(traction, dtype=float)[None, :])


def normal_pressure_forces3d(mesh: GrainMesh3D, side: str, pressure: float) -> np.ndarray:
    """Nodal forces (N) of a pressure (Pa, compression positive) normal to a side.

    The traction of triangle T is ``-p n_T`` (``n_T`` out of the rock), so on the
    faceted borehole wall each facet is pushed along its own normal.
    """
    tri, area, normal = surface_triangles(mesh, side)
    return _spread(mesh, tri, -pressure * area[:, None] * normal)


def far_field_stress_forces3d(mesh: GrainMesh3D, sigma_x: float, sigma_y: float,
                              sigma_z: float) -> np.ndarray:
    """Nodal forces of the in-situ stresses (paper Table 6; compressive Pa) on a box's
    six faces: ``sigma_x`` on ``x-``/``x+``, ``sigma_y`` on ``y-``/``y+``, ``sigma_z``
    on ``z-``/``z+``. A cylinder (no x and y faces) takes ``sigma_x = sigma_y`` as a
    confining pressure on its lateral surface. The borehole wall is left free."""
    out = np.zeros((mesh.n_nodes, 3))
    if "x-" not in mesh.surface_triangles and (sigma_x or sigma_y):
        if sigma_x != sigma_y:
            raise ValueError(f"a cylinder takes one lateral pressure: sigma_x ({sigma_x:g} Pa) "
                             f"must equal sigma_y ({sigma_y:g} Pa)")
        out += normal_pressure_forces3d(mesh, LATERAL, sigma_x)
        sigma_x = sigma_y = 0.0
    for axis, s in zip("xyz", (sigma_x, sigma_y, sigma_z), strict=True):
        if s:
            for sign in "-+":
                out += normal_pressure_forces3d(mesh, axis + sign, s)
    return out
