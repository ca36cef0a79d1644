"""Soundless cracking demolition agent (SCDA) in the borehole, and drilling it out.

The SCDA is modelled as De Silva et al. (2023) do in 3DEC (paper Sect. 4.1,
Table 5): expansive elements filling the borehole, each a block of its own,
held to each other and to the wall by contacts with the Table 5 SCDA
properties, expanding with an outward normal velocity ``v = f exp(-b t)``
(Eq. 9). Here the velocity drives an isotropic in-plane eigenstrain of every
element, ``d(eps)/dt = v / R`` (R the borehole radius), which is exactly an
outward normal velocity ``v`` of the unconstrained plug's boundary; the rock's
resistance turns it into the expansive pressure.

Decisions: the plug is made of blocks, as the paper's expansive elements
are, so the Table 5 contacts are the SCDA's own and it can part. The
SCDA-rock interface is the recipe's ``wall_contact``, smooth and unbonded
by default: a bonded or frictional wall ties every radial crack mouth to
the stiff plug and holds it shut. Measured on the default slab, seed 0,
radial fractures in Cases 1-4: continuous plug with a bonded wall 3/2/1/2,
blocks with a bonded wall 4/2/1/2, blocks with a 30 deg frictional wall
4/2/1/2, blocks with the smooth wall 4/3/3/4.

Layout: the plug's nodes and elements are appended after the rock's; its
contacts after the rock's contacts, the SCDA-rock wall contacts first, then
the contacts between SCDA blocks. Drilling out therefore keeps the leading
rock arrays as they are (:func:`drill_out`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from grainfrac.assembly import GrainAssembly
from grainfrac.errors import GeometryError
from grainfrac.geometry.mesh import contact_frame
from grainfrac.geometry.meshing import hex_lattice
from grainfrac.materials import ScdaRecipe
from grainfrac.physics.model import MechanicalModel, build_mechanical_model, model_from_arrays
from grainfrac.physics.records import Elements, ElementState
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA


@dataclass(frozen=True)
class ScdaFill:
    """An SCDA plug of triangular blocks meshed into the borehole (local node ids).

    Every block has its own three nodes. Contacts pair a node of one side with
    the coincident node of the other: ``wall_*`` the rock wall with the plug,
    ``joint_*`` two neighbouring blocks; each with its tributary area and the
    unit normal from the first node's side to the second's.
    """

    node_xy: np.ndarray  # (3e, 2)
    element_nodes: np.ndarray  # (e, 3) local ids, counter-clockwise
    wall_rock_node: np.ndarray  # (w,) rock node of each SCDA-rock sub-contact
    wall_scda_node: np.ndarray  # (w,) local SCDA node of each sub-contact
    wall_area: np.ndarray  # (w,)
    wall_normal: np.ndarray  # (w, 2) from rock into the plug
    joint_nodes: np.ndarray  # (j, 2) local SCDA nodes of each block-block sub-contact
    joint_area: np.ndarray  # (j,)
    joint_normal: np.ndarray  # (j, 2) from the first block to the second
    radius: float
    recipe: ScdaRecipe

    @property
    def n_wall(self) -> int:
        return len(self.wall_rock_node)


def scda_fill(assembly: GrainAssembly, recipe: ScdaRecipe) -> ScdaFill:
    """Mesh the borehole with SCDA blocks whose outer edges are the wall's faces.

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
    # One ring point per distinct wall position (two rock grains meet at some).
    key = np.round(mesh.node_xy[faces.nodes.ravel()] / 1e-9).astype(np.int64)
    ring_key, ring_of_face_node = np.unique(key, axis=0, return_inverse=True)
    ring_xy = ring_key * 1e-9
    ring_of_face_node = ring_of_face_node.reshape(faces.nodes.shape)

    # Interior: hexagonal lattice clear of the wall, then Delaunay (the plug is convex).
    zone = mesh.zone_size
    radius = outline.borehole_radius
    centre = np.asarray(outline.borehole_center)
    lattice = hex_lattice((centre[0] - radius, centre[1] - radius,
                            centre[0] + radius, centre[1] + radius), zone)
    r = np.hypot(*(lattice - centre).T)
    lattice = lattice[r < radius * math.cos(math.pi / len(ring_xy)) - 0.55 * zone]
    points = np.vstack((ring_xy, lattice))
    tri = Delaunay(points).simplices
    p = points[tri]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                  - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    tri = tri[np.abs(area) > 1e-12 * radius**2]

    # Blocks: node 3 t + k is corner k of triangle t. Edges by their two points.
    edges: dict[tuple[int, int], list[tuple[int, int, int]]] = {}
    for t, corners in enumerate(tri.tolist()):
        for k in range(3):
            a, b = corners[k], corners[(k + 1) % 3]
            edges.setdefault((min(a, b), max(a, b)), []).append(
                (t, 3 * t + k, 3 * t + (k + 1) % 3) if a < b
                else (t, 3 * t + (k + 1) % 3, 3 * t + k))
    thickness = mesh.thickness

    # SCDA-rock sub-contacts: each wall face's two rock nodes with the coincident
    # corners of the block on that face; tributary = half the face.
    w_rock, w_scda, w_area, w_normal = [], [], [], []
    for f in range(len(faces.length)):
        i, j = ring_of_face_node[f]
        owners = edges.get((min(i, j), max(i, j)), [])
        if len(owners) != 1:
            continue  # a sliver block was dropped here: the wall face stays free
        _, low, high = owners[0]
        for rock_node, ring in zip(faces.nodes[f], (i, j), strict=True):
            w_rock.append(rock_node)
            w_scda.append(low if ring == min(i, j) else high)
            w_area.append(0.5 * faces.length[f] * thickness)
            w_normal.append(faces.normal[f])

    # Block-block sub-contacts: both ends of every interior edge.
    centroid = points[tri].mean(axis=1)
    j_nodes, j_area, j_normal = [], [], []
    for (a, b), owners in edges.items():
        if len(owners) != 2:
            continue
        (t1, a1, b1), (t2, a2, b2) = owners
        d = points[b] - points[a]
        length = float(np.hypot(*d))
        n = np.array([d[1], -d[0]]) / length
        if np.dot(centroid[t2] - centroid[t1], n) < 0:
            n = -n
        for first, second in ((a1, a2), (b1, b2)):
            j_nodes.append((first, second))
            j_area.append(0.5 * length * thickness)
            j_normal.append(n)
    return ScdaFill(
        node_xy=points[tri].reshape(-1, 2),
        element_nodes=np.arange(3 * len(tri), dtype=np.int64).reshape(-1, 3),
        wall_rock_node=np.asarray(w_rock, dtype=np.int64),
        wall_scda_node=np.asarray(w_scda, dtype=np.int64),
        wall_area=np.asarray(w_area),
        wall_normal=np.asarray(w_normal).reshape(-1, 2),
        joint_nodes=np.asarray(j_nodes, dtype=np.int64).reshape(-1, 2),
        joint_area=np.asarray(j_area),
        joint_normal=np.asarray(j_normal).reshape(-1, 2),
        radius=radius,
        recipe=recipe,
    )


