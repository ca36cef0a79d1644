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

3D (:func:`scda_fill3d`): the plug fills the faceted borehole prism with
tetrahedral blocks, each on its own four nodes, exactly as the 2D blocks are
triangles on their own three. The tetrahedron element applies the same scalar
eigenstrain to xx, yy and zz (:mod:`grainfrac.physics.elements.tetrahedron`),
so the plug swells isotropically in space: its top and bottom faces are free
and move out along the axis, and with ``R`` the facets' apothem every flat
lateral face moves out at exactly ``v``. The default smooth wall takes no
shear from the axial swelling.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from grainfrac.assembly import GrainAssembly
from grainfrac.errors import GeometryError
from grainfrac.geometry.mesh import contact_frame, tet_volumes
from grainfrac.geometry.meshing import hex_lattice
from grainfrac.geometry.meshing3d import tet_quality
from grainfrac.geometry.solids3d import BOREHOLE, Solid
from grainfrac.materials import ScdaRecipe
from grainfrac.physics.model import MechanicalModel, build_mechanical_model, model_from_arrays
from grainfrac.physics.records import Elements, ElementState
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import DEG, GPA, GPA_PER_M, MPA


@dataclass(frozen=True)
class ScdaFill:
    """An SCDA plug of simplex blocks meshed into the borehole (local node ids).

    Every block has its own ``d + 1`` nodes (triangles in 2D, tetrahedra in 3D).
    Contacts pair a node of one side with the coincident node of the other:
    ``wall_*`` the rock wall with the plug, ``joint_*`` two neighbouring blocks;
    each with its tributary area and the unit normal from the first node's side
    to the second's. ``radius`` is the ``R`` of the eigenstrain rate ``v / R``
    (:func:`set_expansion_velocity`): the nominal borehole radius in 2D, the
    distance from the axis to the wall facets in 3D (so the flat faces move out
    at exactly ``v``).
    """

    node_xy: np.ndarray  # (k, d) node coordinates, (d + 1) e of them
    element_nodes: np.ndarray  # (e, d + 1) local ids, counter-clockwise / right-handed
    wall_rock_node: np.ndarray  # (w,) rock node of each SCDA-rock sub-contact
    wall_scda_node: np.ndarray  # (w,) local SCDA node of each sub-contact
    wall_area: np.ndarray  # (w,)
    wall_normal: np.ndarray  # (w, d) from rock into the plug
    joint_nodes: np.ndarray  # (j, 2) local SCDA nodes of each block-block sub-contact
    joint_area: np.ndarray  # (j,)
    joint_normal: np.ndarray  # (j, d) from the first block to the second
    radius: float
    recipe: ScdaRecipe

    @property
    def n_wall(self) -> int:
        return len(self.wall_rock_node)

    @property
    def dimension(self) -> int:
        return self.node_xy.shape[1]


def scda_fill(assembly: GrainAssembly, recipe: ScdaRecipe) -> ScdaFill:
    """Mesh the borehole with SCDA blocks: triangles in 2D, tetrahedra in 3D
    (:func:`scda_fill3d`).

    Parameters
    ----------
    assembly
        A slab assembly with a borehole.
    recipe
        SCDA properties (paper Table 5).
    """
    if assembly.mesh.dimension == 3:
        return scda_fill3d(assembly, recipe)
    return _scda_fill2d(assembly, recipe)


def _scda_fill2d(assembly: GrainAssembly, recipe: ScdaRecipe) -> ScdaFill:
    """The 2D plug: triangular blocks whose outer edges are the wall's faces."""
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


