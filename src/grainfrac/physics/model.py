"""Immutable mechanical model arrays built from an assembly.

Mass scaling (documented choice, as Itasca codes do for quasi-static work):
the time step is the grains' own critical step (real density, P-wave speed)
at the node where it is the :data:`MASS_SCALING_QUANTILE` quantile, and any
node whose grain elements or contact springs would demand a smaller step gets
more mass, ``m_i = max(m_real, K_i (dt / 2 s)^2)``, with ``K_i`` the
Gershgorin bound of its stiffness row and ``s`` a safety factor. Contacts are
~1000x stiffer than the grains (paper Table 2), so without it the contact
springs would cut the step by ~50x; the few nodes of the smallest zones
would cut it by another ~1.7x (default slab). Quasi-static results do not
depend on masses; stages that need true dynamics can turn it off.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from grainfrac.geometry.mesh import Mesh
from grainfrac.physics import elements as element_layer
from grainfrac.physics.elements import element_row_sums, lame_parameters
from grainfrac.physics.records import Adjacency, Contacts, Elements, build_adjacency

if TYPE_CHECKING:  # the model needs no tessellation or materials code at run time
    from grainfrac.assembly import GrainAssembly

if TYPE_CHECKING:  # the model needs no tessellation or materials code at run time
    from grainfrac.assembly import GrainAssembly

# 95 % of the nodes keep their real mass as far as the grains are concerned; the
# stiffest 5 % (the smallest zones) are scaled. Measured on the default slab: dt
# 1.7x the smallest-zone step. (Tests and README figures were measured with it.)
MASS_SCALING_QUANTILE = 0.05


@dataclass(frozen=True)
class MechanicalModel:
    """Arrays the mechanics kernels need, SI units, for either dimension ``d``.

    Cells are linear simplices (``cells[m, d+1]``: triangles in plane strain of
    ``thickness``, or tetrahedra); ``cell_measure`` is area x thickness in 2D and
    the volume in 3D. Sub-contacts carry an orthonormal frame ``[c, d, d]``: the
    unit normal from the first node's grain to the second's, then d - 1 tangents.
    """

    x: np.ndarray  # (n, d) reference node positions
    cells: np.ndarray  # (m, d + 1)
    grad: np.ndarray  # (m, d + 1, d) shape-function gradients
    cell_size: np.ndarray  # (m,) area (2D) or volume (3D)
    cell_measure: np.ndarray  # (m,) area x thickness (2D) or volume (3D), m3
    lam: np.ndarray  # Lame lambda per element (plane strain in 2D)
    mu: np.ndarray
    thickness: float  # plane-strain slice (2D); 1.0 in 3D
    contact_nodes: np.ndarray
    contact_frame: np.ndarray  # (c, d, d): normal, tangents
    contact_area: np.ndarray
    normal_stiffness: np.ndarray  # kn (Pa/m)
    shear_stiffness: np.ndarray
    tan_friction: np.ndarray
    cohesion: np.ndarray
    tensile_strength: np.ndarray
    tensile_fracture_energy: np.ndarray  # G_I (J/m2); 0: brittle
    shear_fracture_energy: np.ndarray  # G_II (J/m2); 0: brittle
    opening_to_fail: np.ndarray  # 2 G_I / sigma_T (m): inelastic opening that breaks a bond
    slip_to_fail: np.ndarray  # 2 G_II / c (m)
    initially_bonded: np.ndarray
    mass: np.ndarray  # (n,) nodal mass (kg), possibly scaled
    real_mass: np.ndarray
    nodal_stiffness: np.ndarray  # (n,) Gershgorin bound (N/m)
    dt: float
    mass_scaled: bool
    safety: float

    @property
    def dimension(self) -> int:
        return self.x.shape[1]

    @property
    def n_nodes(self) -> int:
        return len(self.x)

    @property
    def n_elements(self) -> int:
        return len(self.cells)

    @property
    def n_contacts(self) -> int:
        return len(self.contact_nodes)

    @cached_property
    def elements(self) -> Elements:
        """The cells as the kernels' record."""
        return Elements(self.cells, self.grad, self.cell_measure, self.lam, self.mu)

    @cached_property
    def contacts(self) -> Contacts:
        """The sub-contacts as the kernels' record."""
        return Contacts(self.contact_nodes, self.contact_frame, self.contact_area,
                        self.normal_stiffness, self.shear_stiffness, self.tan_friction,
                        self.cohesion, self.tensile_strength, self.opening_to_fail,
                        self.slip_to_fail)

    @cached_property
    def adjacency(self) -> Adjacency:
        """Cells and sub-contacts of each node, for the parallel force gather."""
        return build_adjacency(self.n_nodes, self.cells, self.contact_nodes)

    # 2D names the plane-strain code and its figures use.
    @property
    def node_xy(self) -> np.ndarray:
        return self.x

    @property
    def element_nodes(self) -> np.ndarray:
        return self.cells

    @property
    def element_area(self) -> np.ndarray:
        return self.cell_size

    @property
    def dndx(self) -> np.ndarray:
        return self.grad[:, :, 0]

    @property
    def dndy(self) -> np.ndarray:
        return self.grad[:, :, 1]

    @property
    def contact_normal(self) -> np.ndarray:
        return self.contact_frame[:, 0]

    @property
    def contact_tangent(self) -> np.ndarray:
        """The first tangent (the only one in 2D)."""
        return self.contact_frame[:, 1]