def build_scda_model(assembly: GrainAssembly, fill: ScdaFill, *, safety: float = 0.5,
                     mass_scaling: bool | float = True) -> MechanicalModel:
    """The rock model with the plug's blocks, wall contacts and block contacts appended."""
    rock = build_mechanical_model(assembly, safety=safety, mass_scaling=mass_scaling)
    mesh = assembly.mesh
    n_rock = mesh.n_nodes
    rec = fill.recipe
    n_el = len(fill.element_nodes)
    normal = np.vstack((fill.wall_normal, fill.joint_normal))
    # SCDA contacts: the wall first, then those between blocks.
    props = [(rec.wall_contact_properties(), fill.n_wall), (rec.contact, len(fill.joint_area))]

    def column(rock_values: np.ndarray, name: str, unit: float) -> np.ndarray:
        return np.concatenate([rock_values] + [np.full(n, getattr(c, name) * unit)
                                               for c, n in props])

    return model_from_arrays(
        x=np.vstack((mesh.node_xy, fill.node_xy)),
        cells=np.vstack((mesh.element_nodes, fill.element_nodes + n_rock)),
        youngs_modulus=np.concatenate((assembly.element_youngs_modulus,
                                       np.full(n_el, rec.youngs_modulus_GPa * GPA))),
        poisson_ratio=np.concatenate((assembly.element_poisson_ratio,
                                      np.full(n_el, rec.poisson_ratio))),
        density=np.concatenate((assembly.element_density, np.full(n_el, rec.density_kg_m3))),
        thickness=mesh.thickness,
        contact_nodes=np.vstack((mesh.contact_nodes,
                                 np.column_stack((fill.wall_rock_node,
                                                  fill.wall_scda_node + n_rock)),
                                 fill.joint_nodes + n_rock)),
        contact_frame=contact_frame(np.vstack((mesh.contact_normal, normal))),
        contact_area=np.concatenate((mesh.contact_area, fill.wall_area, fill.joint_area)),
        normal_stiffness=column(rock.normal_stiffness, "normal_stiffness_GPa_per_m", GPA_PER_M),
        shear_stiffness=column(rock.shear_stiffness, "shear_stiffness_GPa_per_m", GPA_PER_M),
        friction_angle=column(np.arctan(rock.tan_friction), "friction_angle_deg", DEG),
        cohesion=column(rock.cohesion, "cohesion_MPa", MPA),
        tensile_strength=column(rock.tensile_strength, "tensile_strength_MPa", MPA),
        tensile_fracture_energy=column(rock.tensile_fracture_energy,
                                       "tensile_fracture_energy_J_per_m2", 1.0),
        shear_fracture_energy=column(rock.shear_fracture_energy,
                                     "shear_fracture_energy_J_per_m2", 1.0),
        bonded=np.concatenate((rock.initially_bonded,
                               np.ones(len(normal), dtype=bool))),
        safety=safety,
        mass_scaling=mass_scaling,
    )


