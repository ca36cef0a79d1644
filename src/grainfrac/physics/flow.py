"""Fluid flow along grain boundaries (cubic law), pressure update, the well.

Model (paper Eqs. 2-3, Fig. 3b, Table 4):

- pore aperture of a sub-contact ``a = max(a0 + u_n, a_res)`` with ``u_n`` its
  mechanical opening; its hydraulic aperture is ``min(a, a_max)``;
- a pipe between two consecutive boundary points carries
  ``q = C (p_i - p_j)`` with conductance ``C = a^3 / (12 mu) * w / l``
  (``a`` the mean of its end hydraulic apertures, ``w`` the slab thickness,
  ``l`` its length);
- a fluid node stores ``V (1 + p / Kw)`` of fluid (reference-density volume,
  linearised equation of state), with ``V`` the void volume of the
  sub-contacts at that point (pore aperture x area). a_max caps the flow only:
  a crack wider than a_max still holds its whole void of fluid, else the fluid
  pressure would push its faces apart for free (measured: a 125 um SCDA crack
  capped at 30 um gave the grains 0.0186 J of fluid work for 0.0003 J pumped).

The pressure step is backward Euler in conservative form::

    V+ (1 + p+ / Kw) - V (1 + p / Kw) = dt (sum_j C (p_j+ - p_i+) + Q_i)

so the fluid volume balance closes to round-off whatever the step (Eq. 3 is
its explicit, non-conservative cousin). Fixed-pressure nodes (permeable
sides) are Dirichlet rows; their net inflow is the outflow. The well is one
unknown: the fluid nodes on the borehole wall are merged into it, its storage
is ``V_well c_well p`` plus theirs, and the injection rate is its source.
Where a crack opens faster than fluid arrives, content falls below the void
volume: the node is unsaturated and its pressure is zero (no suction).

Grains are impermeable (paper Sect. 2.1): with breakable grains the faces
between the blocks of one grain are ``sealed`` sub-contacts, whose pipes carry
no flow until the face has cracked (:func:`conducting`). They keep their pore
void, so the pressure solve stays regular.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from grainfrac.geometry.meshing import GrainMesh
from grainfrac.physics import pressure_system
from grainfrac.physics.coupling_kernels import mean_hydraulic_apertures

#: How the borehole wall meets the grain boundaries that end on it
#: (:func:`build_flow_network`).
WELL_WALLS = ("wet", "sealed", "flow_knots")
# Sealed wall: a wall mouth opens to the well once its sub-contacts have cracked or
# opened by this many initial apertures (a bonded Table 2 contact opens elastically
# by at most T / kn = 0.05-0.1 um < a0 = 0.2 um, so in practice: once it cracks).
MOUTH_OPENING_APERTURES = 1.0
# An open mouth joins a wall fluid node to the well over this fraction of the zone
# size: the node sits on the wall, so the link has no physical length; at 1 % it is
# ~100x as conductive as the pipe behind it and the node follows the well, while
# the pressure matrix stays well conditioned.
MOUTH_LENGTH_ZONES = 0.01


@dataclass(frozen=True)
class FluidProperties:
    """Fluid and aperture parameters (SI). Defaults: water, paper Table 4."""

    viscosity: float = 1.0e-3  # Pa s
    bulk_modulus: float = 2.0e9  # Pa
    initial_aperture: float = 2.0e-7  # a0 (m)
    residual_aperture: float = 2.0e-7  # a_res (m), bonded grain boundaries
    maximum_aperture: float = 3.0e-5  # a_max (m)
    # A broken (or fissured) grain boundary does not close back to the intact
    # aperture: its faces no longer match. Default None: same as a_res.
    broken_residual_aperture: float | None = None
    # The void of a contact pressed below its smallest aperture follows its faces as
    # they part (the conductance keeps the aperture law): see closure_initial_aperture.
    closure_storage: bool = False


@dataclass(frozen=True)
class FlowNetwork:
    """Unknowns and pipes of the pressure solve for one mesh.

    ``unknown_of_node`` maps fluid nodes to unknowns (wall nodes share the well
    unknown, which is the last one when there is a well).
    """

    mesh: GrainMesh
    unknown_of_node: np.ndarray  # (p,)
    n_unknowns: int
    well_unknown: int  # -1 without a well
    well_volume: float  # undeformed borehole void volume (m3)
    well_compressibility: float  # 1/Pa
    pipe_unknowns: np.ndarray  # (q', 2) pipes that join two different unknowns
    pipe_index: np.ndarray  # (q',) which mesh pipe
    fixed: np.ndarray  # (n_unknowns,) bool
    fixed_pressure: np.ndarray  # (n_unknowns,)
    sealed: np.ndarray | None = None  # (c,) sub-contacts that conduct only once broken
    wall: str = "wet"  # one of WELL_WALLS
    mouths: Mouths | None = None  # sealed wall: the wall fluid nodes' links to the well

    @property
    def contact_unknown(self) -> np.ndarray:
        return self.unknown_of_node[self.mesh.contact_fluid_node]

    @property
    def wall_pressurised(self) -> bool:
        """Whether the well's pressure loads the borehole wall and its void stores fluid
        (not with injection at the flow knots, where fluid lives in the joints only)."""
        return self.well_unknown >= 0 and self.wall != "flow_knots"


@dataclass(frozen=True)
class Mouths:
    """Where the grain boundaries meet a sealed borehole wall: one link per wall fluid
    node between its own unknown and the well's, shut until :func:`open_mouths`."""

    unknown: np.ndarray  # (k,) the wall nodes' unknowns
    contact_mouth: np.ndarray  # (c,) mouth of each sub-contact, -1 off the wall
    length: float  # m, see MOUTH_LENGTH_ZONES
    width: float  # m, the slab thickness
    is_open: np.ndarray  # (k,) bool


