"""Boundary conditions as nodal arrays.

Stresses at the user edge are compressive magnitudes (paper Table 6); a
compressive stress ``s`` on a side with outward normal ``n`` is the traction
``-s n``. A borehole pressure is the same push on the borehole wall.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from grainfrac.loading.boundary3d import far_field_stress_forces3d, normal_pressure_forces3d

if TYPE_CHECKING:  # loads are plain arrays; the mesher is needed only to build them
    from grainfrac.geometry.meshing import GrainMesh


@dataclass
class Platen:
    """A rigid, frictionless platen acting on ``nodes`` along ``axis``.

    ``side = +1``: the platen is on the positive side (above / right) and pushes
    towards negative ``axis``; ``-1`` the opposite. It moves at ``velocity``
    (m/s, along ``axis``); the penalty stiffness per node follows the
    contact springs so it is as stiff as the rock without limiting the step.
    """

    nodes: np.ndarray
    axis: int
    side: int
    position: float
    velocity: float
    stiffness: np.ndarray
    reaction: float = 0.0


@dataclass
class Loads:
    """External nodal forces, fixed components and platens."""

    external: np.ndarray  # (n, d) constant nodal forces (N)
    fixed: np.ndarray  # (n, d) bool
    prescribed_velocity: np.ndarray  # (n, d)
    platens: list[Platen] = field(default_factory=list)

    @classmethod
    def free(cls, n_nodes: int, dimension: int = 2) -> Loads:
        """No forces, nothing fixed, no platens."""
        return cls(np.zeros((n_nodes, dimension)), np.zeros((n_nodes, dimension), dtype=bool),
                   np.zeros((n_nodes, dimension)))


def side_traction_forces(mesh: GrainMesh, side: str, traction: np.ndarray) -> np.ndarray:
    """Nodal forces (N) of a uniform traction vector (Pa) on a named side."""
    faces = mesh.boundary_faces[side]
    out = np.zeros((mesh.n_nodes, 2))
    half = 0.5 * (faces.length * mesh.thickness)[:, None] * np.asarray(traction)[None, :]
    np.add.at(out, faces.nodes[:, 0], half)
    np.add.at(out, faces.nodes[:, 1], half)
    return out


def normal_pressure_forces(mesh: GrainMesh, side: str, pressure: float) -> np.ndarray:
    """Nodal forces (N) of a pressure (Pa, compression positive) normal to a side
    (a 3D mesh: :func:`grainfrac.loading.boundary3d.normal_pressure_forces3d`)."""
    if mesh.dimension == 3:
        return normal_pressure_forces3d(mesh, side, pressure)
    faces = mesh.boundary_faces[side]
    out = np.zeros((mesh.n_nodes, 2))
    half = -0.5 * pressure * (faces.length * mesh.thickness)[:, None] * faces.normal
    np.add.at(out, faces.nodes[:, 0], half)
    np.add.at(out, faces.nodes[:, 1], half)
    return out


def far_field_stress_forces(mesh: GrainMesh, sigma_x: float, sigma_y: float,
                            sigma_z: float = 0.0) -> np.ndarray:
    """Nodal forces of compressive far-field stresses on a rectangle's outer sides (Pa);
    on a 3D box's six faces with ``sigma_z`` on its top and bottom
    (:func:`grainfrac.loading.boundary3d.far_field_stress_forces3d`)."""
    if mesh.dimension == 3:
        return far_field_stress_forces3d(mesh, sigma_x, sigma_y, sigma_z)
    out = np.zeros((mesh.n_nodes, 2))
    for side, s in (("left", sigma_x), ("right", sigma_x), ("bottom", sigma_y), ("top", sigma_y)):
        out += normal_pressure_forces(mesh, side, s)
    return out
