"""CUDA kernels of one explicit step, one thread per element / contact / node.

The physics is not re-written here: the element stress and nodal forces
(``stress`` and ``node_force`` of :mod:`grainfrac.physics.elements.triangle` and
:mod:`~grainfrac.physics.elements.tetrahedron`), the contact kinematics
(:func:`~grainfrac.physics.kernels.relative_normal`) and the contact law
(:func:`~grainfrac.physics.kernels.contact_law`) are the CPU backend's ``@njit``
functions, which numba compiles for the device when a ``@cuda.jit`` kernel calls
them. What is here is the parallel bookkeeping: how nodal forces and pore voids
are summed, block reductions of the energy books (one atomic per block, not per
thread), an atomic crack counter and list, and a device-side stop flag for a
blow-up so that no step needs the host.

Each kernel mirrors one stage of :func:`~grainfrac.physics.kernels.run_steps`
and keeps its order of operations per element / contact / node. Sums over many
threads come in two kinds (``ordered``):

* ordered (the default): elements, contacts and platen nodes write their forces
  to their own slots, and each node adds its slots in the CPU's serial order
  (cells ascending, then contacts ascending, then platen nodes) while it is
  updated; each pore adds its sub-contacts' voids in order. Every state array is
  then the CPU backend's to the last bit under the simulator, and a GPU run is
  reproducible run to run. Only the energy books (block reductions) are summed
  in another order.
* atomic: float64 atomic adds into the nodes and pores, fewer memory passes; the
  order of the adds changes from run to run, so states differ from the CPU's by
  round-off, which a run with cracks amplifies (docs/performance.md).

Kernels are built per dimension ``d`` and block size so that the local arrays
have compile-time sizes and the reductions a power-of-two shared buffer.
"""

from __future__ import annotations

import math
from functools import cache

from numba import float64

from grainfrac.physics import kernels
from grainfrac.physics.cuda._numba import cuda, raw
from grainfrac.physics.elements import tetrahedron, triangle
from grainfrac.physics.records import ENERGY_KEYS, Elements, ElementState

# Positions of the books in the device's float64[8] view of an energy record.
E_BOUNDARY = ENERGY_KEYS.index("boundary_work")
E_DAMPING = ENERGY_KEYS.index("damping_work")
E_FRICTION = ENERGY_KEYS.index("friction_work")
E_BOND = ENERGY_KEYS.index("bond_energy_released")
E_PLATEN = ENERGY_KEYS.index("platen_work")
E_EXPANSION = ENERGY_KEYS.index("expansion_work")
E_FLUID = ENERGY_KEYS.index("fluid_work")

# Slots of the int64 control array: the step at which a blow-up stopped the run
# (0: running) and the number of cracks in the device's list.
HALTED = 0
N_CRACKS = 1

INTACT = kernels.INTACT


