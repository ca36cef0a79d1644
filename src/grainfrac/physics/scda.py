"""Soundless cracking demolition agent (SCDA) in the borehole, and drilling it out.

The SCDA is modelled as De Silva et al. (2023) do in 3DEC (paper Sect. 4.1,
Table 5): a deformable elastic plug filling the borehole, bonded to the wall
by SCDA-rock contacts, that expands with an outward normal velocity
``v = f exp(-b t)`` (Eq. 9). Here the velocity drives an isotropic in-plane
eigenstrain of the plug, ``d(eps)/dt = v / R`` (R the borehole radius), which
is exactly an outward normal velocity ``v`` of the unconstrained plug's
boundary; the rock's resistance turns it into the expansive pressure.

Layout: the plug's nodes and elements are appended after the rock's, its
SCDA-rock sub-contacts after the rock's contacts. Drilling out therefore
keeps the leading rock arrays as they are (:func:`drill_out`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from grainfrac.assembly import GrainAssembly
from grainfrac.errors import GeometryError
from grainfrac.geometry.meshing import _hex_lattice
from grainfrac.materials import ScdaRecipe
from grainfrac.physics.model import MechanicalModel, build_mechanical_model, model_from_arrays
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA


@dataclass(frozen=True)
class ScdaFill:
    """An SCDA plug meshed into the borehole of an assembly (local node ids)."""

    node_xy: np.ndarray  # (k, 2)
    element_nodes: np.ndarray  # (e, 3) local ids, counter-clockwise
    wall_rock_node: np.ndarray  # (w,) rock node of each SCDA-rock sub-contact
    wall_scda_node: np.ndarray  # (w,) local SCDA node of each sub-contact
    wall_area: np.ndarray  # (w,)
    wall_normal: np.ndarray  # (w, 2) from rock into the plug
    radius: float
    recipe: ScdaRecipe


def scda_fill(assembly: GrainAssembly, recipe: ScdaRecipe) -> ScdaFill:
    """Mesh the borehole with SCDA elements that share the wall's boundary points.

    Parameters
    ----------
    assembly
        A slab assembly with a borehole.
    recipe
        SCDA properties (paper Table 5).
    """
    mesh = assembly.mesh
    outline = mesh.grains.outline
    if outline.borehole_radius <= 0 or "borehole" not in mesh.boundary_faces:
        raise GeometryError("SCDA needs a specimen with a borehole")
    faces = mesh.boundary_faces["borehole"]
    wall_nodes = np.unique(faces.nodes)
    # One plug node per distinct wall position (two rock grains meet at some).
    pos = np.round(mesh.node_xy[wall_nodes] / 1e-9).astype(np.int64)
    _, first, inverse = np.unique(pos, axis=0, return_index=True, return_inverse=True)
    ring_xy = mesh.node_xy[wall_nodes[first]]
    centre = np.asarray(outline.borehole_center)
    angle = np.arctan2(ring_xy[:, 1] - centre[1], ring_xy[:, 0] - centre[0])
    order = np.argsort(angle)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    ring_xy = ring_xy[order]
    scda_of_wall_node = dict(zip(wall_nodes.tolist(), rank[inverse.ravel()].tolist(),
                                 strict=True))

    # Interior: hexagonal lattice clear of the wall, then Delaunay (the plug is convex).
    zone = mesh.zone_size
    radius = outline.borehole_radius
    lattice = _hex_lattice((centre[0] - radius, centre[1] - radius,
                            centre[0] + radius, centre[1] + radius), zone)
    r = np.hypot(*(lattice - centre).T)
    lattice = lattice[r < radius * math.cos(math.pi / len(ring_xy)) - 0.55 * zone]
    node_xy = np.vstack((ring_xy, lattice))
    tri = Delaunay(node_xy).simplices
    p = node_xy[tri]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    tri = tri[np.abs(area) > 1e-12 * radius**2]

    # SCDA-rock sub-contacts: each rock wall node with the plug node at its position;
    # tributary = half of each wall face it belongs to.
    rock_nodes = np.concatenate((faces.nodes[:, 0], faces.nodes[:, 1]))
    weights = np.concatenate((faces.length, faces.length)) * 0.5
    normals = np.vstack((faces.normal, faces.normal))
    uniq, idx = np.unique(rock_nodes, return_inverse=True)
    length = np.bincount(idx, weights=weights)
    normal = np.column_stack((np.bincount(idx, weights=weights * normals[:, 0]),
                              np.bincount(idx, weights=weights * normals[:, 1])))
    normal /= np.hypot(*normal.T)[:, None]
    return ScdaFill(
        node_xy=node_xy,
        element_nodes=tri.astype(np.int64),
        wall_rock_node=uniq,
        wall_scda_node=np.array([scda_of_wall_node[n] for n in uniq.tolist()]),
        wall_area=length * mesh.thickness,
        wall_normal=normal,
        radius=radius,
        recipe=recipe,
    )


def build_scda_model(assembly: GrainAssembly, fill: ScdaFill, *, safety: float = 0.5
                     ) -> MechanicalModel:
    """The rock model with the plug's nodes, elements and wall contacts appended."""
    rock = build_mechanical_model(assembly, safety=safety)
    mesh = assembly.mesh
    n_rock = mesh.n_nodes
    rec = fill.recipe
    n_el = len(fill.element_nodes)
    c = rec.contact
    w = len(fill.wall_rock_node)
    tangent = np.column_stack((-fill.wall_normal[:, 1], fill.wall_normal[:, 0]))
    return model_from_arrays(
        node_xy=np.vstack((mesh.node_xy, fill.node_xy)),
        element_nodes=np.vstack((mesh.element_nodes, fill.element_nodes + n_rock)),
        youngs_modulus=np.concatenate((assembly.element_youngs_modulus,
                                       np.full(n_el, rec.youngs_modulus_GPa * GPA))),
        poisson_ratio=np.concatenate((assembly.element_poisson_ratio,
                                      np.full(n_el, rec.poisson_ratio))),
        density=np.concatenate((assembly.element_density, np.full(n_el, rec.density_kg_m3))),
        thickness=mesh.thickness,
        contact_nodes=np.vstack((mesh.contact_nodes, np.column_stack(
            (fill.wall_rock_node, fill.wall_scda_node + n_rock)))),
        contact_normal=np.vstack((mesh.contact_normal, fill.wall_normal)),
        contact_tangent=np.vstack((mesh.contact_tangent, tangent)),
        contact_area=np.concatenate((mesh.contact_area, fill.wall_area)),
        normal_stiffness=np.concatenate((rock.normal_stiffness,
                                         np.full(w, c.normal_stiffness_GPa_per_m * GPA_PER_M))),
        shear_stiffness=np.concatenate((rock.shear_stiffness,
                                        np.full(w, c.shear_stiffness_GPa_per_m * GPA_PER_M))),
        friction_angle=np.concatenate((np.arctan(rock.tan_friction),
                                       np.full(w, c.friction_angle_deg * DEG))),
        cohesion=np.concatenate((rock.cohesion, np.full(w, c.cohesion_MPa * MPA))),
        tensile_strength=np.concatenate((rock.tensile_strength,
                                         np.full(w, c.tensile_strength_MPa * MPA))),
        tensile_fracture_energy=np.concatenate((rock.tensile_fracture_energy, np.zeros(w))),
        shear_fracture_energy=np.concatenate((rock.shear_fracture_energy, np.zeros(w))),
        bonded=np.concatenate((rock.initially_bonded, np.ones(w, dtype=bool))),
        safety=safety,
    )


