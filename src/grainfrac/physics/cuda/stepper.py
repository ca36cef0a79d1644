"""``run_steps_cuda``: the explicit loop of :func:`grainfrac.physics.kernels.run_steps`
on a GPU, on device copies of the same records.

The host launches the kernels of each step and reads nothing back until the call
ends, except an eight-byte control word every ``sync_every`` steps (to stop
launching after a blow-up). Energy books, the crack list and the blow-up flag
live on the device.
"""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from grainfrac.physics.cuda._numba import SIMULATOR, cuda
from grainfrac.physics.cuda.device_kernels import HALTED, N_CRACKS, step_kernels
from grainfrac.physics.cuda.launch import PreparedLaunch
from grainfrac.physics.records import (
    Contacts,
    ContactState,
    CrackLog,
    Elements,
    ElementState,
    NodeLoads,
    NodeState,
    PlatenSet,
    PoreSpringSet,
    StepControl,
    node_slots,
)

# 256 threads a block on a GPU (a plain tetrahedron-step probe on an H200 ran best there);
# the simulator runs each thread as a Python thread, so fewer, smaller blocks.
DEFAULT_TPB = 32 if SIMULATOR else 256
DEFAULT_SYNC_EVERY = 1000


def to_device(record):
    """A copy of a record whose arrays live on the device (scalars stay as they are)."""
    return type(record)(*(cuda.to_device(np.ascontiguousarray(a)) if isinstance(a, np.ndarray)
                          else a for a in record))


def host_zeros(shape, dtype=np.float64) -> np.ndarray:
    """Zeros in page-locked (pinned) host memory: copies between it and the device go
    straight over the bus, where pageable memory is staged through a driver buffer
    first. For the state arrays of a solver on the GPU backend, copied every cycle."""
    array = cuda.pinned_array(shape, dtype)
    array[...] = 0
    return array


def copy_fields(source, target, names: tuple[str, ...]) -> None:
    """Copy the named arrays of one record into another of the same type, in place:
    host to device or device to host (whichever ``target`` holds)."""
    for name in names:
        src, dst = getattr(source, name), getattr(target, name)
        if hasattr(dst, "copy_to_device"):
            dst.copy_to_device(np.ascontiguousarray(src))
        elif dst.flags.c_contiguous:
            src.copy_to_host(dst)
        else:
            dst[...] = src.copy_to_host()


def device_energies(energies: np.ndarray):
    """The device copy of an energy record (ENERGY_DTYPE): a float64[8] in its order."""
    return cuda.to_device(np.ascontiguousarray(energies).view(np.float64).copy())


def add_energies(energies: np.ndarray, device_books) -> None:
    """Overwrite the host energy record with the device's books."""
    energies.view(np.float64)[:] = device_books.copy_to_host()


class DeviceWork(NamedTuple):
    """Device scratch of a call: the control word ``[halted step, n cracks]``, the
    largest |v| of each step and the platen of each platen node."""

    control: object
    vmax: object
    platen_of: object


class _StageClock:
    """Adds the wall time since its last call to ``timings[stage]`` (if timing)."""

    def __init__(self, timings: dict[str, float] | None):
        self.timings = timings
        if timings is not None:
            cuda.synchronize()
        self.last = time.perf_counter()

    def __call__(self, stage: str) -> None:
        if self.timings is None:
            return
        cuda.synchronize()
        now = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + now - self.last
        self.last = now