def _displacement_to_fail(fracture_energy: np.ndarray, strength: np.ndarray) -> np.ndarray:
    """Inelastic displacement 2 G / strength of linear softening (0 where brittle)."""
    safe = np.where(strength > 0, strength, 1.0)
    return np.where((fracture_energy > 0) & (strength > 0), 2.0 * fracture_energy / safe, 0.0)


def nodal_stiffness_bound(grain_rows: np.ndarray, contact_nodes, frame, contact_area, kn,
                          ks) -> np.ndarray:
    """Gershgorin bound of each node's stiffness row (N/m): largest over its dofs.

    ``grain_rows`` (nodes, d): the grains' part, :func:`element_row_sums` added onto the
    nodes; the contacts' rows are added to a copy of it."""
    d = grain_rows.shape[1]
    k = grain_rows.copy()
    normal = frame[:, 0]
    kmat = (kn * contact_area)[:, None, None] * np.einsum("ci,cj->cij", normal, normal)
    for t in range(1, d):
        tangent = frame[:, t]
        kmat = kmat + (ks * contact_area)[:, None, None] * np.einsum("ci,cj->cij", tangent,
                                                                     tangent)
    row = 2.0 * np.abs(kmat).sum(axis=2)  # the pair matrix is [[K, -K], [-K, K]]
    np.add.at(k, contact_nodes[:, 0], row)
    np.add.at(k, contact_nodes[:, 1], row)
    return k.max(axis=1)


def partly_scaled_step(real_mass: np.ndarray, stiffness: np.ndarray, safety: float,
                       real_dt: float, scaled_dt: float, fraction: float) -> float:
    """The step (s) at which mass scaling adds ``fraction`` of the mass it adds at
    ``scaled_dt``: added(dt) = sum max(0, K_i (dt / 2 s)^2 - m_i) grows from 0 at
    the real-mass step ``real_dt`` to its full value at ``scaled_dt`` (bisection)."""

    def added(dt: float) -> float:
        return float(np.sum(np.maximum(stiffness * (dt / (2.0 * safety)) ** 2 - real_mass,
                                       0.0)))

    target = fraction * added(scaled_dt)
    low, high = real_dt, scaled_dt
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if added(mid) < target else (low, mid)
    return high


def build_mechanical_model(
    assembly: GrainAssembly, *, mass_scaling: bool | float = True, safety: float = 0.5
) -> MechanicalModel:
    """Precompute shape gradients, moduli, masses and the stable time step.

    Parameters
    ----------
    assembly
        The assembled grains with materials.
    mass_scaling
        Scale nodal masses so contact springs do not restrict the step (see module doc):
        True (or 1.0), False (or 0.0: real masses), or the fraction of the added mass
        to keep (:func:`partly_scaled_step`).
    safety
        Fraction of the critical time step used.
    """
    mesh: Mesh = assembly.mesh.record()
    return model_from_arrays(
        x=mesh.x,
        cells=mesh.cells,
        youngs_modulus=assembly.element_youngs_modulus,
        poisson_ratio=assembly.element_poisson_ratio,
        density=assembly.element_density,
        thickness=mesh.thickness,
        contact_nodes=mesh.contact_nodes,
        contact_frame=mesh.contact_frame,
        contact_area=mesh.contact_area,
        normal_stiffness=assembly.contact_view("normal_stiffness"),
        shear_stiffness=assembly.contact_view("shear_stiffness"),
        friction_angle=assembly.contact_view("friction_angle"),
        cohesion=assembly.contact_view("cohesion"),
        tensile_strength=assembly.contact_view("tensile_strength"),
        tensile_fracture_energy=assembly.contact_view("tensile_fracture_energy"),
        shear_fracture_energy=assembly.contact_view("shear_fracture_energy"),
        bonded=~assembly.contact_view("fissure"),
        mass_scaling=mass_scaling,
        safety=safety,
    )