def insert_scda(rock_solver: MechanicsSolver, scda_model: MechanicalModel, fill: ScdaFill
                ) -> MechanicsSolver:
    """A solver on ``scda_model`` that continues ``rock_solver``'s state, plug stress-free.

    The plug is placed into the deformed borehole: its wall nodes take the
    displacement of the rock wall node at their position, interior nodes an
    affine fit of those; the resulting strain is stored as the elements'
    initial strain and the wall misfit as the contacts' opening offset, so the
    plug starts without stress.
    """
    n_rock = rock_solver.model.n_nodes
    c_rock = rock_solver.model.n_contacts
    s = MechanicsSolver(scda_model, damping=rock_solver.damping,
                        velocity_limit=rock_solver.velocity_limit)
    _copy_state(rock_solver, s, n_rock, c_rock)
    loads = rock_solver.loads
    s.loads.external[:n_rock] = loads.external
    s.loads.fixed[:n_rock] = loads.fixed
    s.loads.prescribed_velocity[:n_rock] = loads.prescribed_velocity
    s.loads.platens = loads.platens

    u_wall = np.zeros((len(fill.node_xy), 2))
    count = np.zeros(len(fill.node_xy))
    np.add.at(u_wall, fill.wall_scda_node, rock_solver.u[fill.wall_rock_node])
    np.add.at(count, fill.wall_scda_node, 1.0)
    on_wall = count > 0
    u_wall[on_wall] /= count[on_wall, None]
    # Affine fit u = a + G x of the wall displacements for the interior nodes.
    design = np.column_stack((np.ones(on_wall.sum()), fill.node_xy[on_wall]))
    coef, *_ = np.linalg.lstsq(design, u_wall[on_wall], rcond=None)
    u_plug = np.column_stack((np.ones(len(fill.node_xy)), fill.node_xy)) @ coef
    u_plug[on_wall] = u_wall[on_wall]
    s.u[n_rock:] = u_plug

    m = scda_model
    plug = np.arange(rock_solver.model.element_nodes.shape[0], len(m.element_nodes))
    nodes = m.element_nodes[plug]
    ux, uy = s.u[nodes, 0], s.u[nodes, 1]
    s.initial_strain[plug, 0] = np.sum(m.dndx[plug] * ux, axis=1)
    s.initial_strain[plug, 1] = np.sum(m.dndy[plug] * uy, axis=1)
    s.initial_strain[plug, 2] = np.sum(m.dndy[plug] * ux + m.dndx[plug] * uy, axis=1)
    wall = np.arange(c_rock, m.n_contacts)
    a, b = m.contact_nodes[wall, 0], m.contact_nodes[wall, 1]
    s.opening_offset[wall] = np.sum((s.u[b] - s.u[a]) * m.contact_normal[wall], axis=1)
    return s