def build_flow_network(
    mesh: GrainMesh,
    *,
    permeable_sides: dict[str, float] | None = None,
    well: bool = True,
    well_compressibility: float = 1.0 / 2.0e9,
    sealed: np.ndarray | None = None,
    wall: str = "wet",
    well_nodes: np.ndarray | None = None,
) -> FlowNetwork:
    """Flow unknowns for a mesh, with every pipe conducting (see :func:`conducting`).

    Parameters
    ----------
    mesh
        The meshed assembly.
    permeable_sides
        Side name -> fixed pressure (Pa) of the fluid nodes on that side.
    well
        Merge the borehole-wall fluid nodes into one well unknown.
    well_compressibility
        Compressibility of the well fluid volume (1/Pa), default that of water.
    sealed
        (c,) bool: sub-contacts that carry no flow while bonded (grain interiors
        of breakable grains); None or all False: every sub-contact conducts.
    wall
        How the well meets the grain boundaries that end on its wall
        (``WELL_WALLS``):

        - ``"wet"``: the wall's fluid nodes are merged into the well, so the well
          pressure acts inside every wall contact from the first step (a permeable
          wall), and on the wall itself;
        - ``"sealed"``: the well pressure acts on the wall; each wall fluid node is
          its own unknown, joined to the well by a mouth that opens once one of
          its sub-contacts cracks or opens by ``MOUTH_OPENING_APERTURES`` a0
          (:func:`open_mouths`);
        - ``"flow_knots"``: 3DEC's injection at the flow knots where the joints
          meet the wall: the fluid enters the wall contacts (merged, as ``"wet"``)
          and lives in the joints only: no pressure on the wall, no borehole void.
    well_nodes
        Fluid nodes that are the well instead of the borehole wall's, with no void of
        its own and no wall (``wall`` must be ``"flow_knots"``): a point injection, as
        into the centre of the penny-shaped crack.
    """
    if sealed is not None and len(sealed) != mesh.n_contacts:
        raise ValueError(f"sealed has {len(sealed)} entries for {mesh.n_contacts} sub-contacts")
    if wall not in WELL_WALLS:
        raise ValueError(f"wall: must be one of {', '.join(WELL_WALLS)} (got {wall!r})")
    n_nodes = len(mesh.fluid_node_x)
    unknown = np.arange(n_nodes)
    well_unknown = -1
    well_volume = 0.0
    mouths = None
    wall_nodes = mesh.fluid_node_sets.get("borehole", np.zeros(0, dtype=np.int64))
    if well_nodes is not None:
        if wall != "flow_knots":
            raise ValueError("well_nodes: a point injection has no wall: give wall = "
                             "'flow_knots'")
        wall_nodes = np.asarray(well_nodes, dtype=np.int64)
    if well and (mesh.has_borehole or well_nodes is not None):
        if wall == "sealed":
            well_unknown = n_nodes
            unknown = np.arange(n_nodes)
            mouth_of_node = np.full(n_nodes, -1)
            mouth_of_node[wall_nodes] = np.arange(len(wall_nodes))
            mouths = Mouths(unknown=unknown[wall_nodes].copy(),
                            contact_mouth=mouth_of_node[mesh.contact_fluid_node],
                            length=MOUTH_LENGTH_ZONES * mesh.wall_zone_size,
                            # 2D: the node stands for the whole slab thickness; 3D: a
                            # zone of the grain boundary's line on the wall
                            width=(mesh.thickness if mesh.dimension == 2
                                   else mesh.wall_zone_size),
                            is_open=np.zeros(len(wall_nodes), dtype=bool))
        else:
            keep = np.ones(n_nodes, dtype=bool)
            keep[wall_nodes] = False
            unknown = np.full(n_nodes, -1)
            unknown[keep] = np.arange(keep.sum())
            well_unknown = int(keep.sum())
            unknown[wall_nodes] = well_unknown
        if wall != "flow_knots":
            well_volume = borehole_volume(mesh)
    n_unknowns = max(int(unknown.max()), well_unknown) + 1
    pu = unknown[mesh.pipe_nodes]
    distinct = pu[:, 0] != pu[:, 1]
    fixed = np.zeros(n_unknowns, dtype=bool)
    fixed_pressure = np.zeros(n_unknowns)
    for side, pressure in (permeable_sides or {}).items():
        nodes = mesh.fluid_node_sets[side]
        ids = unknown[nodes]
        ids = ids[ids != well_unknown] if well_unknown >= 0 else ids
        fixed[ids] = True
        fixed_pressure[ids] = pressure
    return FlowNetwork(
        mesh=mesh,
        unknown_of_node=unknown,
        n_unknowns=n_unknowns,
        well_unknown=well_unknown,
        well_volume=well_volume,
        well_compressibility=well_compressibility,
        pipe_unknowns=pu[distinct],
        pipe_index=np.flatnonzero(distinct),
        fixed=fixed,
        fixed_pressure=fixed_pressure,
        sealed=None if sealed is None or not np.any(sealed) else np.asarray(sealed, dtype=bool),
        wall=wall,
        mouths=mouths,
    )