def model_from_arrays(
    *, x, cells, youngs_modulus, poisson_ratio, density, contact_nodes, contact_frame,
    contact_area, normal_stiffness, shear_stiffness, friction_angle, cohesion,
    tensile_strength, bonded, thickness: float = 1.0, tensile_fracture_energy=None,
    shear_fracture_energy=None, mass_scaling: bool | float = True, safety: float = 0.5,
) -> MechanicalModel:
    """Build a :class:`MechanicalModel` from per-element and per-contact arrays (SI).

    The dimension is that of ``x`` (2: triangles in plane strain of ``thickness``,
    3: tetrahedra). Fracture energies (J/m2) left out are zero: brittle contacts.
    """
    if not 0.0 < safety < 1.0:
        raise ValueError(f"safety must be in (0, 1), got {safety}")
    x = np.asarray(x, dtype=np.float64)
    n_nodes, dimension = x.shape
    element = element_layer.element_for_dimension(dimension)
    if cells.shape[1] != element.NODES_PER_CELL:
        raise ValueError(f"{dimension}D cells need {element.NODES_PER_CELL} nodes, "
                         f"got {cells.shape[1]}")
    grad, size = element.gradients(x, cells)
    if np.any(size <= 0):
        raise ValueError("elements must be positively oriented (counter-clockwise "
                         "triangles, right-handed tetrahedra) with positive measure")
    measure = element.measure(size, thickness)
    lam, mu = lame_parameters(youngs_modulus, poisson_ratio)
    n_contacts = len(contact_nodes)
    g_tensile = (np.zeros(n_contacts) if tensile_fracture_energy is None
                 else np.asarray(tensile_fracture_energy, dtype=np.float64))
    g_shear = (np.zeros(n_contacts) if shear_fracture_energy is None
               else np.asarray(shear_fracture_energy, dtype=np.float64))
    real_mass = np.zeros(n_nodes)
    np.add.at(real_mass, cells, element.lumped_mass(density, size, thickness))
    # Summed once for both bounds: a pass over every element stiffness (4.9 s on the cube).
    k_grain = np.zeros((n_nodes, dimension))
    np.add.at(k_grain, cells, element_row_sums(grad, measure, lam, mu))
    k_nodes = nodal_stiffness_bound(k_grain, contact_nodes, contact_frame, contact_area,
                                    normal_stiffness, shear_stiffness)
    fraction = float(mass_scaling)
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"mass_scaling must be a bool or a fraction in [0, 1], got {mass_scaling}")
    real_dt = safety * 2.0 / np.sqrt(np.max(k_nodes / real_mass))
    if fraction > 0.0:
        grain_node_dt = 2.0 / np.sqrt(k_grain.max(axis=1) / real_mass)
        dt = safety * float(np.quantile(grain_node_dt, MASS_SCALING_QUANTILE))
        if fraction < 1.0:
            dt = partly_scaled_step(real_mass, k_nodes, safety, real_dt, dt, fraction)
        mass = np.maximum(real_mass, k_nodes * (dt / (2.0 * safety)) ** 2)
    else:
        mass = real_mass
        dt = real_dt
    return MechanicalModel(
        x=x,
        cells=np.ascontiguousarray(cells, dtype=np.int64),
        grad=grad,
        cell_size=size,
        cell_measure=measure,
        lam=lam,
        mu=mu,
        thickness=float(thickness),
        contact_nodes=np.ascontiguousarray(contact_nodes, dtype=np.int64).reshape(-1, 2),
        contact_frame=np.ascontiguousarray(contact_frame, dtype=np.float64),
        contact_area=contact_area,
        normal_stiffness=normal_stiffness,
        shear_stiffness=shear_stiffness,
        tan_friction=np.tan(friction_angle),
        cohesion=cohesion,
        tensile_strength=tensile_strength,
        tensile_fracture_energy=g_tensile,
        shear_fracture_energy=g_shear,
        opening_to_fail=_displacement_to_fail(g_tensile, tensile_strength),
        slip_to_fail=_displacement_to_fail(g_shear, cohesion),
        initially_bonded=np.asarray(bonded, dtype=bool),
        mass=mass,
        real_mass=real_mass,
        nodal_stiffness=k_nodes,
        dt=float(dt),
        mass_scaled=fraction > 0.0,
        safety=safety,
    )
