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

import numpy as np

from grainfrac.assembly import GrainAssembly

# 95 % of the nodes keep their real mass as far as the grains are concerned; the
# stiffest 5 % (the smallest zones) are scaled. Measured on the default slab: dt
# 1.7x the smallest-zone step. (Tests and README figures were measured with it.)
MASS_SCALING_QUANTILE = 0.05


@dataclass(frozen=True)
class MechanicalModel:
    """Arrays the mechanics kernels need, SI units."""

    node_xy: np.ndarray
    element_nodes: np.ndarray
    dndx: np.ndarray  # (m, 3)
    dndy: np.ndarray  # (m, 3)
    element_area: np.ndarray
    lam: np.ndarray  # plane-strain Lame lambda per element
    mu: np.ndarray
    thickness: float
    contact_nodes: np.ndarray
    contact_normal: np.ndarray
    contact_tangent: np.ndarray
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
    def n_nodes(self) -> int:
        return len(self.node_xy)

    @property
    def n_contacts(self) -> int:
        return len(self.contact_nodes)


def shape_gradients(node_xy: np.ndarray, element_nodes: np.ndarray):
    """Gradients of the linear shape functions and areas of triangles."""
    p = node_xy[element_nodes]
    x, y = p[..., 0], p[..., 1]
    two_a = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    inv = 1.0 / two_a[:, None]
    dndx = np.column_stack((y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1])) * inv
    dndy = np.column_stack((x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0])) * inv
    return dndx, dndy, 0.5 * two_a


def _displacement_to_fail(fracture_energy: np.ndarray, strength: np.ndarray) -> np.ndarray:
    """Inelastic displacement 2 G / strength of linear softening (0 where brittle)."""
    safe = np.where(strength > 0, strength, 1.0)
    return np.where((fracture_energy > 0) & (strength > 0), 2.0 * fracture_energy / safe, 0.0)


def lame_parameters(youngs_modulus: np.ndarray, poisson_ratio: np.ndarray):
    """Lame lambda and mu from E and nu."""
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    return lam, mu


def _element_row_sums(dndx, dndy, area, lam, mu, thickness) -> np.ndarray:
    """Absolute row sums of each element stiffness matrix, per (element, node, dof)."""
    m = len(area)
    b = np.zeros((m, 3, 6))
    b[:, 0, 0::2] = dndx
    b[:, 1, 1::2] = dndy
    b[:, 2, 0::2] = dndy
    b[:, 2, 1::2] = dndx
    d = np.zeros((m, 3, 3))
    d[:, 0, 0] = d[:, 1, 1] = lam + 2 * mu
    d[:, 0, 1] = d[:, 1, 0] = lam
    d[:, 2, 2] = mu
    ke = np.einsum("mia,mij,mjb->mab", b, d, b) * (area * thickness)[:, None, None]
    return np.abs(ke).sum(axis=2).reshape(m, 3, 2)


def nodal_stiffness_bound(
    node_count, element_nodes, dndx, dndy, area, lam, mu, thickness,
    contact_nodes, normal, tangent, contact_area, kn, ks,
) -> np.ndarray:
    """Gershgorin bound of each node's stiffness row (N/m): largest over its two dofs."""
    k = np.zeros((node_count, 2))
    rows = _element_row_sums(dndx, dndy, area, lam, mu, thickness)
    np.add.at(k, element_nodes, rows)
    kmat = (kn * contact_area)[:, None, None] * np.einsum("ci,cj->cij", normal, normal) + (
        ks * contact_area
    )[:, None, None] * np.einsum("ci,cj->cij", tangent, tangent)
    row = 2.0 * np.abs(kmat).sum(axis=2)  # the pair matrix is [[K, -K], [-K, K]]
    np.add.at(k, contact_nodes[:, 0], row)
    np.add.at(k, contact_nodes[:, 1], row)
    return k.max(axis=1)


def build_mechanical_model(
    assembly: GrainAssembly, *, mass_scaling: bool = True, safety: float = 0.5
) -> MechanicalModel:
    """Precompute shape gradients, moduli, masses and the stable time step.

    Parameters
    ----------
    assembly
        The assembled grains with materials.
    mass_scaling
        Scale nodal masses so contact springs do not restrict the step (see module doc).
    safety
        Fraction of the critical time step used.
    """
    mesh = assembly.mesh
    return model_from_arrays(
        node_xy=mesh.node_xy,
        element_nodes=mesh.element_nodes,
        youngs_modulus=assembly.element_youngs_modulus,
        poisson_ratio=assembly.element_poisson_ratio,
        density=assembly.element_density,
        thickness=mesh.thickness,
        contact_nodes=mesh.contact_nodes,
        contact_normal=mesh.contact_normal,
        contact_tangent=mesh.contact_tangent,
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
    *, node_xy, element_nodes, youngs_modulus, poisson_ratio, density, thickness,
    contact_nodes, contact_normal, contact_tangent, contact_area, normal_stiffness,
    shear_stiffness, friction_angle, cohesion, tensile_strength, bonded,
    tensile_fracture_energy=None, shear_fracture_energy=None,
    mass_scaling: bool = True, safety: float = 0.5,
) -> MechanicalModel:
    """Build a :class:`MechanicalModel` from per-element and per-contact arrays (SI).

    Fracture energies (J/m2) left out are zero: brittle contacts.
    """
    if not 0.0 < safety < 1.0:
        raise ValueError(f"safety must be in (0, 1), got {safety}")
    n_nodes = len(node_xy)
    dndx, dndy, area = shape_gradients(node_xy, element_nodes)
    if np.any(area <= 0):
        raise ValueError("elements must be counter-clockwise with positive area")
    lam, mu = lame_parameters(youngs_modulus, poisson_ratio)
    n_contacts = len(contact_nodes)
    g_tensile = (np.zeros(n_contacts) if tensile_fracture_energy is None
                 else np.asarray(tensile_fracture_energy, dtype=np.float64))
    g_shear = (np.zeros(n_contacts) if shear_fracture_energy is None
               else np.asarray(shear_fracture_energy, dtype=np.float64))
    real_mass = np.zeros(n_nodes)
    np.add.at(real_mass, element_nodes,
              np.repeat((density * area * thickness / 3.0)[:, None], 3, axis=1))
    k_nodes = nodal_stiffness_bound(
        n_nodes, element_nodes, dndx, dndy, area, lam, mu, thickness,
        contact_nodes, contact_normal, contact_tangent, contact_area, normal_stiffness,
        shear_stiffness,
    )
    if mass_scaling:
        k_grain = np.zeros((n_nodes, 2))
        np.add.at(k_grain, element_nodes,
                  _element_row_sums(dndx, dndy, area, lam, mu, thickness))
        grain_node_dt = 2.0 / np.sqrt(k_grain.max(axis=1) / real_mass)
        dt = safety * float(np.quantile(grain_node_dt, MASS_SCALING_QUANTILE))
        mass = np.maximum(real_mass, k_nodes * (dt / (2.0 * safety)) ** 2)
    else:
        mass = real_mass
        dt = safety * 2.0 / np.sqrt(np.max(k_nodes / mass))
    return MechanicalModel(
        node_xy=node_xy,
        element_nodes=element_nodes,
        dndx=dndx,
        dndy=dndy,
        element_area=area,
        lam=lam,
        mu=mu,
        thickness=thickness,
        contact_nodes=contact_nodes,
        contact_normal=contact_normal,
        contact_tangent=contact_tangent,
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
        mass_scaled=mass_scaling,
        safety=safety,
    )