def _blocks(n: int, tpb: int) -> int:
    return max(1, (n + tpb - 1) // tpb)


class GatherOrder(NamedTuple):
    """What the ordered sums need of a model, made once per model: device CSR lists of
    each node's cell and contact slots (:func:`node_slots`) and the slots the elements
    (``cell_force[e, k]``) and contacts (``on_second[c]``) write their forces to."""

    cell_ptr: object
    cell_slot: object
    contact_ptr: object
    contact_slot: object
    cell_force: object
    on_second: object

    @classmethod
    def of(cls, n_nodes: int, cells: np.ndarray, contact_nodes: np.ndarray) -> GatherOrder:
        """From host arrays: ``cells`` (n, d + 1) and the contacts' node pairs."""
        n, k = cells.shape
        lists = (*node_slots(n_nodes, cells), *node_slots(n_nodes, contact_nodes))
        return cls(*(cuda.to_device(a) for a in lists), cuda.device_array((n, k, k - 1)),
                   cuda.device_array((max(len(contact_nodes), 1), k - 1)))

    @classmethod
    def stand_in(cls, d: int) -> GatherOrder:
        """One-element arrays of the right types for the atomic kernels (never read)."""
        one = cuda.to_device(np.zeros(1, np.int64))
        return cls(one, one, one, one, cuda.device_array((1, d + 1, d)),
                   cuda.device_array((1, d)))


class _CallSums(NamedTuple):
    """What one call's ordered sums read besides the model's :class:`GatherOrder`: the
    CSR lists of the platen nodes (by node) and of the pores' sub-contacts (by pore),
    each platen node's axis, and the slots the pores' terms go to (stand-ins when
    atomic)."""

    platen_ptr: object
    platen_slot: object
    platen_axis: object
    pore_ptr: object
    pore_slot: object
    pore_term: object
    rate_term: object


def _call_sums(ordered: bool, n_nodes: int, platens: PlatenSet, pores: PoreSpringSet,
               platen_of: np.ndarray) -> _CallSums:
    if not ordered:
        one = cuda.to_device(np.zeros(1, np.int64))
        return _CallSums(one, one, one, one, one, cuda.device_array(1), cuda.device_array(1))
    has_platens, has_pores = platens.nodes.shape[0] > 0, pores.contact.shape[0] > 0
    platen_nodes = platens.nodes.copy_to_host() if has_platens else np.zeros(0, np.int64)
    axis = platens.axis.copy_to_host() if has_platens else np.zeros(0, np.int64)
    pore = pores.pore.copy_to_host() if has_pores else np.zeros(0, np.int64)
    device = [cuda.to_device(a) for a in (*node_slots(n_nodes, platen_nodes),
                                          axis[platen_of].astype(np.int64),
                                          *node_slots(pores.held_void.shape[0], pore))]
    n_terms = max(pores.contact.shape[0], 1)
    return _CallSums(*device, cuda.device_array(n_terms), cuda.device_array(n_terms))


def fetch_cracks(cracks: CrackLog, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The first ``n`` entries of a device crack log, in the CPU backend's order
    (by step, then contact): the device appends within a step in any order."""
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    contact = cracks.contact[:n].copy_to_host()
    step = cracks.step[:n].copy_to_host()
    order = np.lexsort((contact, step))
    return contact[order], step[order]


def run_steps_cuda(control: StepControl, nodes: NodeState, loads: NodeLoads,
                   elements: Elements, element_state: ElementState, contacts: Contacts,
                   contact_state: ContactState, platens: PlatenSet, pores: PoreSpringSet,
                   energies, cracks: CrackLog, *, tpb: int = DEFAULT_TPB,
                   sync_every: int = DEFAULT_SYNC_EVERY,
                   timings: dict[str, float] | None = None, ordered: bool = True,
                   order: GatherOrder | None = None) -> tuple[int, int]:
    """Advance ``control.n_steps`` explicit steps on the GPU.

    Same semantics as :func:`grainfrac.physics.kernels.run_steps`, with every
    record's arrays on the device (:func:`to_device`) and ``energies`` the device
    float64[8] of :func:`device_energies`. Cracks are appended to the device
    ``cracks`` in any order within a step (:func:`fetch_cracks` sorts them).
    Returns (number of cracks appended, steps done); a run whose velocities
    exceed ``velocity_limit`` stops after the offending step, as on the CPU. On
    such a stop ``nodes.force`` holds zeros (atomic sums) or the step before's
    forces (ordered) rather than the last step's.

    ``ordered`` sums nodal forces and pore voids in the CPU's order (bit for bit its
    states under the simulator, reproducible on a GPU); otherwise with atomics
    (:mod:`~grainfrac.physics.cuda.device_kernels`). ``order``: the model's
    :class:`GatherOrder`, made here from the device arrays if not given.

    With ``timings`` (a dict) the host waits for the device after each stage and
    adds its wall time (s) under "elements", "contacts" (with the pores),
    "platens" and "nodes": a time split for benchmarks, slower than a plain run.
    """
    clock = _StageClock(timings)
    d = nodes.u.shape[1]
    k = step_kernels(d, tpb, ordered)
    n_steps = int(control.n_steps)
    if n_steps <= 0:
        return 0, 0
    n_nodes = nodes.u.shape[0]
    n_elements = elements.cells.shape[0]
    n_contacts = contacts.nodes.shape[0]
    n_pore_contacts = pores.contact.shape[0]
    n_platen_nodes = platens.nodes.shape[0]
    offsets = platens.offsets.copy_to_host() if platens.offsets.shape[0] else np.zeros(1, int)
    platen_of = np.repeat(np.arange(max(len(offsets) - 1, 0)), np.diff(offsets))
    work = DeviceWork(cuda.to_device(np.zeros(2, np.int64)), cuda.device_array(n_steps),
                      cuda.to_device(platen_of.astype(np.int64)))
    if not ordered:
        order = GatherOrder.stand_in(d)
    elif order is None:
        order = GatherOrder.of(n_nodes, elements.cells.copy_to_host(),
                               contacts.nodes.copy_to_host())
    sums = _call_sums(ordered, n_nodes, platens, pores, platen_of)
    cell_force, on_second, pore_term = order.cell_force, order.on_second, sums.pore_term
    k["fill"][_blocks(n_steps, tpb), tpb](work.vmax, 0.0)
    k["fill_rows"][_blocks(n_nodes, tpb), tpb](nodes.force, 0.0)
    dt = float(control.dt)
    alpha = float(control.damping)
    allow = bool(control.allow_failure)
    limit = float(control.velocity_limit)
    ge, gc, gn = _blocks(n_elements, tpb), _blocks(n_contacts, tpb), _blocks(n_nodes, tpb)
    gp, gq = _blocks(n_platen_nodes, tpb), _blocks(n_pore_contacts, tpb)
    es, cs = element_state, contact_state
    # The arguments are converted once for the cycle; each step passes its number.
    element_forces = PreparedLaunch(k["element_forces"], ge, tpb, (
        0, dt, nodes.u, elements.cells, elements.grad, elements.measure, elements.lam,
        elements.mu, es.stress, es.eigenstrain, es.eigenstrain_rate, es.initial_strain,
        nodes.force, energies, work.control, work.vmax, limit, platens.position,
        platens.velocity, platens.reaction, pores.void, cell_force), varying=(0,))
    if n_pore_contacts:
        n_pores = pores.held_void.shape[0]
        pore_void_sum = PreparedLaunch(k["pore_void_sum"], gq, tpb, (
            nodes.u, nodes.v, contacts.nodes, contacts.frame, contacts.area, pores.contact,
            pores.pore, pores.lower, pores.initial_aperture, pores.void, pores.rate,
            pore_term, sums.rate_term, work.control))
        if ordered:
            pore_sums = [PreparedLaunch(k["segment_sums"], _blocks(n_pores, tpb), tpb,
                                        (sums.pore_ptr, sums.pore_slot, term, out, work.control))
                         for term, out in ((pore_term, pores.void), (sums.rate_term, pores.rate))]
        pore_pressures = PreparedLaunch(k["pore_pressures"], _blocks(n_pores, tpb), tpb, (
            dt, pores.held_void, pores.storage, pores.ceiling, pores.resistance, pores.void,
            pores.rate, pores.dissipated, work.control))
        pore_pressure = PreparedLaunch(k["pore_pressure"], gq, tpb, (
            pores.contact, pores.pore, pores.void, cs.pressure, work.control))
    if n_contacts:
        contact_forces = PreparedLaunch(k["contact_forces"], gc, tpb, (
            0, dt, allow, nodes.u, nodes.v, nodes.force, contacts.nodes, contacts.frame,
            contacts.area, contacts.kn, contacts.ks, contacts.tan_phi, contacts.cohesion,
            contacts.tensile_strength, contacts.opening_to_fail, contacts.slip_to_fail,
            cs.bonded, cs.status, cs.sigma_n, cs.tau, cs.damage, cs.plastic_opening,
            cs.pressure, cs.released, cs.opening_offset, energies, work.control,
            cracks.contact, cracks.step, on_second), varying=(0,))
    if n_platen_nodes:
        platen_forces = PreparedLaunch(k["platen_forces"], gp, tpb, (
            platens.x, nodes.u, nodes.force, work.platen_of, platens.nodes, platens.axis,
            platens.side, platens.position, platens.stiffness, platens.reaction,
            platens.node_force, work.control))
        if ordered:
            n_platens = platens.position.shape[0]
            in_order = cuda.to_device(np.arange(n_platen_nodes, dtype=np.int64))
            platen_reactions = PreparedLaunch(k["segment_sums"], _blocks(n_platens, tpb), tpb,
                                              (platens.offsets, in_order, platens.node_force,
                                               platens.reaction, work.control))
        platen_work = PreparedLaunch(k["platen_work"], gp, tpb, (
            dt, nodes.v, work.platen_of, platens.nodes, platens.axis, platens.node_force,
            energies, work.control))
    update_nodes = PreparedLaunch(k["update_nodes"], gn, tpb, (
        0, dt, alpha, 0, nodes.u, nodes.v, nodes.force, loads.mass, loads.external,
        loads.fixed, loads.prescribed_velocity, energies, work.vmax, work.control,
        order.cell_ptr, order.cell_slot, order.contact_ptr, order.contact_slot, sums.platen_ptr,
        sums.platen_slot, cell_force, on_second, sums.platen_axis, platens.node_force),
        varying=(0, 3))
    for step in range(n_steps):
        element_forces(step)
        clock("elements")
        if n_pore_contacts:
            pore_void_sum()
            if ordered:
                for pore_sum in pore_sums:
                    pore_sum()
            pore_pressures()
            pore_pressure()
        if n_contacts:
            contact_forces(step)
        clock("contacts")
        if n_platen_nodes:
            platen_forces()
            if ordered:
                platen_reactions()
            clock("platens")
        update_nodes(step, int(step == n_steps - 1))
        clock("nodes")
        if n_platen_nodes:
            platen_work()
            clock("platens")
        if (step + 1) % sync_every == 0 and work.control.copy_to_host()[HALTED]:
            break
    state = work.control.copy_to_host()
    done = int(state[HALTED]) or n_steps
    return int(state[N_CRACKS]), done