def insert_scda(rock_solver: MechanicsSolver, scda_model: MechanicalModel, fill: ScdaFill
                ) -> MechanicsSolver:
    """A solver on ``scda_model`` that continues ``rock_solver``'s state, plug stress-free.

    The plug is placed into the deformed borehole: every block node takes the
    affine fit ``u = a + G x`` of the rock wall's displacements (so coincident
    block corners move together), the resulting strain is stored as the
    elements' initial strain and the wall misfit as the contacts' opening
    offset, so the plug starts without stress.
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

    wall_xy = rock_solver.model.node_xy[fill.wall_rock_node]
    design = np.column_stack((np.ones(len(wall_xy)), wall_xy))
    coef, *_ = np.linalg.lstsq(design, rock_solver.u[fill.wall_rock_node], rcond=None)
    s.u[n_rock:] = np.column_stack((np.ones(len(fill.node_xy)), fill.node_xy)) @ coef

    m = scda_model
    plug = np.arange(rock_solver.model.element_nodes.shape[0], len(m.element_nodes))
    nodes = m.element_nodes[plug]
    ux, uy = s.u[nodes, 0], s.u[nodes, 1]
    s.initial_strain[plug, 0] = np.sum(m.dndx[plug] * ux, axis=1)
    s.initial_strain[plug, 1] = np.sum(m.dndy[plug] * uy, axis=1)
    s.initial_strain[plug, 2] = np.sum(m.dndy[plug] * ux + m.dndx[plug] * uy, axis=1)
    scda_contacts = np.arange(c_rock, m.n_contacts)
    a, b = m.contact_nodes[scda_contacts, 0], m.contact_nodes[scda_contacts, 1]
    s.opening_offset[scda_contacts] = np.sum((s.u[b] - s.u[a]) * m.contact_normal[scda_contacts],
                                             axis=1)
    return s


def plug_elements(solver: MechanicsSolver, n_rock_elements: int) -> np.ndarray:
    """Element ids of the plug in a solver on the SCDA model."""
    return np.arange(n_rock_elements, len(solver.model.element_nodes))


def set_expansion_velocity(solver: MechanicsSolver, plug: np.ndarray, velocity: float,
                           radius: float) -> None:
    """Drive the plug's boundary outward at ``velocity`` (m/s) via its eigenstrain rate."""
    solver.eigenstrain_rate[:] = 0.0
    solver.eigenstrain_rate[plug] = velocity / radius


def expansive_pressure(solver: MechanicsSolver, n_rock_contacts: int, n_wall: int) -> float:
    """Area-weighted mean normal stress (Pa, compression positive) on the SCDA-rock contacts
    (the ``n_wall`` contacts after the rock's)."""
    wall = slice(n_rock_contacts, n_rock_contacts + n_wall)
    area = solver.model.contact_area[wall]
    return float(np.sum(solver.sigma_n[wall] * area) / np.sum(area))


def plug_stored_energy(scda_solver: MechanicsSolver, n_rock_nodes: int,
                       n_rock_contacts: int) -> float:
    """Elastic and kinetic energy (J) held by the plug and its contacts."""
    from grainfrac.physics import kernels

    m = scda_solver.model
    plug = np.flatnonzero(m.cells.min(axis=1) >= n_rock_nodes)
    strain = kernels.element_strain_energy(
        scda_solver.u, Elements(*(np.ascontiguousarray(a[plug]) for a in m.elements)),
        ElementState(*(np.ascontiguousarray(a[plug]) for a in scda_solver.element_state())))
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
    s.energies["energy_removed"] += plug_stored_energy(scda_solver, n_rock, c_rock)
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
