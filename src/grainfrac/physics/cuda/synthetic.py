"""Synthetic 3D grain blocks for the GPU tests and benchmark (no tessellation stack).

A cube of ``n^3`` sub-cubes, each cut into 6 right-handed tetrahedra (Kuhn split,
as ``tests/test_elements.py::tet_block``), is cut into slab "grains" by planes
normal to x: the nodes on each plane are duplicated, the cells beyond it take the
copies, and each node pair is joined by a bonded sub-contact (normal +x, area the
node's tributary share of the plane). Quartz-like properties (paper Table 2:
E = 76 GPa, nu = 0.08, 2650 kg/m3; Q-Q contacts kn = 1.853e14, ks = 3.51e13 Pa/m,
phi = 40.5 deg, c = 56.44 MPa, sigma_T = 17.92 MPa).
"""

from __future__ import annotations

import itertools
import math
from typing import NamedTuple

import numpy as np

from grainfrac.geometry.mesh import contact_frame
from grainfrac.physics.elements import tetrahedron
from grainfrac.physics.model import MechanicalModel, model_from_arrays

MPA = 1e6
QUARTZ = {"youngs_modulus": 76e9, "poisson_ratio": 0.08, "density": 2650.0}
KN, KS = 185300.0e9, 35105.0e9  # Pa/m
FRICTION = math.radians(40.5)
COHESION, TENSILE = 56.44 * MPA, 17.92 * MPA


class GrainBlock(NamedTuple):
    """The model and the nodes of its two x faces (to hold and to pull)."""

    model: MechanicalModel
    low_face: np.ndarray
    high_face: np.ndarray


def _kuhn_cells() -> np.ndarray:
    """The 6 tets of the unit cube as corner numbers ``a*4 + b*2 + c``, right-handed."""
    corners = np.array(list(itertools.product((0, 1), repeat=3)), dtype=float)
    cells = []
    for perm in itertools.permutations(range(3)):
        step = [0, 0, 0]
        path = [0]
        for axis in perm:
            step[axis] = 1
            path.append(step[0] * 4 + step[1] * 2 + step[2])
        cells.append(path)
    cells = np.array(cells)
    _, vol = tetrahedron.gradients(corners, cells)
    cells[vol < 0] = cells[vol < 0][:, [0, 2, 1, 3]]
    return cells


def grain_block(n: int, *, size: float = 0.01, cuts: int = 2, softening: bool = True,
                mass_scaling: bool = True) -> GrainBlock:
    """A block of ``6 n^3`` tetrahedra in (at most) ``cuts + 1`` slab grains, bonded.

    With ``softening`` every other contact plane has G_I = 40 and G_II = 400 J/m2
    (linear softening), the others are brittle.
    """
    m = n + 1
    g = np.linspace(0.0, size, m)
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    local = _kuhn_cells()
    corner_offset = np.array([(a * m + b) * m + c for a, b, c in
                              itertools.product((0, 1), repeat=3)])
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), np.arange(n),
                                              indexing="ij"))
    base = (i * m + j) * m + k
    cells = (base[:, None, None] + corner_offset[local][None]).reshape(-1, 4)
    cube_i = np.repeat(i, 6)
    # Distinct interior planes (a small block has room for fewer than asked).
    planes = sorted({round(n * (p + 1) / (cuts + 1)) for p in range(cuts)} - {0, n})
    node_i = np.repeat(np.arange(m), m * m)
    xs, pairs, areas, soft = [x], [], [], []
    h = size / n
    jj, kk = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    tributary = (h * np.where((jj == 0) | (jj == n), 0.5, 1.0)
                 * h * np.where((kk == 0) | (kk == n), 0.5, 1.0)).ravel()
    n_nodes = len(x)
    for p, plane in enumerate(planes):
        on_plane = np.flatnonzero(node_i == plane)
        copy = n_nodes + np.arange(len(on_plane))
        n_nodes += len(on_plane)
        xs.append(x[on_plane])
        remap = np.full(n_nodes, -1)
        remap[on_plane] = copy
        beyond = cube_i >= plane
        sub = cells[beyond]
        moved = remap[sub] >= 0
        sub[moved] = remap[sub[moved]]
        cells[beyond] = sub
        pairs.append(np.stack([on_plane, copy], axis=1))
        areas.append(tributary)
        soft.append(np.full(len(on_plane), softening and p % 2 == 0))
    x = np.concatenate(xs)
    contact_nodes = np.concatenate(pairs) if pairs else np.zeros((0, 2), np.int64)
    c = len(contact_nodes)
    normal = np.zeros((c, 3))
    normal[:, 0] = 1.0
    soft = np.concatenate(soft) if soft else np.zeros(0, bool)
    ne = len(cells)
    model = model_from_arrays(
        x=x, cells=cells, youngs_modulus=np.full(ne, QUARTZ["youngs_modulus"]),
        poisson_ratio=np.full(ne, QUARTZ["poisson_ratio"]),
        density=np.full(ne, QUARTZ["density"]), contact_nodes=contact_nodes,
        contact_frame=contact_frame(normal), contact_area=np.concatenate(areas),
        normal_stiffness=np.full(c, KN), shear_stiffness=np.full(c, KS),
        friction_angle=np.full(c, FRICTION), cohesion=np.full(c, COHESION),
        tensile_strength=np.full(c, TENSILE), bonded=np.ones(c, bool),
        tensile_fracture_energy=np.where(soft, 40.0, 0.0),
        shear_fracture_energy=np.where(soft, 400.0, 0.0), mass_scaling=mass_scaling,
    )
    low = np.flatnonzero(np.isclose(x[:, 0], 0.0))
    high = np.flatnonzero(np.isclose(x[:, 0], size))
    return GrainBlock(model, low, high)


def pull_loads(block: GrainBlock, velocity: tuple[float, float, float]):
    """Loads that hold the x = 0 face and move the x = size face at ``velocity`` (m/s)."""
    from grainfrac.loading.boundary import Loads

    model = block.model
    loads = Loads.free(model.n_nodes, 3)
    loads.fixed[block.low_face] = True
    loads.fixed[block.high_face] = True
    loads.prescribed_velocity[block.high_face] = velocity
    return loads