# The 3D plug's interior points and its sliver rule.
_PLUG_CLEARANCE = 0.55  # x zone: lattice points kept this far inside the wall facets (as 2D)
_PLUG_JITTER = 0.05  # x zone: lattice displacement, so Qhull meets no cospherical ties
_PLUG_SEED = 0  # fixed: a mesh always gets the same plug (a resumed run rebuilds it)
# x zone^3: Delaunay tetrahedra below this volume are flat, not blocks. Qhull's
# triangulated output leaves some of four points on one wall facet (measured on
# 30 x 30 x 8 mm slabs: 12-16 of volume 0 on seed 0, none on seeds 1-3); the
# tetrahedra below them cover the facet, so nothing is lost (scda_fill3d checks
# that every surface triangle lies on the wall or an end face). The flattest
# tetrahedra kept have 0.02-0.04 zone^3.
_FLAT_VOLUME = 1e-12
_SLIVER_QUALITY = 0.12  # normalised volume below which a tetrahedron is poor (rock mesher's)
_CLEANUP_PASSES = 5
_REDRAW_JITTER = 0.2  # x zone: how far the lattice points of a poor tetrahedron are moved
# Tetrahedron faces, the face opposite corner k first: (1, 2, 3) is opposite 0, ...
_TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def scda_fill3d(assembly: GrainAssembly, recipe: ScdaRecipe) -> ScdaFill:
    """Fill the faceted borehole prism of a 3D slab with tetrahedral SCDA blocks.

    Points: the distinct points of the borehole wall's surface triangles (so
    the plug's wall corners coincide with the rock's wall nodes) and a lattice
    clear of the wall: hexagonal layers of the zone size in (x, y), stacked
    like close-packed spheres along z from the bottom face to the top face
    (these two layers lie in the faces, so the free ends are meshed finely
    too), displaced by up to 5 % of a zone. The prism is convex, so Qhull's
    Delaunay tetrahedra of the points fill it; its flat ones
    (:data:`_FLAT_VOLUME`) are dropped. Every tetrahedron is a block on its own
    four nodes: node ``4 t + k`` is corner ``k`` of block ``t``.

    Contacts: every triangle two blocks share gives three block-block
    sub-contacts (its corners' node pairs, a third of its area each, the
    normal from the first block into the second). Every plug surface triangle
    on the wall gives its corners a third of its area each, paired with the
    rock node(s) at that point: where several grains meet at the point (one
    rock node per grain) the third is split among them in proportion to their
    own tributary areas on the wall, so each rock node is pushed as much as
    the wall it stands for; the normal is the facet's, from the rock into the
    plug. The top and bottom faces are free.

    Parameters
    ----------
    assembly
        A 3D slab assembly with a borehole.
    recipe
        SCDA properties (paper Table 5).
    """
    mesh = assembly.mesh
    solid = mesh.grains.solid
    wall_tri = mesh.surface_triangles.get(BOREHOLE)
    if not solid.has_borehole or wall_tri is None or len(wall_tri) == 0:
        raise GeometryError("SCDA needs a specimen with a borehole")
    h = mesh.wall_zone_size  # the plug fills the borehole, meshed as its wall is
    apothem = solid.apothem
    facet_normal = solid.facet_normals()
    z0, z1 = float(solid.lo[2]), float(solid.hi[2])

    # Rock nodes on the wall, their tributary areas, and the distinct wall points.
    corners = mesh.node_x[wall_tri]
    tri_area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                             corners[:, 2] - corners[:, 0]), axis=1)
    tributary = np.bincount(wall_tri.ravel(), weights=np.repeat(tri_area / 3.0, 3),
                            minlength=mesh.n_nodes)
    rock_nodes = np.unique(wall_tri)
    wall_points, wall_of_rock = np.unique(mesh.node_point[rock_nodes], return_inverse=True)
    by_point = np.argsort(wall_of_rock, kind="stable")
    point_ptr = np.concatenate(([0], np.cumsum(np.bincount(wall_of_rock,
                                                           minlength=len(wall_points)))))
    rock_at_point = rock_nodes[by_point]  # the rock nodes at wall point i: [ptr[i], ptr[i+1])

    points, tets = _tetrahedralise_plug(mesh.points[wall_points], solid, h)

    # Every tetrahedron face, its points sorted so a shared face has one key; the
    # block node at each point travels with it.
    n_tet = len(tets)
    face_points = tets[:, _TET_FACES].reshape(-1, 3)
    face_nodes = (4 * np.arange(n_tet)[:, None, None] + _TET_FACES[None]).reshape(-1, 3)
    order = np.argsort(face_points, axis=1)
    face_points = np.take_along_axis(face_points, order, axis=1)
    face_nodes = np.take_along_axis(face_nodes, order, axis=1)
    face_opposite = tets.ravel()  # point opposite face 4 t + k is corner k
    _, first, inverse, count = np.unique(face_points, axis=0, return_index=True,
                                         return_inverse=True, return_counts=True)
    if np.any(count > 2):
        raise GeometryError("SCDA plug: a triangle is shared by more than two tetrahedra")
    x = points[face_points]
    cross = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / (2.0 * area[:, None])
    # Out of the face's own tetrahedron: away from its opposite point.
    away = np.einsum("ij,ij->i", normal, points[face_opposite] - x[:, 0]) > 0
    normal[away] = -normal[away]

    # Block-block sub-contacts: both sides of every shared face, first occurrence first.
    inverse = inverse.ravel()
    shared = count[inverse] == 2
    second = shared & (np.arange(len(inverse)) != first[inverse])
    f2 = np.flatnonzero(second)
    f1 = first[inverse[f2]]
    joint_nodes = np.stack((face_nodes[f1], face_nodes[f2]), axis=2).reshape(-1, 2)
    joint_area = np.repeat(area[f1] / 3.0, 3)
    joint_normal = np.repeat(normal[f1], 3, axis=0)  # out of the first, into the second

    # Surface faces: on the wall, or on the free top and bottom.
    surface = np.flatnonzero(count[inverse] == 1)
    ends = np.abs(normal[surface, 2]) > 1.0 - 1e-9
    on_wall = surface[~ends]
    facet = np.argmax(normal[on_wall] @ facet_normal.T, axis=1)
    distance = np.einsum("ij,ij->i", x[on_wall, 0], facet_normal[facet])
    if (np.any(np.einsum("ij,ij->i", normal[on_wall], facet_normal[facet]) < 1.0 - 1e-9)
            or np.any(np.abs(distance - apothem) > 1e-9 * apothem)
            or np.any(face_points[on_wall] >= len(wall_points))):
        raise GeometryError("SCDA plug: a surface triangle lies neither on the borehole wall "
                            "nor on the top or bottom face")
    end_z = x[surface[ends]][..., 2]
    if not np.all((np.abs(end_z - z0) < 1e-9 * h) | (np.abs(end_z - z1) < 1e-9 * h)):
        raise GeometryError("SCDA plug: a surface triangle lies neither on the borehole wall "
                            "nor on the top or bottom face")

    # SCDA-rock sub-contacts: each wall corner's third, split over the rock nodes there.
    w_rock, w_scda, w_facet, w_area = [], [], [], []
    for f, k in zip(on_wall.tolist(), facet.tolist(), strict=True):
        for point, node in zip(face_points[f].tolist(), face_nodes[f].tolist(), strict=True):
            rock = rock_at_point[point_ptr[point]:point_ptr[point + 1]]
            share = tributary[rock] / tributary[rock].sum()
            w_rock.extend(rock.tolist())
            w_scda.extend([node] * len(rock))
            w_facet.extend([k] * len(rock))
            w_area.extend((area[f] / 3.0 * share).tolist())
    # One sub-contact per (rock node, plug node, facet): a block with two faces on one
    # facet meets the rock there once.
    key, pair_of = np.unique(np.column_stack((w_rock, w_scda, w_facet)), axis=0,
                             return_inverse=True)
    wall_area = np.bincount(pair_of.ravel(), weights=np.asarray(w_area), minlength=len(key))
    return ScdaFill(
        node_xy=points[tets].reshape(-1, 3),
        element_nodes=np.arange(4 * n_tet, dtype=np.int64).reshape(-1, 4),
        wall_rock_node=key[:, 0].astype(np.int64),
        wall_scda_node=key[:, 1].astype(np.int64),
        wall_area=wall_area,
        wall_normal=-facet_normal[key[:, 2]],
        joint_nodes=joint_nodes.astype(np.int64),
        joint_area=joint_area,
        joint_normal=joint_normal,
        radius=apothem,
        recipe=recipe,
    )