def open_mouths(network: FlowNetwork, aperture: np.ndarray, bonded: np.ndarray,
                fluid: FluidProperties) -> FlowNetwork:
    """``network`` with the sealed wall's mouths opened where a wall sub-contact has
    cracked or its aperture exceeds a0 by ``MOUTH_OPENING_APERTURES`` a0. An open
    mouth stays open (a crack that has taken well fluid keeps its path to the well)."""
    mouths = network.mouths
    if mouths is None or mouths.is_open.all():
        return network
    on_wall = mouths.contact_mouth >= 0
    opened = ~np.asarray(bonded, dtype=bool) | (
        aperture >= fluid.initial_aperture * (1.0 + MOUTH_OPENING_APERTURES))
    now = np.zeros(len(mouths.is_open), dtype=bool)
    now[mouths.contact_mouth[on_wall & opened]] = True
    if not (now & ~mouths.is_open).any():
        return network
    return replace(network, mouths=replace(mouths, is_open=mouths.is_open | now))


def links(network: FlowNetwork, aperture: np.ndarray,
          fluid: FluidProperties) -> tuple[np.ndarray, np.ndarray]:
    """Everything that carries flow between two unknowns: their unknown pairs (k, 2) and
    cubic-law conductances (m3 / (s Pa)): the pipes, and a sealed wall's open mouths
    (at the mean hydraulic aperture of the mouth's sub-contacts)."""
    ends, cond = network.pipe_unknowns, pipe_conductance(network, aperture, fluid)
    mouths = network.mouths
    if mouths is None or not mouths.is_open.any():
        return ends, cond
    on_wall = mouths.contact_mouth >= 0
    k = len(mouths.is_open)
    hydraulic = np.minimum(aperture[on_wall], fluid.maximum_aperture)
    a = (np.bincount(mouths.contact_mouth[on_wall], weights=hydraulic, minlength=k)
         / np.maximum(np.bincount(mouths.contact_mouth[on_wall], minlength=k), 1))
    open_ = np.flatnonzero(mouths.is_open)
    mouth_cond = a[open_]**3 / (12.0 * fluid.viscosity) * mouths.width / mouths.length
    mouth_ends = np.column_stack((mouths.unknown[open_],
                                  np.full(len(open_), network.well_unknown)))
    return np.concatenate((ends, mouth_ends)), np.concatenate((cond, mouth_cond))


