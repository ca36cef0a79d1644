"""Named records the mechanics kernels take (numba-compatible NamedTuples of arrays).

Static records (``Elements``, ``Contacts``) hold what a model fixes; state
records (``NodeState``, ``ElementState``, ``ContactState``) what the kernels
advance; the others carry loads, platens, pore springs, the crack log and the
step controls. Arrays are SI and shaped by the dimension ``d``: the same kernels
and the same scalar laws serve triangles and tetrahedra, and a CUDA backend can
take the same arrays. ``ENERGY_DTYPE`` names the energy books: one structured
record, so no code reads them by position.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

# The mechanics' energy books (J), in the order reports list them.
ENERGY_KEYS = ("boundary_work", "damping_work", "friction_work", "bond_energy_released",
               "platen_work", "expansion_work", "fluid_work", "energy_removed")
ENERGY_DTYPE = np.dtype([(name, np.float64) for name in ENERGY_KEYS])


def new_energies() -> np.ndarray:
    """A zeroed energy record (a structured array of one element)."""
    return np.zeros(1, dtype=ENERGY_DTYPE)


class StepControl(NamedTuple):
    """How many explicit steps to take and how."""

    n_steps: int
    dt: float  # s
    damping: float  # local damping coefficient alpha
    allow_failure: bool  # False holds intact bonds elastic
    velocity_limit: float  # m/s; beyond it the run has blown up
    threads: int  # above 1: update cells, contacts and nodes on this many threads


class NodeState(NamedTuple):
    """Per node: displacement, velocity and the force being assembled, all ``(n, d)``."""

    u: np.ndarray
    v: np.ndarray
    force: np.ndarray


class NodeLoads(NamedTuple):
    """Per node: mass (kg), constant external force (N), fixed components, their velocity."""

    mass: np.ndarray  # (n,)
    external: np.ndarray  # (n, d)
    fixed: np.ndarray  # (n, d) bool
    prescribed_velocity: np.ndarray  # (n, d)


class Elements(NamedTuple):
    """Linear simplex cells: ``cells[m, d+1]``, ``grad[m, d+1, d]``, measure (m3), Lame."""

    cells: np.ndarray
    grad: np.ndarray
    measure: np.ndarray
    lam: np.ndarray
    mu: np.ndarray


class Adjacency(NamedTuple):
    """How the parallel step adds forces into nodes without races, in the serial order.

    Cells come in blocks of consecutive cells, ``block_ptr[b]`` to ``block_ptr[b + 1]``,
    that share no node: a thread takes a run of blocks and adds each cell's forces
    straight into its nodes in the serial kernel's order. Meshes list their cells grain by grain and
    grains meet only through sub-contacts (two distinct nodes), so blocks end at grain
    ends. Node ``contact_node[i]``'s sub-contacts are
    ``contact_slot[contact_ptr[i]:contact_ptr[i + 1]]`` as ``2 c + side`` (side 1: the
    node is the contact's second), ascending ``c``.
    """

    block_ptr: np.ndarray
    contact_node: np.ndarray
    contact_ptr: np.ndarray
    contact_slot: np.ndarray


# Cell blocks of the parallel step: the places where a thread's run of cells may end;
# enough to balance any thread count up to about this.
CELL_BLOCKS = 64


def cell_blocks(n_nodes: int, cells: np.ndarray, n_blocks: int = CELL_BLOCKS) -> np.ndarray:
    """Bounds of up to ``n_blocks`` runs of consecutive cells of about equal size that
    share no node.

    A run may end before cell ``i`` only where no node has cells on both sides; among
    those places the ones nearest to ``k m / n_blocks`` are taken. A mesh with no such
    place (one grain) is one block.
    """
    cells = np.asarray(cells, dtype=np.int64)
    m = len(cells)
    cell = np.repeat(np.arange(m), cells.shape[1])
    first = np.full(n_nodes, m, dtype=np.int64)
    last = np.full(n_nodes, -1, dtype=np.int64)
    np.minimum.at(first, cells.ravel(), cell)
    np.maximum.at(last, cells.ravel(), cell)
    used = last >= 0
    # spanning[i] > 0: some node has cells before i and from i on
    spanning = np.zeros(m + 1, dtype=np.int64)
    np.add.at(spanning, first[used] + 1, 1)
    np.add.at(spanning, last[used] + 1, -1)
    ends = np.flatnonzero(np.cumsum(spanning)[1:m] == 0) + 1
    if len(ends) == 0:
        return np.array([0, m], dtype=np.int64)
    targets = np.arange(1, n_blocks) * m / n_blocks
    nearest = np.clip(np.searchsorted(ends, targets), 1, len(ends)) - 1
    upper = np.minimum(nearest + 1, len(ends) - 1)
    pick = np.where(np.abs(ends[upper] - targets) < np.abs(ends[nearest] - targets),
                    upper, nearest)
    return np.unique(np.concatenate([[0], ends[pick], [m]])).astype(np.int64)


def node_slots(n_nodes: int, node_of_slot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists ``(ptr, slot)`` over every node: node ``n``'s slots are
    ``slot[ptr[n]:ptr[n + 1]]``, ascending (a stable sort). ``node_of_slot`` is the node
    of each slot, e.g. ``cells.ravel()`` (slot ``(d + 1) e + k``) or
    ``contact_nodes.ravel()`` (slot ``2 c + side``): ascending slots are the serial
    kernels' order of adding into a node."""
    node_of_slot = np.asarray(node_of_slot, dtype=np.int64).ravel()
    ptr = np.zeros(n_nodes + 1, dtype=np.int64)
    np.cumsum(np.bincount(node_of_slot, minlength=n_nodes), out=ptr[1:])
    return ptr, np.argsort(node_of_slot, kind="stable").astype(np.int64)


def build_adjacency(n_nodes: int, cells: np.ndarray, contact_nodes: np.ndarray) -> Adjacency:
    """The :class:`Adjacency` of a mesh: :func:`node_slots` of the contacts, kept for the
    nodes that have any."""
    ptr, contact_slot = node_slots(n_nodes, contact_nodes)
    contact_node = np.flatnonzero(np.diff(ptr)).astype(np.int64)
    contact_ptr = np.append(ptr[contact_node], ptr[-1])
    return Adjacency(cell_blocks(n_nodes, cells), contact_node, contact_ptr, contact_slot)


class ElementState(NamedTuple):
    """Per element: stress (Voigt, tension positive), eigenstrain and initial strain.

    ``eigenstrain`` is isotropic in the model's plane (2D) or space (3D) and grows by
    ``eigenstrain_rate`` per second; ``initial_strain`` (Voigt, engineering shear)
    lets a body inserted into a loaded specimen start stress-free.
    """

    stress: np.ndarray
    eigenstrain: np.ndarray
    eigenstrain_rate: np.ndarray
    initial_strain: np.ndarray


class Contacts(NamedTuple):
    """Sub-contacts: node pairs, frame ``[c, d, d]`` (normal, then d - 1 tangents),
    area (m2), stiffness (Pa/m) and strength (Pa) with the softening lengths (m)."""

    nodes: np.ndarray
    frame: np.ndarray
    area: np.ndarray
    kn: np.ndarray
    ks: np.ndarray
    tan_phi: np.ndarray
    cohesion: np.ndarray
    tensile_strength: np.ndarray
    opening_to_fail: np.ndarray
    slip_to_fail: np.ndarray


class ContactState(NamedTuple):
    """Per sub-contact: bond, status, normal stress (compression positive), shear
    stress vector ``tau[c, d-1]`` in the tangent frame, softening state, fluid
    pressure, bond energy released (J) and the opening at creation (m)."""

    bonded: np.ndarray
    status: np.ndarray
    sigma_n: np.ndarray
    tau: np.ndarray
    damage: np.ndarray
    plastic_opening: np.ndarray
    pressure: np.ndarray
    released: np.ndarray
    opening_offset: np.ndarray


class PlatenSet(NamedTuple):
    """Rigid frictionless platens; platen ``p`` acts on ``nodes[offsets[p]:offsets[p+1]]``."""

    x: np.ndarray  # (n, d) reference node positions
    nodes: np.ndarray
    offsets: np.ndarray
    axis: np.ndarray
    side: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    stiffness: np.ndarray
    reaction: np.ndarray
    node_force: np.ndarray


class PoreSpringSet(NamedTuple):
    """Pores whose pressure follows their void (see ``kernels.pore_spring_pressure``)."""

    contact: np.ndarray
    pore: np.ndarray
    lower: np.ndarray
    initial_aperture: np.ndarray  # a0 of each listed sub-contact's void
    held_void: np.ndarray
    storage: np.ndarray
    ceiling: np.ndarray
    resistance: np.ndarray
    void: np.ndarray  # workspace, one per pore
    rate: np.ndarray  # workspace, one per pore
    dissipated: np.ndarray  # (1,) J, accumulated


class CrackLog(NamedTuple):
    """Contacts that broke during a call and the step (within the call) when they did."""

    contact: np.ndarray
    step: np.ndarray