def plug_elements(solver: MechanicsSolver, n_rock_elements: int) -> np.ndarray:
    """Element ids of the plug in a solver on the SCDA model."""
    return np.arange(n_rock_elements, len(solver.model.element_nodes))


def set_expansion_velocity(solver: MechanicsSolver, plug: np.ndarray, velocity: float,
                           radius: float) -> None:
    """Drive the plug's boundary outward at ``velocity`` (m/s) via its eigenstrain rate."""
    solver.eigenstrain_rate[:] = 0.0
    solver.eigenstrain_rate[plug] = velocity / radius


def expansive_pressure(solver: MechanicsSolver, n_rock_contacts: int) -> float:
    """Area-weighted mean normal stress (Pa, compression positive) on the SCDA-rock contacts."""
    wall = slice(n_rock_contacts, None)
    area = solver.model.contact_area[wall]
    return float(np.sum(solver.sigma_n[wall] * area) / np.sum(area))


def plug_stored_energy(scda_solver: MechanicsSolver, n_rock_nodes: int,
                       n_rock_contacts: int) -> float:
    """Elastic and kinetic energy (J) held by the plug and its wall contacts."""
    from grainfrac.physics import kernels

    m = scda_solver.model
    plug = np.flatnonzero(m.element_nodes.min(axis=1) >= n_rock_nodes)
    strain = kernels.element_strain_energy(
        scda_solver.u, m.element_nodes[plug], m.dndx[plug], m.dndy[plug], m.element_area[plug],
        m.lam[plug], m.mu[plug], m.thickness, scda_solver.eigenstrain[plug],
        scda_solver.initial_strain[plug])
    wall = slice(n_rock_contacts, None)
    contact = kernels.contact_strain_energy(
        scda_solver.sigma_n[wall], scda_solver.tau[wall], m.normal_stiffness[wall],
        m.shear_stiffness[wall], m.contact_area[wall])
    kinetic = 0.5 * float(np.sum(m.mass[n_rock_nodes:, None] * scda_solver.v[n_rock_nodes:] ** 2))
    return float(strain) + contact + kinetic


def drill_out(scda_solver: MechanicsSolver, rock_model: MechanicalModel) -> MechanicsSolver:
    """Remove the plug: a solver on the rock model that keeps the rock state and its cracks.

    The energy the plug and its wall contacts held leaves with them; it is
    booked as ``energy_removed`` so the energy balance still closes.
    """
    n_rock = rock_model.n_nodes
    c_rock = rock_model.n_contacts
    s = MechanicsSolver(rock_model, damping=scda_solver.damping,
                        velocity_limit=scda_solver.velocity_limit)
    _copy_state(scda_solver, s, n_rock, c_rock)
    s.energies[7] += plug_stored_energy(scda_solver, n_rock, c_rock)
    ld = scda_solver.loads
    s.loads.external[:] = ld.external[:n_rock]
    s.loads.fixed[:] = ld.fixed[:n_rock]
    s.loads.prescribed_velocity[:] = ld.prescribed_velocity[:n_rock]
    s.loads.platens = ld.platens
    return s


def _copy_state(src: MechanicsSolver, dst: MechanicsSolver, n_nodes: int, n_contacts: int
                ) -> None:
    """Copy the leading rock part of a solver's state into another model's solver."""
    dst.u[:n_nodes] = src.u[:n_nodes]
    dst.v[:n_nodes] = src.v[:n_nodes]
    rock_el = min(len(src.stress), len(dst.stress))  # the plug's elements come after
    for name in ("stress", "eigenstrain", "initial_strain"):
        getattr(dst, name)[:rock_el] = getattr(src, name)[:rock_el]
    for name in ("bonded", "status", "sigma_n", "tau", "damage", "plastic_opening", "released",
                 "contact_pressure", "opening_offset"):
        getattr(dst, name)[:n_contacts] = getattr(src, name)[:n_contacts]
    dst.energies[:] = src.energies
    dst.time = src.time
    dst.step_count = src.step_count
    dst.cracks = src.cracks
    dst.allow_failure = src.allow_failure
