"""Compiled kernels of the explicit grain-contact mechanics (numba, CPU).

Kernels take named records (:mod:`grainfrac.physics.records`) of flat arrays and
numbers, never config objects, and serve both dimensions: they loop over the
dimension ``d`` and the ``d + 1`` nodes of a linear simplex (triangle in plane
strain, tetrahedron). Signs: tension positive in grains; in contacts the normal
stress ``sigma_n`` is compression positive (as in the Coulomb criterion), the
normal displacement ``u_n`` is opening positive. Units SI. Stress and strain
components follow :mod:`grainfrac.physics.elements` (Voigt order).

References: small-strain constant-strain simplices; 3DEC Coulomb slip joint with
tensile cut-off (Itasca 2022, "Joint constitutive models"); local non-viscous
damping and central differences (Cundall 1987).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from grainfrac.physics.elements import tetrahedron, triangle

# Contact status codes (also the ``mode`` of a crack).
INTACT = 0
TENSILE = 1
SHEAR = 2


# -- elements -------------------------------------------------------------------------
@njit(cache=True)
def element_forces(nodes, elements, state, force):
    """Add the cells' internal forces to ``force`` and store their stresses.

    The element kernel of the model's dimension does the work
    (:func:`grainfrac.physics.elements.triangle.internal_forces`, plane strain, or
    :func:`grainfrac.physics.elements.tetrahedron.internal_forces`).
    """
    if elements.grad.shape[2] == 2:
        triangle.internal_forces(nodes.u, elements, state, force)
    else:
        tetrahedron.internal_forces(nodes.u, elements, state, force)


@njit(cache=True)
def element_strain_energy(u, elements, state):
    """Elastic strain energy stored in the cells (J)."""
    if elements.grad.shape[2] == 2:
        return triangle.strain_energy(u, elements, state)
    return tetrahedron.strain_energy(u, elements, state)


# -- contacts -------------------------------------------------------------------------
@njit(cache=True)
def contact_law(u_n, shear, kn, ks, tan_phi, cohesion, tensile_strength, bonded,
                allow_failure, damage, plastic_opening, opening_to_fail, slip_to_fail):
    """Coulomb slip with tensile cut-off and linear softening for one sub-contact (Pa).

    The law sees the magnitude |tau| of the shear stress vector (d - 1 components);
    the caller keeps its direction. A bonded contact whose ``opening_to_fail`` /
    ``slip_to_fail`` is zero is brittle: it breaks the step its tensile or Coulomb
    strength is exceeded (3DEC's Coulomb slip joint). Otherwise it softens: one
    damage D in [0, 1) scales both strengths by (1 - D) and grows with the
    inelastic opening and slip, dD = du_p / opening_to_fail + ds_p / slip_to_fail.
    With ``opening_to_fail = 2 G_I / sigma_T`` the work of a pure opening to
    failure is the mode-I fracture energy G_I, and ``slip_to_fail = 2 G_II / c``
    gives G_II in pure shear. The inelastic opening u_p stays in the bond
    (sigma_n = -kn (u_n - u_p)); at D = 1 the bond breaks. A softened bond that
    fails in shear while in tension is counted a tensile crack.

    Parameters
    ----------
    u_n : opening displacement (m), positive when the faces separate.
    shear : magnitude of the trial shear stress, |tau_old + ks du_s| (Pa).
    kn, ks : normal and shear stiffness (Pa/m).
    tan_phi, cohesion, tensile_strength : strength (residual friction kept after failure).
    bonded : whether the bond is intact.
    allow_failure : if False, intact bonds stay elastic whatever the stress.
    damage, plastic_opening : softening state of the bond (-, m).
    opening_to_fail, slip_to_fail : inelastic opening and slip that exhaust the bond (m).

    Returns
    -------
    sigma_n, shear, new_status, slip_work_density, released_energy_density,
    softening_work_density, damage, plastic_opening
        ``sigma_n`` compression positive; ``shear`` the new magnitude |tau|;
        ``new_status`` is INTACT if nothing broke this call, else TENSILE or SHEAR;
        energies per unit area (J/m2): friction work, elastic energy released at
        the break, and work dissipated by softening this call.
    """
    sigma_n = -kn * (u_n - plastic_opening) if bonded else -kn * u_n
    tau = shear
    status = INTACT
    slip_work = 0.0
    softening_work = 0.0
    if bonded:
        if not allow_failure:
            return sigma_n, tau, INTACT, 0.0, 0.0, 0.0, damage, plastic_opening
        t_limit = (1.0 - damage) * tensile_strength
        if -sigma_n > t_limit:
            status = TENSILE
            # A softening slope steeper than kn would snap back: brittle instead.
            if opening_to_fail > 0.0 and kn * opening_to_fail > tensile_strength:
                dp = (-sigma_n - t_limit) / (kn - tensile_strength / opening_to_fail)
                d_new = damage + dp / opening_to_fail
                if d_new < 1.0:
                    status = INTACT
                    t_new = (1.0 - d_new) * tensile_strength
                    softening_work += 0.5 * (t_limit + t_new) * dp
                    damage = d_new
                    plastic_opening += dp
                    sigma_n = -t_new
        if status == INTACT:
            limit = (1.0 - damage) * cohesion + sigma_n * tan_phi
            if tau > limit:
                status = SHEAR
                if slip_to_fail > 0.0 and ks * slip_to_fail > cohesion and limit > 0.0:
                    ds = (tau - limit) / (ks - cohesion / slip_to_fail)
                    d_new = damage + ds / slip_to_fail
                    if d_new < 1.0:
                        status = INTACT
                        new_limit = (1.0 - d_new) * cohesion + sigma_n * tan_phi
                        work = 0.5 * (limit + new_limit) * ds
                        if sigma_n > 0.0:
                            slip_work = sigma_n * tan_phi * ds
                            work -= slip_work
                        softening_work += work
                        damage = d_new
                        tau = new_limit
                # A bond softened by opening loses its cohesion too; its last
                # shear slip under tension ends a mode-I crack.
                if status == SHEAR and damage > 0.0 and sigma_n < 0.0:
                    status = TENSILE
        if status == INTACT:
            return sigma_n, tau, INTACT, slip_work, 0.0, softening_work, damage, plastic_opening
        before = 0.5 * (sigma_n * sigma_n / kn + tau * tau / ks)
        # Broken: the faces meet where they were bonded; the inelastic opening goes.
        sigma_n = -kn * u_n
        damage = 1.0
        plastic_opening = 0.0
    else:
        before = 0.0
    # Unbonded (or just broken): no tension, friction only.
    if sigma_n <= 0.0:
        sigma_n = 0.0
        tau = 0.0
    else:
        limit = sigma_n * tan_phi
        if tau > limit:
            excess = tau - limit
            tau = limit
            if not bonded:
                slip_work = limit * excess / ks
    released = 0.0
    if bonded:
        after = 0.5 * (sigma_n * sigma_n / kn + tau * tau / ks)
        released = before - after
    return sigma_n, tau, status, slip_work, released, softening_work, damage, plastic_opening


@njit(cache=True, inline="always")
def relative_normal(w, a, b, frame, c):
    """(w_b - w_a) . n of contact ``c`` for a nodal field ``w`` (displacement, velocity)."""
    r = (w[b, 0] - w[a, 0]) * frame[c, 0, 0]
    for i in range(1, w.shape[1]):
        r += (w[b, i] - w[a, i]) * frame[c, 0, i]
    return r


def _contact_range_for(three):
    """:func:`contact_range` compiled for 3D (``three``) or 2D: the flag is a
    compile-time constant of the closure, so the other dimension's lines vanish."""

    @njit(cache=True)
    def contact_range_d(nodes, contacts, state, dt, allow_failure, first, stop, out,
                        failed_now):
        u, v, force = nodes.u, nodes.v, nodes.force
        pairs, frame, area_of, kn, ks_of = (contacts.nodes, contacts.frame, contacts.area,
                                            contacts.kn, contacts.ks)
        tau, sigma_n, bonded, status = state.tau, state.sigma_n, state.bonded, state.status
        damage, plastic, released = state.damage, state.plastic_opening, state.released
        friction_work = 0.0
        fluid_work = 0.0
        bond_work = 0.0
        n_failed = 0
        for c in range(first, stop):
            a = pairs[c, 0]
            b = pairs[c, 1]
            dux = u[b, 0] - u[a, 0]
            duy = u[b, 1] - u[a, 1]
            dvx = v[b, 0] - v[a, 0]
            dvy = v[b, 1] - v[a, 1]
            nx = frame[c, 0, 0]
            ny = frame[c, 0, 1]
            if three:
                tx = frame[c, 1, 0]
                ty = frame[c, 1, 1]
            else:
                # 2D frames are (n, n rotated by +90 deg) exactly (mesh.contact_frame).
                tx = -ny
                ty = nx
            u_n = dux * nx + duy * ny
            v_n = dvx * nx + dvy * ny
            v_s1 = dvx * tx + dvy * ty
            v_s2 = 0.0
            if three:
                dvz = v[b, 2] - v[a, 2]
                u_n += (u[b, 2] - u[a, 2]) * frame[c, 0, 2]
                v_n += dvz * frame[c, 0, 2]
                v_s1 += dvz * frame[c, 1, 2]
                v_s2 = dvx * frame[c, 2, 0] + dvy * frame[c, 2, 1] + dvz * frame[c, 2, 2]
            u_n -= state.opening_offset[c]
            ks = ks_of[c]
            tau1 = tau[c, 0] + ks * (v_s1 * dt)
            tau2 = tau[c, 1] + ks * (v_s2 * dt) if three else 0.0
            magnitude = math.sqrt(tau1 * tau1 + tau2 * tau2) if three else abs(tau1)
            pressure = state.pressure[c]
            area = area_of[c]
            w_fluid = pressure * area * (v_n * dt)
            sn, shear, new_status, w_slip, e_rel, w_soft, d_c, up_c = contact_law(
                u_n, magnitude, kn[c], ks, contacts.tan_phi[c], contacts.cohesion[c],
                contacts.tensile_strength[c], bonded[c], allow_failure, damage[c], plastic[c],
                contacts.opening_to_fail[c], contacts.slip_to_fail[c],
            )
            if shear != magnitude:
                # Keep the direction: the unit vector first, so in 2D tau = +-shear exactly.
                if shear == 0.0:
                    tau1 = 0.0
                    tau2 = 0.0
                else:
                    tau1 = shear * (tau1 / magnitude)
                    tau2 = shear * (tau2 / magnitude)
            damage[c] = d_c
            plastic[c] = up_c
            # A bond's energy: what softening dissipated, plus what its break released.
            bond = (w_soft + e_rel) * area
            released[c] += bond
            if new_status != INTACT:
                bonded[c] = False
                status[c] = new_status
            sigma_n[c] = sn
            tau[c, 0] = tau1
            # Traction on face b (first grain pushes b along +n when compressed).
            fn = (sn + pressure) * area
            fs1 = tau1 * area
            fx = fn * nx - fs1 * tx
            fy = fn * ny - fs1 * ty
            fz = 0.0
            if three:
                tau[c, 1] = tau2
                fs2 = tau2 * area
                fx -= fs2 * frame[c, 2, 0]
                fy -= fs2 * frame[c, 2, 1]
                fz = fn * frame[c, 0, 2] - fs1 * frame[c, 1, 2] - fs2 * frame[c, 2, 2]
            if out is None:
                fluid_work += w_fluid
                bond_work += bond
                friction_work += w_slip * area
                if new_status != INTACT:
                    failed_now[n_failed] = c
                    n_failed += 1
                if three:
                    force[b, 2] += fz
                    force[a, 2] -= fz
                force[b, 0] += fx
                force[b, 1] += fy
                force[a, 0] -= fx
                force[a, 1] -= fy
            else:
                on_second, books, broke = out
                on_second[c, 0] = fx
                on_second[c, 1] = fy
                if three:
                    on_second[c, 2] = fz
                books[c, 0] = w_slip * area
                books[c, 1] = w_fluid
                books[c, 2] = bond
                broke[c] = new_status != INTACT
        return friction_work, n_failed, fluid_work, bond_work

    return contact_range_d


_contact_range_2d = _contact_range_for(False)
_contact_range_3d = _contact_range_for(True)


@njit(cache=True)
def contact_range(nodes, contacts, state, dt, allow_failure, first, stop, out, failed_now):
    """Advance sub-contacts ``first .. stop - 1`` one step.

    Relative displacement of the second node with respect to the first:
    opening ``u_n = (u_b - u_a).n - offset``; shear increment along each tangent
    ``t_k``: ``(v_b - v_a).t_k dt``. ``opening_offset`` is the opening at which a
    contact was created (zero for grain boundaries; the wall misfit for an SCDA
    plug inserted after loading). The trial shear vector ``tau + ks du_s`` goes to
    :func:`contact_law` as its magnitude; where the law changes the magnitude the
    vector keeps its direction. A fluid pressure ``p`` pushes the two faces apart
    (force ``p A`` on each). The two shear components are scalars (the second is
    zero in 2D): loops over a runtime number of tangents made the kernel 1.5 x slower,
    and the kernel is compiled once per dimension so that the 3D-only lines cost the
    2D step nothing (a runtime test cost the 2D contact update 9 %).

    With ``out = None`` the forces are added to ``nodes.force`` (serial), broken
    contacts listed in ``failed_now``, and the step's friction work, number of
    breaks, fluid pressure work (p A du_n) and bond energy (J: softening plus the
    energy released at breaks, also added to ``released``) are returned. With
    ``out = (on_second, books, broke)`` each contact's force on its second node,
    its three works and whether it broke are stored instead (parallel chunks).
    """
    if nodes.u.shape[1] == 3:
        return _contact_range_3d(nodes, contacts, state, dt, allow_failure, first, stop,
                                 out, failed_now)
    return _contact_range_2d(nodes, contacts, state, dt, allow_failure, first, stop, out,
                             failed_now)


@njit(cache=True)
def contact_forces(nodes, contacts, state, dt, allow_failure, failed_now):
    """Add every sub-contact's spring and fluid pressure forces to ``nodes.force``.

    See :func:`contact_range`. Returns the frictional work of this step (J), the
    number of contacts that broke (listed in ``failed_now``), the work of the fluid
    pressure on the faces (J) and the bond energy of this step (J).
    """
    return contact_range(nodes, contacts, state, dt, allow_failure, 0,
                         contacts.nodes.shape[0], None, failed_now)


@njit(cache=True, parallel=True)
def contact_updates(nodes, contacts, state, dt, allow_failure, out, threads):
    """Every sub-contact's update, an equal run of contacts per each of ``threads``
    tasks (:func:`contact_range`).

    ``out = (on_second, books, broke)``: the force on each second node (for the
    gather), the step's friction / fluid / bond work per contact and whether it
    broke; the caller sums and lists them in contact order. (Tasks call a serial
    function: numba dropped the state writes of an inlined update inside ``prange``.)
    """
    n = contacts.nodes.shape[0]
    for t in prange(threads):
        contact_range(nodes, contacts, state, dt, allow_failure, t * n // threads,
                      (t + 1) * n // threads, out, out[2])


@njit(cache=True, parallel=True)
def block_element_forces(nodes, elements, state, adjacency, threads):
    """Zero ``nodes.force`` and add the cells' internal forces, a run of blocks per thread.

    Blocks share no node (:class:`grainfrac.physics.records.Adjacency`); each of
    ``threads`` tasks takes the consecutive blocks nearest its share of the cells and
    adds them in ascending order, so every node's force is bit for bit the serial
    :func:`element_forces`'. One call per thread: a call per block made the 2D
    parallel step slower than the serial one. (Each task calls a serial kernel: numba
    dropped the state writes of an inlined update inside ``prange``.)
    """
    force = nodes.force
    for n in prange(force.shape[0]):
        force[n, :] = 0.0
    blocks = adjacency.block_ptr
    cells = blocks[-1]
    for t in prange(threads):
        first = blocks[np.searchsorted(blocks, t * cells // threads)]
        stop = blocks[np.searchsorted(blocks, (t + 1) * cells // threads)]
        if elements.grad.shape[2] == 2:
            triangle.range_forces(nodes.u, elements, state, first, stop, force)
        else:
            tetrahedron.range_forces(nodes.u, elements, state, first, stop, force)


def _gather_contact_forces_for(d):
    """:func:`gather_contact_forces` compiled for ``d`` components per node (unrolled)."""

    @njit(cache=True, parallel=True)
    def gather_contact_forces_d(force, adjacency, on_second):
        ptr, slots = adjacency.contact_ptr, adjacency.contact_slot
        for i in prange(adjacency.contact_node.shape[0]):
            n = adjacency.contact_node[i]
            for j in range(ptr[i], ptr[i + 1]):
                slot = slots[j]
                # slot = 2 contact + (0 for its first node, 1 for its second)
                c = slot >> 1
                if slot & 1:
                    for k in range(d):
                        force[n, k] += on_second[c, k]
                else:
                    for k in range(d):
                        force[n, k] -= on_second[c, k]

    return gather_contact_forces_d


_gather_contact_forces_2d = _gather_contact_forces_for(2)
_gather_contact_forces_3d = _gather_contact_forces_for(3)


@njit(cache=True)
def gather_contact_forces(force, adjacency, on_second):
    """Add each sub-contact's forces into its two nodes, a node per task, in parallel.

    A node adds its contacts in ascending contact order after its cells: the order of
    the serial kernels, so the forces are bit for bit the serial step's.
    """
    if force.shape[1] == 2:
        _gather_contact_forces_2d(force, adjacency, on_second)
    else:
        _gather_contact_forces_3d(force, adjacency, on_second)


def contact_strain_energy(sigma_n, tau, kn, ks, area) -> float:
    """Elastic energy stored in the contact springs (J); ``tau`` is ``(c, d - 1)``."""
    return float(np.sum(0.5 * area * (sigma_n**2 / kn + np.sum(tau**2, axis=1) / ks)))


@njit(cache=True)
def pore_pressure(held_void, void, storage, ceiling, resistance, rate, dt):
    """One pore's pressure (Pa) at ``void`` (m3) changing at ``rate`` (m3/s), and the
    energy (J) its flow resistance dissipates over ``dt``: the spring
    ``(held_void - void) / storage`` less ``resistance x rate``, within [0, ceiling]."""
    spring = min(max((held_void - void) / storage, 0.0), ceiling)
    if resistance <= 0.0:
        return spring, 0.0
    p = min(max(spring - resistance * rate, 0.0), ceiling)
    return p, (spring - p) * rate * dt


@njit(cache=True)
def pore_spring_pressure(u, v, dt, contacts, pores, pressure):
    """Set the fluid pressure of the listed pores from their current void.

    Pore ``k``'s void is ``V = sum A max(a0 + u_n, lower)`` over its sub-contacts
    ``pores.contact`` (``initial_aperture`` = a0, per sub-contact); its pressure is
    ``(held_void[k] - V) / storage[k] - resistance[k] dV/dt``, at least 0 and at most
    ``ceiling[k]``: a spring of compliance ``storage`` about the void its fluid fills at
    zero pressure, and the pressure drop that draws (or drives) the fluid through the
    pore's pipes at the rate its void changes. ``dV/dt`` sums ``A v_n`` over the
    sub-contacts above their smallest aperture (``v`` the velocities that moved the
    nodes into ``u``). The drop's work on the grains, dissipated in the fluid, is added
    to ``pores.dissipated[0]`` (J) for steps of ``dt``.
    """
    pores.void[:] = 0.0
    pores.rate[:] = 0.0
    for j in range(pores.contact.shape[0]):
        c = pores.contact[j]
        a = contacts.nodes[c, 0]
        b = contacts.nodes[c, 1]
        u_n = relative_normal(u, a, b, contacts.frame, c)
        aperture = pores.initial_aperture[j] + u_n
        k = pores.pore[j]
        if aperture > pores.lower[j]:
            pores.rate[k] += contacts.area[c] * relative_normal(v, a, b, contacts.frame, c)
        else:
            aperture = pores.lower[j]
        pores.void[k] += contacts.area[c] * aperture
    for k in range(pores.held_void.shape[0]):
        p, dissipated = pore_pressure(pores.held_void[k], pores.void[k], pores.storage[k],
                                      pores.ceiling[k], pores.resistance[k], pores.rate[k], dt)
        pores.dissipated[0] += dissipated
        pores.void[k] = p  # the workspace now holds the pore's pressure
    for j in range(pores.contact.shape[0]):
        pressure[pores.contact[j]] = pores.void[pores.pore[j]]


# -- nodes and platens ------------------------------------------------------------------
def _update_nodes_for(d):
    """:func:`update_nodes` compiled for ``d`` components per node: a constant bound
    lets the compiler unroll the inner loop."""

    @njit(cache=True)
    def update_nodes_d(nodes, loads, dt, alpha):
        u, v, force = nodes.u, nodes.v, nodes.force
        external, fixed, mass = loads.external, loads.fixed, loads.mass
        prescribed = loads.prescribed_velocity
        w_ext = 0.0
        w_damp = 0.0
        unbalanced = 0.0
        vmax = 0.0
        for n in range(u.shape[0]):
            for i in range(d):
                f = force[n, i] + external[n, i]
                if fixed[n, i]:
                    v[n, i] = prescribed[n, i]
                    # The support's reaction balances f and works on the prescribed motion.
                    w_ext -= f * v[n, i] * dt
                else:
                    unbalanced += abs(f)
                    vn = v[n, i]
                    # branch-free sign: (vn > 0) - (vn < 0)
                    fd = -alpha * abs(f) * ((vn > 0.0) - (vn < 0.0))
                    v[n, i] = vn + dt * (f + fd) / mass[n]
                    w_damp -= fd * v[n, i] * dt
                w_ext += external[n, i] * v[n, i] * dt
                u[n, i] += dt * v[n, i]
                # not (|v| <= vmax) is also true for NaN
                if not abs(v[n, i]) <= vmax:
                    vmax = abs(v[n, i]) if abs(v[n, i]) == abs(v[n, i]) else np.inf
        return w_ext, w_damp, unbalanced, vmax

    return update_nodes_d


_update_nodes_2d = _update_nodes_for(2)
_update_nodes_3d = _update_nodes_for(3)


@njit(cache=True)
def update_nodes(nodes, loads, dt, alpha):
    """Local non-viscous damping and a central-difference step.

    F_d = -alpha |F| sign(v);  v += dt (F + F_d) / m;  u += dt v.
    ``fixed[n, i]`` holds a component at ``prescribed_velocity[n, i]``.
    Returns (boundary work of external forces and supports, damping work,
    sum |unbalanced force| over free components, max |v| (inf if NaN)) of this step.
    """
    if nodes.u.shape[1] == 2:
        return _update_nodes_2d(nodes, loads, dt, alpha)
    return _update_nodes_3d(nodes, loads, dt, alpha)


@njit(cache=True, parallel=True)
def update_nodes_parallel(nodes, loads, dt, alpha):
    """:func:`update_nodes` over the nodes in parallel: the same motion bit for bit; the
    work sums are reduced per thread, so they agree with the serial ones to round-off."""
    u, v, force = nodes.u, nodes.v, nodes.force
    external, fixed, mass = loads.external, loads.fixed, loads.mass
    w_ext = 0.0
    w_damp = 0.0
    unbalanced = 0.0
    vmax = 0.0
    for n in prange(u.shape[0]):
        for i in range(u.shape[1]):
            f = force[n, i] + external[n, i]
            vn = v[n, i]
            support = 0.0
            damp = 0.0
            free = 0.0
            if fixed[n, i]:
                vn = loads.prescribed_velocity[n, i]
                support = f * vn * dt
            else:
                free = abs(f)
                fd = -alpha * abs(f) * ((vn > 0.0) - (vn < 0.0))
                vn = vn + dt * (f + fd) / mass[n]
                damp = fd * vn * dt
            v[n, i] = vn
            w_ext += external[n, i] * vn * dt - support
            w_damp -= damp
            unbalanced += free
            u[n, i] += dt * vn
            # NaN compares false: count it as a runaway velocity.
            speed = abs(vn) if abs(vn) == abs(vn) else np.inf
            vmax = max(vmax, speed)
    return w_ext, w_damp, unbalanced, vmax


@njit(cache=True)
def platen_forces(u, platens, p, force):
    """Frictionless rigid platen ``p``: penalty force on nodes that pass its plane.

    ``side = +1`` for a platen above the specimen (pushes down), ``-1`` below.
    Stores each node's force in ``node_force`` and returns the total force the
    platen exerts on the specimen along ``axis``.
    """
    axis = platens.axis[p]
    side = platens.side[p]
    position = platens.position[p]
    total = 0.0
    for i in range(platens.offsets[p], platens.offsets[p + 1]):
        n = platens.nodes[i]
        x = platens.x[n, axis] + u[n, axis]
        pen = (x - position) * side
        f = -side * platens.stiffness[i] * pen if pen > 0.0 else 0.0
        force[n, axis] += f
        platens.node_force[i] = f
        total += f
    return total


# -- the explicit loop ---------------------------------------------------------------------
def _run_steps_for(threaded):
    """The explicit loop compiled with its threaded kernels or without them.

    ``threaded`` is a constant of the compiled loop, so a one-thread run never compiles
    the ``prange`` kernels: with an empty numba cache they were 15 s of the 2D loop's
    38 s compile, and a small 3D run's first start took 65 s against 38 s without them.
    """

    # nogil: a run's snapshot files are compressed by another thread meanwhile.
    @njit(cache=True, nogil=True)
    def run_steps_d(control, nodes, loads, elements, element_state, contacts,
                    contact_state, adjacency, platens, pores, energies, cracks):
        """Advance ``control.n_steps`` explicit steps without returning to Python.

        ``energies`` (a record of :data:`grainfrac.physics.records.ENERGY_DTYPE`)
        accumulates the work books; ``energy_removed`` is not touched here. The
        eigenstrain grows by ``eigenstrain_rate dt`` per step; the work it does on the
        body is ``-V tr(sigma) d(eigenstrain)`` over the model's axes. Broken contacts
        are appended to ``cracks`` (step index within this call). Returns (number of
        cracks appended, steps done). The loop stops early, after the offending step,
        when any velocity exceeds ``velocity_limit`` or is not finite: a blow-up is
        caught where it starts. The pores listed by ``pores`` (the free pores during
        injection, else none) have a fluid pressure that follows their void at every
        step (:func:`pore_spring_pressure`).

        Threaded (:func:`run_steps_threaded`, for ``control.threads`` above 1), the cells,
        contacts and nodes are updated on that many threads: each thread adds a run of
        grain blocks' cell forces into their nodes, contacts write theirs per contact and
        each contact node gathers them through ``adjacency`` in the serial order, so the
        motion, stresses and cracks are bit for bit those of the serial path; only the
        energy books' sums over nodes are reduced in another order (round-off).
        """
        dt = control.dt
        d = nodes.u.shape[1]
        book = energies[0]
        n_failed_total = 0
        n_contacts = contacts.nodes.shape[0]
        failed_now = np.empty(n_contacts, dtype=np.int64)
        threads = control.threads
        parallel = threaded  # a constant: the other branches are not compiled
        if parallel:
            on_second = np.empty((n_contacts, d))
            contact_books = np.empty((n_contacts, 3))
            broke = np.zeros(n_contacts, dtype=np.bool_)
        rate = element_state.eigenstrain_rate
        expanding = np.flatnonzero(rate)
        for step in range(control.n_steps):
            for i in range(expanding.shape[0]):
                e = expanding[i]
                element_state.eigenstrain[e] += rate[e] * dt
            if parallel:
                block_element_forces(nodes, elements, element_state, adjacency, threads)
            else:
                nodes.force[:, :] = 0.0
                element_forces(nodes, elements, element_state, nodes.force)
            stress = element_state.stress
            for i in range(expanding.shape[0]):
                e = expanding[i]
                trace = stress[e, 0]
                for k in range(1, d):
                    trace += stress[e, k]
                book.expansion_work -= elements.measure[e] * trace * rate[e] * dt
            if pores.contact.shape[0] > 0:
                pore_spring_pressure(nodes.u, nodes.v, dt, contacts, pores, contact_state.pressure)
            if parallel:
                contact_updates(nodes, contacts, contact_state, dt, control.allow_failure,
                                (on_second, contact_books, broke), threads)
                gather_contact_forces(nodes.force, adjacency, on_second)
                w_fric = 0.0
                w_fluid = 0.0
                w_bond = 0.0
                n_failed = 0
                for c in range(n_contacts):
                    w_fluid += contact_books[c, 1]
                    w_bond += contact_books[c, 2]
                    w_fric += contact_books[c, 0]
                    if broke[c]:
                        failed_now[n_failed] = c
                        n_failed += 1
            else:
                w_fric, n_failed, w_fluid, w_bond = contact_forces(
                    nodes, contacts, contact_state, dt, control.allow_failure, failed_now)
            for i in range(n_failed):
                cracks.contact[n_failed_total] = failed_now[i]
                cracks.step[n_failed_total] = step
                n_failed_total += 1
            book.friction_work += w_fric
            book.bond_energy_released += w_bond
            book.fluid_work += w_fluid
            for p in range(platens.axis.shape[0]):
                platens.position[p] += platens.velocity[p] * dt
                platens.reaction[p] = platen_forces(nodes.u, platens, p, nodes.force)
            if parallel:
                w_ext, w_damp, _, vmax = update_nodes_parallel(nodes, loads, dt, control.damping)
            else:
                w_ext, w_damp, _, vmax = update_nodes(nodes, loads, dt, control.damping)
            for p in range(platens.axis.shape[0]):
                ax = platens.axis[p]
                for i in range(platens.offsets[p], platens.offsets[p + 1]):
                    book.platen_work += platens.node_force[i] * nodes.v[platens.nodes[i], ax] * dt
            book.boundary_work += w_ext
            book.damping_work += w_damp
            if vmax > control.velocity_limit:
                return n_failed_total, step + 1
        return n_failed_total, control.n_steps

    return run_steps_d


run_steps = _run_steps_for(False)
run_steps_threaded = _run_steps_for(True)