def conducting(network: FlowNetwork, bonded: np.ndarray | None = None) -> FlowNetwork:
    """``network`` (built with every pipe) less the pipes of intact sealed faces.

    A pipe is shut while both its end sub-contacts are sealed and bonded: once
    either end has cracked, the face conducts at the mean of the end apertures,
    as a grain boundary does. ``bonded`` None: every sub-contact intact.
    """
    if network.sealed is None:
        return network
    ends = network.mesh.pipe_contacts[network.pipe_index]
    shut = network.sealed[ends]
    if bonded is not None:
        shut &= np.asarray(bonded, dtype=bool)[ends]
    keep = ~shut.all(axis=1)
    return replace(network, pipe_unknowns=network.pipe_unknowns[keep],
                   pipe_index=network.pipe_index[keep])


def borehole_wall_loop(mesh: GrainMesh) -> np.ndarray:
    """The borehole wall as :func:`borehole_volume` walks it, fixed by the mesh.

    2D: node triples (k, 3), each face's start and end node and the start node of
    the face that begins where it ends (its twin node across a crack mouth, or the
    same node). 3D: the wall's surface triangles (t, 3), wound so that their normal
    points away from the borehole axis (into the rock).
    """
    if mesh.dimension == 3:
        tri = mesh.surface_triangles["borehole"].copy()
        p = mesh.node_x[tri]
        normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        radial = p.mean(axis=1)[:, :2]
        inward = np.einsum("ij,ij->i", normal[:, :2], radial) < 0.0
        tri[inward] = tri[inward][:, ::-1]
        return np.vstack((tri, _crack_mouth_triangles(mesh, tri)))
    faces = mesh.boundary_faces["borehole"].nodes
    start, end = faces[:, 0], faces[:, 1]
    gap = mesh.node_xy[end][:, None, :] - mesh.node_xy[start][None, :, :]
    following = start[np.argmin(np.einsum("ijk,ijk->ij", gap, gap), axis=1)]
    return np.column_stack((start, end, following))


def _crack_mouth_triangles(mesh, tri: np.ndarray) -> np.ndarray:
    """Triangles (k, 3) that close the 3D borehole wall across its crack mouths.

    Each grain's wall patch has nodes of its own; where two patches meet, an edge
    a -> b of one (as its outward winding runs) has a twin b' -> a' on the other at the
    same two points. The quad (b, a, a', b') bridges them with the winding of both, so
    it is flat and empty while the grain boundary is closed and spans the mouth's
    opening once it opens. Where three grains meet on the wall, a small triangle stays
    open (second order in the openings).
    """
    edges = np.concatenate((tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]))
    key = np.sort(edges, axis=1)
    _, first, count = np.unique(key, axis=0, return_index=True, return_counts=True)
    rim = edges[first[count == 1]]  # edges of one triangle only: the patches' rims
    point = mesh.node_point[rim]
    lookup = {(int(pa), int(pb)): k for k, (pa, pb) in enumerate(point)}
    # The twin of a -> b runs b' -> a' (rim[k2] = (b', a')).
    quads = [(b, a, rim[k2, 1], rim[k2, 0])
             for k, ((a, b), (pa, pb)) in enumerate(zip(rim, point, strict=True))
             if (k2 := lookup.get((int(pb), int(pa)), -1)) > k]
    if not quads:
        return np.empty((0, 3), dtype=tri.dtype)
    q = np.array(quads, dtype=tri.dtype)
    return np.vstack((q[:, [0, 1, 2]], q[:, [0, 2, 3]]))