@cache
def step_kernels(d: int, tpb: int, ordered: bool = True):
    """The kernels for dimension ``d``, ``tpb`` threads per block (a power of 2) and
    ordered or atomic sums (module doc)."""
    if tpb & (tpb - 1):
        raise ValueError(f"threads per block must be a power of two, got {tpb}")
    n_tangents = d - 1

    @cuda.jit(device=True)
    def block_sum(buf, value):
        """Sum of ``value`` over the block, valid in thread 0 (every thread must call)."""
        t = cuda.threadIdx.x
        buf[t] = value
        cuda.syncthreads()
        s = tpb // 2
        while s > 0:
            if t < s:
                buf[t] += buf[t + s]
            cuda.syncthreads()
            s //= 2
        total = buf[0]
        cuda.syncthreads()  # the buffer is reused by the next reduction
        return total

    @cuda.jit(device=True)
    def block_max(buf, value):
        """Largest ``value`` over the block, valid in every thread."""
        t = cuda.threadIdx.x
        buf[t] = value
        cuda.syncthreads()
        s = tpb // 2
        while s > 0:
            if t < s and buf[t + s] > buf[t]:
                buf[t] = buf[t + s]
            cuda.syncthreads()
            s //= 2
        total = buf[0]
        cuda.syncthreads()
        return total

    @cuda.jit
    def fill(array, value):
        """``array[:] = value`` for a flat array."""
        i = cuda.grid(1)
        if i < array.shape[0]:
            array[i] = value

    @cuda.jit
    def fill_rows(array, value):
        """``array[:, :] = value`` for an ``(n, d)`` array, one thread a row."""
        i = cuda.grid(1)
        if i < array.shape[0]:
            for j in range(array.shape[1]):
                array[i, j] = value

    @cuda.jit
    def element_forces(step, dt, u, cells, grad, measure, lam, mu, stress, eigenstrain,
                       eigenstrain_rate, initial_strain, force, energy, control, vmax,
                       velocity_limit, platen_position, platen_velocity, platen_reaction,
                       pore_void, cell_force):
        """Eigenstrain growth, f_a = -V B_a^T sigma (into ``cell_force[e, a]`` as
        ``V B_a^T sigma`` when ordered, else added to the nodes), expansion work.

        Also the step's first work: stop if the previous step blew up (``vmax``),
        move the platens, zero their reactions and the pores' voids.
        """
        buf = cuda.shared.array(tpb, float64)
        if control[HALTED] != 0:
            return
        # The previous step's largest |v| (inf if NaN) stops the run where it started.
        if step > 0 and not vmax[step - 1] <= velocity_limit:
            if cuda.grid(1) == 0:
                control[HALTED] = step
            return
        e = cuda.grid(1)
        stride = cuda.gridsize(1)
        if e == 0:
            for p in range(platen_position.shape[0]):
                platen_position[p] += platen_velocity[p] * dt
                platen_reaction[p] = 0.0
        for k in range(e, pore_void.shape[0], stride):
            pore_void[k] = 0.0
        work = 0.0
        if e < cells.shape[0]:
            rate = eigenstrain_rate[e]
            if rate != 0.0:
                eigenstrain[e] += rate * dt
            elements = Elements(raw(cells), raw(grad), raw(measure), raw(lam), raw(mu))
            state = ElementState(raw(stress), raw(eigenstrain), raw(eigenstrain_rate),
                                 raw(initial_strain))
            # The element layer's own stress and nodal-force functions (CPU kernels too).
            if d == 2:
                sxx, syy, sxy, szz = triangle.stress(raw(u), elements, state, e)
                stress[e, 0] = sxx
                stress[e, 1] = syy
                stress[e, 2] = sxy
                stress[e, 3] = szz
                trace = sxx + syy
                for k in range(3):
                    n = cells[e, k]
                    fx, fy = triangle.node_force(elements, e, k, measure[e], sxx, syy, sxy)
                    if ordered:
                        cell_force[e, k, 0] = fx
                        cell_force[e, k, 1] = fy
                    else:
                        cuda.atomic.add(force, (n, 0), -fx)
                        cuda.atomic.add(force, (n, 1), -fy)
            else:
                sxx, syy, szz, syz, sxz, sxy = tetrahedron.stress(raw(u), elements, state, e)
                stress[e, 0] = sxx
                stress[e, 1] = syy
                stress[e, 2] = szz
                stress[e, 3] = syz
                stress[e, 4] = sxz
                stress[e, 5] = sxy
                trace = sxx + syy + szz
                for k in range(4):
                    n = cells[e, k]
                    fx, fy, fz = tetrahedron.node_force(elements, e, k, measure[e], sxx, syy,
                                                        szz, syz, sxz, sxy)
                    if ordered:
                        cell_force[e, k, 0] = fx
                        cell_force[e, k, 1] = fy
                        cell_force[e, k, 2] = fz
                    else:
                        cuda.atomic.add(force, (n, 0), -fx)
                        cuda.atomic.add(force, (n, 1), -fy)
                        cuda.atomic.add(force, (n, 2), -fz)
            if rate != 0.0:
                work = -(measure[e] * trace * rate * dt)
        total = block_sum(buf, work)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_EXPANSION, total)

    @cuda.jit
    def pore_void_sum(u, v, contact_nodes, frame, area, pore_contact, pore, lower,
                      initial_aperture, pore_void, pore_rate, pore_term, rate_term, control):
        """V_k = sum A max(a0 + u_n, lower) over pore k's sub-contacts, and its rate
        sum A v_n over those above ``lower``: each term into ``pore_term`` /
        ``rate_term`` when ordered (``segment_sums`` adds them), else atomics."""
        if control[HALTED] != 0:
            return
        j = cuda.grid(1)
        if j < pore_contact.shape[0]:
            c = pore_contact[j]
            a, b = contact_nodes[c, 0], contact_nodes[c, 1]
            aperture = initial_aperture[j] + kernels.relative_normal(raw(u), a, b, raw(frame), c)
            rate = 0.0
            if aperture > lower[j]:
                rate = area[c] * kernels.relative_normal(raw(v), a, b, raw(frame), c)
            else:
                aperture = lower[j]
            if ordered:
                pore_term[j] = area[c] * aperture
                rate_term[j] = rate
            else:
                cuda.atomic.add(pore_void, pore[j], area[c] * aperture)
                cuda.atomic.add(pore_rate, pore[j], rate)

    @cuda.jit
    def segment_sums(ptr, slot, values, out, control):
        """``out[k] = sum of values[slot[s]]`` for ``s`` from ``ptr[k]`` to ``ptr[k + 1]``,
        added in that order as the CPU does (one thread a sum): a pore's void from its
        sub-contacts' terms, a platen's reaction from its nodes' forces."""
        if control[HALTED] != 0:
            return
        k = cuda.grid(1)
        if k < out.shape[0]:
            total = 0.0
            for s in range(ptr[k], ptr[k + 1]):
                total += values[slot[s]]
            out[k] = total

    @cuda.jit
    def pore_pressures(dt, held_void, storage, ceiling, resistance, pore_void, pore_rate,
                       dissipated, control):
        """Each pore's pressure into ``pore_void`` (:func:`kernels.pore_pressure`), its
        dissipation added to ``dissipated[0]``; the rate is zeroed for the next step."""
        if control[HALTED] != 0:
            return
        k = cuda.grid(1)
        if k < held_void.shape[0]:
            p, lost = kernels.pore_pressure(held_void[k], pore_void[k], storage[k], ceiling[k],
                                            resistance[k], pore_rate[k], dt)
            if lost != 0.0:
                cuda.atomic.add(dissipated, 0, lost)
            pore_void[k] = p
            pore_rate[k] = 0.0

    @cuda.jit
    def pore_pressure(pore_contact, pore, pore_pressure_of, pressure, control):
        """Each listed sub-contact gets its pore's pressure."""
        if control[HALTED] != 0:
            return
        j = cuda.grid(1)
        if j < pore_contact.shape[0]:
            pressure[pore_contact[j]] = pore_pressure_of[pore[j]]

    @cuda.jit
    def contact_forces(step, dt, allow_failure, u, v, force, contact_nodes, frame, area, kn, ks,
                       tan_phi, cohesion, tensile_strength, opening_to_fail, slip_to_fail,
                       bonded, status, sigma_n, tau, damage, plastic_opening, pressure,
                       released, opening_offset, energy, control, crack_contact, crack_step,
                       on_second):
        """Contact springs and fluid pressure through the scalar contact law (one thread
        a sub-contact, see :func:`grainfrac.physics.kernels.contact_forces`). The force
        on the second node goes to ``on_second[c]`` when ordered, else into the nodes."""
        buf = cuda.shared.array(tpb, float64)
        if control[HALTED] != 0:
            return
        c = cuda.grid(1)
        friction = 0.0
        fluid = 0.0
        bond_work = 0.0
        if c < contact_nodes.shape[0]:
            a = contact_nodes[c, 0]
            b = contact_nodes[c, 1]
            u_n = kernels.relative_normal(raw(u), a, b, raw(frame), c) - opening_offset[c]
            du_n = kernels.relative_normal(raw(v), a, b, raw(frame), c) * dt
            k_s = ks[c]
            trial = cuda.local.array(n_tangents, float64)
            for t in range(n_tangents):
                dv = (v[b, 0] - v[a, 0]) * frame[c, 1 + t, 0]
                for i in range(1, d):
                    dv += (v[b, i] - v[a, i]) * frame[c, 1 + t, i]
                trial[t] = tau[c, t] + k_s * (dv * dt)
            if n_tangents == 1:
                magnitude = abs(trial[0])
            else:
                sq = 0.0
                for t in range(n_tangents):
                    sq += trial[t] * trial[t]
                magnitude = math.sqrt(sq)
            p = pressure[c]
            face = area[c]
            fluid = p * face * du_n
            sn, shear, new_status, w_slip, e_rel, w_soft, d_c, up_c = kernels.contact_law(
                u_n, magnitude, kn[c], k_s, tan_phi[c], cohesion[c], tensile_strength[c],
                bonded[c], allow_failure, damage[c], plastic_opening[c], opening_to_fail[c],
                slip_to_fail[c],
            )
            if shear != magnitude:
                for t in range(n_tangents):
                    trial[t] = shear * (trial[t] / magnitude) if shear != 0.0 else 0.0
            damage[c] = d_c
            plastic_opening[c] = up_c
            bond_work = (w_soft + e_rel) * face
            released[c] += bond_work
            if new_status != INTACT:
                bonded[c] = False
                status[c] = new_status
                slot = cuda.atomic.add(control, N_CRACKS, 1)
                crack_contact[slot] = c
                crack_step[slot] = step
            sigma_n[c] = sn
            for t in range(n_tangents):
                tau[c, t] = trial[t]
            friction = w_slip * face
            fn = (sn + p) * face
            for i in range(d):
                f = fn * frame[c, 0, i]
                for t in range(n_tangents):
                    f -= (trial[t] * face) * frame[c, 1 + t, i]
                if ordered:
                    on_second[c, i] = f
                else:
                    cuda.atomic.add(force, (b, i), f)
                    cuda.atomic.add(force, (a, i), -f)
        total = block_sum(buf, friction)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_FRICTION, total)
        total = block_sum(buf, fluid)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_FLUID, total)
        total = block_sum(buf, bond_work)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_BOND, total)

    @cuda.jit
    def platen_forces(x, u, force, platen_of, platen_nodes, axis, side, position, stiffness,
                      reaction, node_force, control):
        """Penalty force of the platens on the nodes past their planes
        (:func:`grainfrac.physics.kernels.platen_forces`), one thread a platen node.
        Ordered, the nodes gather ``node_force`` and ``segment_sums`` adds the reactions."""
        if control[HALTED] != 0:
            return
        i = cuda.grid(1)
        if i < platen_nodes.shape[0]:
            p = platen_of[i]
            n = platen_nodes[i]
            ax = axis[p]
            pen = (x[n, ax] + u[n, ax] - position[p]) * side[p]
            f = -side[p] * stiffness[i] * pen if pen > 0.0 else 0.0
            node_force[i] = f
            if not ordered:
                cuda.atomic.add(force, (n, ax), f)
                cuda.atomic.add(reaction, p, f)

    @cuda.jit
    def update_nodes(step, dt, alpha, keep_force, u, v, force, mass, external, fixed,
                     prescribed_velocity, energy, vmax, control, cell_ptr, cell_slot,
                     contact_ptr, contact_slot, platen_ptr, platen_slot, cell_force, on_second,
                     platen_axis, node_force):
        """Local damping and a central-difference step
        (:func:`grainfrac.physics.kernels.update_nodes`).

        Ordered, each node first adds its cells', contacts' and platen nodes' forces
        in the CPU's order (the ``*_ptr`` / ``*_slot`` lists of
        :func:`grainfrac.physics.records.node_slots`; ``platen_axis`` is the axis
        of each platen node) and keeps the sum in
        ``force``. Atomic, it reads ``force`` and zeroes it for the next step unless
        ``keep_force`` (the call's last step leaves it, as the CPU does)."""
        buf = cuda.shared.array(tpb, float64)
        if control[HALTED] != 0:
            return
        n = cuda.grid(1)
        w_ext = 0.0
        w_damp = 0.0
        v_top = 0.0
        if n < u.shape[0]:
            if ordered:
                gathered = cuda.local.array(d, float64)
                for i in range(d):
                    gathered[i] = 0.0
                for s in range(cell_ptr[n], cell_ptr[n + 1]):
                    slot = cell_slot[s]  # (d + 1) e + k
                    e = slot // (d + 1)
                    k = slot - e * (d + 1)
                    for i in range(d):
                        gathered[i] -= cell_force[e, k, i]
                for s in range(contact_ptr[n], contact_ptr[n + 1]):
                    slot = contact_slot[s]  # 2 c + (1 if the node is the second)
                    c = slot >> 1
                    for i in range(d):
                        if slot & 1:
                            gathered[i] += on_second[c, i]
                        else:
                            gathered[i] -= on_second[c, i]
                for s in range(platen_ptr[n], platen_ptr[n + 1]):
                    j = platen_slot[s]
                    gathered[platen_axis[j]] += node_force[j]
                for i in range(d):
                    force[n, i] = gathered[i]
            for i in range(d):
                f = force[n, i] + external[n, i]
                if not keep_force and not ordered:
                    force[n, i] = 0.0
                if fixed[n, i]:
                    v[n, i] = prescribed_velocity[n, i]
                    w_ext -= f * v[n, i] * dt
                else:
                    vn = v[n, i]
                    fd = -alpha * abs(f) * (int(vn > 0.0) - int(vn < 0.0))
                    v[n, i] = vn + dt * (f + fd) / mass[n]
                    w_damp -= fd * v[n, i] * dt
                w_ext += external[n, i] * v[n, i] * dt
                u[n, i] += dt * v[n, i]
                speed = abs(v[n, i])
                if not speed <= v_top:
                    v_top = speed if speed == speed else math.inf
        total = block_sum(buf, w_ext)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_BOUNDARY, total)
        total = block_sum(buf, w_damp)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_DAMPING, total)
        top = block_max(buf, v_top)
        if cuda.threadIdx.x == 0:
            cuda.atomic.max(vmax, step, top)

    @cuda.jit
    def platen_work(dt, v, platen_of, platen_nodes, axis, node_force, energy, control):
        """Work of the platens on the nodes this step: sum f v dt along each axis."""
        buf = cuda.shared.array(tpb, float64)
        if control[HALTED] != 0:
            return
        i = cuda.grid(1)
        work = 0.0
        if i < platen_nodes.shape[0]:
            work = node_force[i] * v[platen_nodes[i], axis[platen_of[i]]] * dt
        total = block_sum(buf, work)
        if cuda.threadIdx.x == 0 and total != 0.0:
            cuda.atomic.add(energy, E_PLATEN, total)

    return {
        "fill": fill, "fill_rows": fill_rows, "element_forces": element_forces,
        "pore_void_sum": pore_void_sum, "segment_sums": segment_sums,
        "pore_pressures": pore_pressures, "pore_pressure": pore_pressure,
        "contact_forces": contact_forces,
        "platen_forces": platen_forces, "update_nodes": update_nodes,
        "platen_work": platen_work,
    }