def _tetrahedralise_plug(wall: np.ndarray, solid: Solid, h: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Delaunay tetrahedra (right-handed) of the wall points and the plug's lattice.

    Flat tetrahedra are dropped. A lattice row lined up with a vertical edge of
    the wall makes slivers (two edge points and two lattice points in one
    radial plane); the lattice points of poor tetrahedra (normalised volume
    below :data:`_SLIVER_QUALITY`, the rock mesher's rule) are displaced afresh,
    by up to :data:`_REDRAW_JITTER` zones, and the plug is redone, up to
    :data:`_CLEANUP_PASSES` times. Moving rather than deleting them (as the
    rock's mesher does) keeps the plug's resolution: deleting them took out
    40 % of the blocks of one 30 x 30 x 8 mm slab and left a sliver anyway.
    """
    rng = np.random.default_rng(_PLUG_SEED)
    base, in_face = _plug_lattice(solid, h)
    lattice = _displace(base, in_face, _PLUG_JITTER * h, rng, solid, h)
    nb = len(wall)
    for _ in range(_CLEANUP_PASSES + 1):
        points = np.vstack((wall, lattice))
        delaunay = Delaunay(points)
        if len(delaunay.coplanar):
            raise GeometryError(f"SCDA plug: Qhull left {len(delaunay.coplanar)} points out "
                                "of its tetrahedra (points too close together)")
        tets = delaunay.simplices
        volume = tet_volumes(points[tets])
        keep = np.abs(volume) > _FLAT_VOLUME * h**3
        tets, volume = tets[keep], volume[keep]
        tets[volume < 0] = tets[volume < 0][:, [0, 2, 1, 3]]
        poor = tet_quality(points[tets]) < _SLIVER_QUALITY
        culprits = np.unique(tets[poor][tets[poor] >= nb]) - nb
        if len(culprits) == 0:
            break
        lattice[culprits] = _displace(base[culprits], in_face[culprits], _REDRAW_JITTER * h,
                                      rng, solid, h)
    return points, tets


def _plug_lattice(solid: Solid, h: float) -> tuple[np.ndarray, np.ndarray]:
    """The plug's interior lattice before displacement, and which points lie in the end
    faces: close-packed hexagonal layers of spacing ``h`` from the bottom face to the
    top face, at least :data:`_PLUG_CLEARANCE` zones inside every wall facet."""
    z0, z1 = float(solid.lo[2]), float(solid.hi[2])
    apothem = solid.apothem
    normal = solid.facet_normals()[:, :2]
    layers = max(1, round((z1 - z0) / (h * math.sqrt(2.0 / 3.0))))
    plane = hex_lattice((-apothem, -apothem, apothem, apothem), h)
    out, end = [], []
    for k in range(layers + 1):
        # Alternate layers sit over the hollows of the one below (close packing).
        q = plane + (k % 2) * np.array([0.5 * h, h / (2.0 * math.sqrt(3.0))])
        q = q[apothem - np.max(q @ normal.T, axis=1) >= _PLUG_CLEARANCE * h]
        out.append(np.column_stack((q, np.full(len(q), z0 + (z1 - z0) * k / layers))))
        end.append(np.full(len(q), k in (0, layers)))
    return np.vstack(out), np.concatenate(end)


def _displace(x: np.ndarray, in_face: np.ndarray, jitter: float, rng: np.random.Generator,
              solid: Solid, h: float) -> np.ndarray:
    """Lattice points moved by up to ``jitter`` (m) along each axis; those in an end
    face stay in it; one that would come closer to the wall than half the clearance
    stays where it was."""
    step = rng.uniform(-jitter, jitter, x.shape)
    step[in_face, 2] = 0.0
    moved = x + step
    clearance = solid.apothem - np.max(moved[:, :2] @ solid.facet_normals()[:, :2].T, axis=1)
    near = clearance < 0.5 * _PLUG_CLEARANCE * h
    moved[near] = x[near]
    return moved


def build_scda_model(assembly: GrainAssembly, fill: ScdaFill, *, safety: float = 0.5,
                     mass_scaling: bool | float = True,
                     rock: MechanicalModel | None = None) -> MechanicalModel:
    """The rock model with the plug's blocks, wall contacts and block contacts appended.

    ``rock``: a model of ``assembly`` already built (only its contact properties are
    read, which safety and mass scaling leave alone); built here if not given.
    """
    if rock is None:
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
        x=np.vstack((mesh.node_x, fill.node_xy)),
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
                        velocity_limit=rock_solver.velocity_limit, backend=rock_solver.backend)
    _copy_state(rock_solver, s, n_rock, c_rock)
    loads = rock_solver.loads
    s.loads.external[:n_rock] = loads.external
    s.loads.fixed[:n_rock] = loads.fixed
    s.loads.prescribed_velocity[:n_rock] = loads.prescribed_velocity
    s.loads.platens = loads.platens

    wall_xy = rock_solver.model.x[fill.wall_rock_node]
    design = np.column_stack((np.ones(len(wall_xy)), wall_xy))
    coef, *_ = np.linalg.lstsq(design, rock_solver.u[fill.wall_rock_node], rcond=None)
    s.u[n_rock:] = np.column_stack((np.ones(len(fill.node_xy)), fill.node_xy)) @ coef

    m = scda_model
    plug = np.arange(rock_solver.model.element_nodes.shape[0], len(m.element_nodes))
    nodes = m.element_nodes[plug]
    if m.dimension == 2:
        ux, uy = s.u[nodes, 0], s.u[nodes, 1]
        s.initial_strain[plug, 0] = np.sum(m.dndx[plug] * ux, axis=1)
        s.initial_strain[plug, 1] = np.sum(m.dndy[plug] * uy, axis=1)
        s.initial_strain[plug, 2] = np.sum(m.dndy[plug] * ux + m.dndx[plug] * uy, axis=1)
    else:
        # du[e, i, j] = d u_j / d x_i; Voigt xx, yy, zz, yz, xz, xy with engineering shears.
        du = np.einsum("eki,ekj->eij", m.grad[plug], s.u[nodes])
        s.initial_strain[plug, :3] = np.diagonal(du, axis1=1, axis2=2)
        for col, (i, j) in zip((3, 4, 5), ((1, 2), (0, 2), (0, 1)), strict=True):
            s.initial_strain[plug, col] = du[:, i, j] + du[:, j, i]
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
                        velocity_limit=scda_solver.velocity_limit, backend=scda_solver.backend)
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