def borehole_volume(mesh: GrainMesh, displacement: np.ndarray | None = None,
                    wall_loop: np.ndarray | None = None) -> float:
    """Void volume (m3) of the borehole with the wall nodes moved by ``displacement``
    (n_nodes, d) if given. ``wall_loop`` is :func:`borehole_wall_loop` (computed here
    if not given; callers that ask at every step pass it).

    2D: the area of the wall polygon times the slab thickness. Where a grain boundary
    meets the wall its two grains have nodes of their own at the same place; the
    polygon closes across that crack mouth (whose own void is the contact's
    aperture). Summed over the faces alone, the shoelace formula lost r x the mouth's
    opening: a mouth opening by 2.3 um took 0.55 mJ of well fluid work on the grains
    that the well's void did not show (lab HS, 5 ml/min, seed 8; 1.16x the pumped
    energy on the grains over the run).

    3D: the divergence theorem with the field F = (x, y, 0) / 2 (div F = 1), which has
    no flux through the borehole's flat ends: V = sum over the wall triangles of
    F(centroid) . S (S the triangle's area vector out of the hole), exact for flat
    triangles. The wall is closed across its crack mouths (:func:`_crack_mouth_triangles`)
    for the reason given for 2D.
    """
    loop = borehole_wall_loop(mesh) if wall_loop is None else wall_loop
    if mesh.dimension == 3:
        x = mesh.node_x if displacement is None else mesh.node_x + displacement[:mesh.n_nodes]
        p = x[loop]
        area_vector = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        centroid = p.mean(axis=1)
        return float(0.5 * np.sum(centroid[:, :2] * area_vector[:, :2]))
    start, end, following = loop[:, 0], loop[:, 1], loop[:, 2]
    xy = mesh.node_xy if displacement is None else mesh.node_xy + displacement[:len(mesh.node_xy)]
    a = np.concatenate((xy[start], xy[end]))
    b = np.concatenate((xy[end], xy[following]))
    return abs(0.5 * np.sum(a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1])) * mesh.thickness


def pore_aperture(opening: np.ndarray, fluid: FluidProperties,
                  bonded: np.ndarray | None = None,
                  initial_aperture: np.ndarray | None = None) -> np.ndarray:
    """``max(a0 + opening, lower)`` per sub-contact (m), the width of the void that
    holds fluid; ``lower`` from :func:`smallest_aperture`, a0 the fluid's or
    ``initial_aperture`` (per sub-contact). Pipes cap it at a_max
    (:func:`pipe_conductance`)."""
    lower = (np.full(np.shape(opening), fluid.residual_aperture) if bonded is None
             else smallest_aperture(fluid, bonded))
    a0 = fluid.initial_aperture if initial_aperture is None else initial_aperture
    return np.maximum(a0 + opening, lower)


def closure_initial_aperture(opening: np.ndarray, fluid: FluidProperties) -> np.ndarray:
    """Per sub-contact, the a0 of a void that follows its faces from ``opening`` (m, the
    reference state's) on: ``max(a0, lower - opening)`` with ``lower`` a broken contact's
    smallest aperture, so that the void is ``lower`` at that opening and grows by every
    metre the faces part from there (:attr:`FluidProperties.closure_storage`)."""
    lower = smallest_aperture(fluid, np.zeros(np.shape(opening), dtype=bool))
    return np.maximum(fluid.initial_aperture, lower - opening)


def smallest_aperture(fluid: FluidProperties, bonded: np.ndarray) -> np.ndarray:
    """Lower aperture bound per sub-contact (m): a_res, or where ``bonded`` is False
    (cracks, fissures) the broken residual aperture if one is set."""
    broken = (fluid.residual_aperture if fluid.broken_residual_aperture is None
              else fluid.broken_residual_aperture)
    return np.where(bonded, fluid.residual_aperture, broken)


def pipe_conductance(network: FlowNetwork, aperture: np.ndarray,
                     fluid: FluidProperties) -> np.ndarray:
    """Cubic-law conductance (m3 / (s Pa)) of each pipe that joins two unknowns, from
    the pore apertures capped at a_max (the hydraulic aperture)."""
    mesh = network.mesh
    i = network.pipe_index
    a = mean_hydraulic_apertures(np.asarray(aperture, dtype=float), fluid.maximum_aperture,
                                 mesh.pipe_contacts, i)
    return a**3 / (12.0 * fluid.viscosity) * mesh.pipe_width[i] / mesh.pipe_length[i]


def storage_volume(network: FlowNetwork, aperture: np.ndarray,
                   well_volume: float | None = None) -> np.ndarray:
    """Void volume (m3) of each unknown: pore apertures x sub-contact areas, plus the
    borehole's ``well_volume`` (default: the undeformed borehole)."""
    v = np.bincount(network.contact_unknown, weights=aperture * network.mesh.contact_area,
                    minlength=network.n_unknowns)
    if network.well_unknown >= 0:
        v[network.well_unknown] += network.well_volume if well_volume is None else well_volume
    return v


def _compressibility(network: FlowNetwork, fluid: FluidProperties) -> np.ndarray:
    c = np.full(network.n_unknowns, 1.0 / fluid.bulk_modulus)
    if network.well_unknown >= 0:
        c[network.well_unknown] = network.well_compressibility
    return c


@dataclass
class FluidState:
    """Pressures and fluid content per unknown, and the running volume balance.

    ``content`` is the fluid held by each unknown as a reference-density volume
    (m3); it changes only by flow, so the balance ``injected = stored +
    outflow`` is exact. Pressure follows from content and void volume; where
    content falls below the void volume the node is unsaturated at p = 0.
    """

    pressure: np.ndarray
    volume: np.ndarray
    content: np.ndarray
    injected: float = 0.0
    outflow: float = 0.0
    # Energy (J) the pump put into the well (the integral of p_well Q dt), and the
    # work of the well pressure on the borehole wall (kept by the coupling).
    pump_work: float = 0.0
    wall_work: float = 0.0
    # Energy (J) dissipated by viscous flow in the pipes (dt sum C dp^2 per step),
    # and carried out through the fixed-pressure nodes (their pressure x outflow).
    viscous_work: float = 0.0
    outflow_work: float = 0.0
    # Unknowns the last solve held dry (unsaturated, p = 0): the next solve's active
    # set starts from them (None: from none).
    dry: np.ndarray | None = None

    def stored(self, free: np.ndarray) -> float:
        """Fluid held by the free unknowns (m3 at reference density)."""
        return float(self.content[free].sum())


def initial_state(network: FlowNetwork, aperture: np.ndarray, fluid: FluidProperties,
                  pressure: float | np.ndarray = 0.0,
                  well_volume: float | None = None) -> FluidState:
    """Saturated network at ``pressure`` (fixed nodes at their fixed pressure)."""
    p = np.broadcast_to(np.asarray(pressure, dtype=float), (network.n_unknowns,)).copy()
    p[network.fixed] = network.fixed_pressure[network.fixed]
    v = storage_volume(network, aperture, well_volume)
    return FluidState(pressure=p, volume=v,
                      content=v * (1.0 + _compressibility(network, fluid) * p))


def _sources(network: FlowNetwork, injection_rate: float) -> np.ndarray:
    q = np.zeros(network.n_unknowns)
    if injection_rate:
        if network.well_unknown < 0:
            raise ValueError("injection needs a well")
        q[network.well_unknown] = injection_rate
    return q


@dataclass(frozen=True)
class SharedCompliance:
    """The opening (m3/Pa) of pore i under a pressure change at pore j through the crack
    modes they share: ``B = near + modes diag(kappa) modes^T``, symmetric.

    ``near`` (sparse n x n) holds the rank-one blocks of small cracks explicitly;
    ``modes`` (sparse n x K, the open area of each large crack at each node) and
    ``kappa`` (K) keep the large ones as factors, because a crack of N nodes is a dense
    N x N block that a sparse direct factorisation fills at ~N^3 / 3 operations:
    after SCDA charging in the 100 mm cube, one crack of a few thousand nodes made each
    pressure solve take ~60 s. :func:`implicit_step` solves with them by the
    Sherman-Morrison-Woodbury identity (one factorisation of the sparse part, K
    solves, a K x K system).
    """

    near: sp.csr_matrix
    modes: sp.csc_matrix
    kappa: np.ndarray

    @property
    def low_rank(self) -> pressure_system.LowRank:
        """``modes diag(kappa) modes^T``."""
        return pressure_system.LowRank(self.modes, self.kappa)

    def __matmul__(self, p: np.ndarray) -> np.ndarray:
        return self.near @ p + self.low_rank @ p

    def diagonal(self) -> np.ndarray:
        return self.near.diagonal() + self.low_rank.diagonal()


def implicit_step(network: FlowNetwork, state: FluidState, aperture: np.ndarray, dt: float,
                  fluid: FluidProperties, injection_rate: float = 0.0,
                  compliance: np.ndarray | None = None,
                  well_volume: float | None = None,
                  shared_compliance: SharedCompliance | sp.spmatrix | None = None,
                  pipe_links: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Advance pressures by ``dt``: backward Euler on fluid content; update the balance.

    Solves, for the free unknowns,
    ``(V c + beta + B) p+ - dt sum_j C (p_j+ - p_i+) = content - V + (beta + B) p + dt Q``
    where ``beta`` (m3/Pa, ``compliance``) is the opening compliance of each pore
    at fixed total stress under a pressure change of its own, and ``B``
    (``shared_compliance``, :class:`SharedCompliance` or sparse) the opening of pore i under a
    pressure change at pore j through a mode they share (fixed-stress split:
    they stand in for the mechanical response to the pressure change that the
    staggered mechanics delivers next; with both zero this is the plain
    conservative step). Content then changes by exactly the net flow.
    ``well_volume`` is the borehole's current void (default: undeformed);
    ``pipe_links``: :func:`links` of ``network`` and ``aperture``, if the caller has them
    (or of the apertures that conduct, where the voids are not as wide: closure_storage).
    """
    c = _compressibility(network, fluid)
    v_new = storage_volume(network, aperture, well_volume)
    beta = np.zeros(network.n_unknowns) if compliance is None else compliance
    lap = pressure_system.laplacian(network.n_unknowns,
                                   *(pipe_links or links(network, aperture, fluid)))
    source = _sources(network, injection_rate)
    storage = v_new * c + beta
    rhs = state.content - v_new + beta * state.pressure + dt * source
    matrix = (sp.diags(storage) + dt * lap).tocsr()
    low_rank = None
    if shared_compliance is not None:
        rhs = rhs + shared_compliance @ state.pressure
        if sp.issparse(shared_compliance):
            matrix = (matrix + shared_compliance).tocsr()
        else:
            matrix = (matrix + shared_compliance.near).tocsr()
            if shared_compliance.modes.shape[1]:
                low_rank = shared_compliance
    free = ~network.fixed
    p_new, state.dry = _solve_without_suction(matrix, rhs, network.fixed,
                                              network.fixed_pressure, low_rank, state.dry,
                                              guess=state.pressure)
    flow_out = lap @ p_new
    net_in = source - flow_out
    state.content[free] += dt * net_in[free]
    state.outflow += float(dt * net_in[network.fixed].sum())
    state.outflow_work += float(dt * np.dot(p_new[network.fixed], net_in[network.fixed]))
    state.viscous_work += float(dt * np.dot(p_new, flow_out))
    state.injected += dt * injection_rate
    if network.well_unknown >= 0:
        state.pump_work += dt * injection_rate * p_new[network.well_unknown]
    state.pressure = p_new
    state.volume = v_new


def compression_energy(network: FlowNetwork, state: FluidState, fluid: FluidProperties) -> float:
    """Elastic energy (J) of the fluid in the free unknowns at the last pressure solve,
    sum V c p^2 / 2.

    With the pump's work, the viscous dissipation, the energy carried out and the
    fluid's work on the grains it closes the fluid's energy books: along the
    backward-Euler step, pump = viscous + outflow + sum p d(content), and the last
    term is compression plus the opening of the pores, which the solve anticipates
    (fixed-stress compliance) and the mechanics then delivers. (The pressure at
    which each node's content would fit its current void instead counts that
    anticipated opening as compression: up to 34 MPa against the solve's 1.6 MPa
    at crack-tip nodes, and single steps that lost 5.6 mJ of it.)
    """
    free = ~network.fixed
    c = _compressibility(network, fluid)[free]
    return float(np.sum(0.5 * state.volume[free] * c * state.pressure[free] ** 2))


def undrained_pressure(network: FlowNetwork, state: FluidState, aperture: np.ndarray,
                       fluid: FluidProperties, compliance: np.ndarray,
                       well_volume: float | None = None) -> np.ndarray:
    """Pressure (Pa) at which each unknown's fluid content fits the void of ``aperture``.

    The same linearisation as :func:`implicit_step` without flow: storage
    ``V c + beta`` about the current pressure. Where the void has grown past
    the content the node is unsaturated and the result is 0.
    """
    v = storage_volume(network, aperture, well_volume)
    c = _compressibility(network, fluid)
    excess = state.content - v * (1.0 + c * state.pressure)
    return np.maximum(state.pressure + excess / (v * c + compliance), 0.0)


def _solve_without_suction(matrix: sp.csr_matrix, rhs: np.ndarray, fixed: np.ndarray,
                           fixed_pressure: np.ndarray, low_rank: SharedCompliance | None = None,
                           dry: np.ndarray | None = None, max_rounds: int = 50,
                           guess: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``(matrix + low_rank) p = rhs`` with ``p >= 0`` on the free unknowns
    (primal-dual active set for this complementarity problem; ``low_rank``, if given,
    adds its large cracks' modes, :class:`SharedCompliance`). Returns the pressures
    and the unknowns held dry.

    The active set starts from ``dry`` (the last step's): most of it holds from one
    step to the next, and every round is a factorisation. Measured on the 50 x 50 x
    10 mm 3D hybrid slab (seed 0, 750 fluid steps): 4.6 rounds a step from an empty
    set, 2.0 from the last step's (the solves' time 11.4 -> 3.2 s; breakdown 7.1561
    -> 7.1558 MPa, where a node within the release tolerance ends otherwise).

    Fluid cannot pull (no suction): a node whose pressure would be negative (a pore
    opening faster than fluid can reach it) is unsaturated and held at p = 0, so
    the flows towards it are driven by its neighbours' pressures only. A node held
    dry is let go again when, with its neighbours' new pressures, it would hold
    more fluid than its void (``rhs - matrix p > 0`` there, by more than 1 Pa of
    its own storage). Without that release a dry node stayed at zero while its
    neighbours filled it: 30 % more fluid than void at 0 MPa, let go later as
    47 MPa and 1.1 mJ of viscous flow in one step for 0.075 mJ pumped
    (lab-calibrated rock, hybrid, 15 % fissures, seed 0). The matrix (storage
    plus a graph Laplacian) is an M-matrix, for which these rounds settle.
    """
    dry = np.zeros_like(fixed) if dry is None else dry & ~fixed
    # ``guess`` (the last step's pressures) starts an iterative solve; a direct one
    # reads only the held values.
    p = np.where(fixed, fixed_pressure, 0.0 if guess is None else np.where(dry, 0.0, guess))
    modes = None if low_rank is None else low_rank.low_rank  # ``near`` is in the matrix
    diagonal = matrix.diagonal() if modes is None else matrix.diagonal() + modes.diagonal()
    for _ in range(max_rounds):
        free = ~fixed & ~dry
        if free.any():
            p = pressure_system.solve_free(matrix, rhs, free, p, modes, diagonal)
        negative = free & (p < 0.0)
        wet = np.zeros_like(dry)
        if dry.any():
            # Whole products, then the dry rows: the same sums as products of the dry
            # rows alone, without slicing them out (tens of thousands in the 100 mm cube).
            pushed = matrix @ p if modes is None else matrix @ p + modes @ p
            wet[dry] = rhs[dry] - pushed[dry] > diagonal[dry]
        if not negative.any() and not wet.any():
            break
        p[negative] = 0.0
        dry = (dry | negative) & ~wet
    return np.maximum(p, np.where(fixed, -np.inf, 0.0)), dry


def explicit_step(network: FlowNetwork, state: FluidState, aperture: np.ndarray, dt: float,
                  fluid: FluidProperties, injection_rate: float = 0.0) -> None:
    """Forward-Euler reference of :func:`implicit_step` (stable only for tiny ``dt``)."""
    c = _compressibility(network, fluid)
    v_new = storage_volume(network, aperture)
    lap = pressure_system.laplacian(network.n_unknowns, *links(network, aperture, fluid))
    source = _sources(network, injection_rate)
    net_in = -(lap @ state.pressure) + source
    free = ~network.fixed
    state.content[free] += dt * net_in[free]
    state.outflow += float(dt * net_in[network.fixed].sum())
    state.injected += dt * injection_rate
    p_new = state.pressure.copy()
    p_new[free] = ((state.content / v_new - 1.0) / c)[free]
    state.pressure = np.where(free & (p_new < 0.0), 0.0, p_new)
    state.volume = v_new


def stable_explicit_dt(network: FlowNetwork, aperture: np.ndarray,
                       fluid: FluidProperties) -> float:
    """Largest stable forward-Euler step: min_i V_i c_i / sum_j C_ij."""
    c = _compressibility(network, fluid)
    v = storage_volume(network, aperture)
    ends, cond = links(network, aperture, fluid)
    total = np.bincount(ends.ravel(), weights=np.repeat(cond, 2),
                        minlength=network.n_unknowns)
    free = ~network.fixed & (total > 0)
    return float(np.min(v[free] * c[free] / total[free]))
