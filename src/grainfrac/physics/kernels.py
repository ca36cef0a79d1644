"""Compiled kernels of the explicit grain-contact mechanics (numba, CPU).

Kernels take only flat arrays and numbers, never config objects. Signs:
tension positive in grains; in contacts the normal stress ``sigma_n`` is
compression positive (as in the Coulomb criterion), the normal displacement
``u_n`` is opening positive. Units SI.

References: small-strain constant-strain triangles (plane strain);
3DEC Coulomb slip joint with tensile cut-off (Itasca 2022, "Joint constitutive
models"); local non-viscous damping and central differences (Cundall 1987).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# Contact status codes (also the ``mode`` of a crack).
INTACT = 0
TENSILE = 1
SHEAR = 2


@njit(cache=True)
def _elastic_strain(u, e, element_nodes, dndx, dndy, eigenstrain, initial_strain):
    """Elastic strain of element ``e``: B u minus its initial strain and in-plane eigenstrain."""
    exx = -initial_strain[e, 0] - eigenstrain[e]
    eyy = -initial_strain[e, 1] - eigenstrain[e]
    gxy = -initial_strain[e, 2]
    for k in range(3):
        n = element_nodes[e, k]
        exx += dndx[e, k] * u[n, 0]
        eyy += dndy[e, k] * u[n, 1]
        gxy += dndy[e, k] * u[n, 0] + dndx[e, k] * u[n, 1]
    return exx, eyy, gxy


@njit(cache=True)
def element_forces(u, element_nodes, dndx, dndy, area, lam, mu, thickness, force, stress,
                   eigenstrain, initial_strain):
    """Add plane-strain internal forces of linear triangles to ``force``; store stresses.

    eps = B u - eps0 - e_x I, where ``initial_strain`` eps0 = (xx, yy, xy
    engineering) lets a body inserted into a loaded specimen start stress-free
    and the isotropic in-plane ``eigenstrain`` e_x drives SCDA expansion;
    sigma = lam tr(eps) I + 2 mu eps;  f_a = -A t B_a^T sigma.
    ``stress[e] = (sxx, syy, sxy, szz)``.
    """
    for e in range(element_nodes.shape[0]):
        exx, eyy, gxy = _elastic_strain(u, e, element_nodes, dndx, dndy, eigenstrain,
                                        initial_strain)
        tr = lam[e] * (exx + eyy)
        sxx = tr + 2.0 * mu[e] * exx
        syy = tr + 2.0 * mu[e] * eyy
        sxy = mu[e] * gxy
        stress[e, 0] = sxx
        stress[e, 1] = syy
        stress[e, 2] = sxy
        stress[e, 3] = tr
        at = area[e] * thickness
        for k in range(3):
            n = element_nodes[e, k]
            force[n, 0] -= at * (dndx[e, k] * sxx + dndy[e, k] * sxy)
            force[n, 1] -= at * (dndx[e, k] * sxy + dndy[e, k] * syy)


@njit(cache=True)
def contact_law(u_n, du_s, tau_old, kn, ks, tan_phi, cohesion, tensile_strength, bonded,
                allow_failure, damage, plastic_opening, opening_to_fail, slip_to_fail):
    """Coulomb slip with tensile cut-off and linear softening for one sub-contact (Pa).

    A bonded contact whose ``opening_to_fail`` / ``slip_to_fail`` is zero is
    brittle: it breaks the step its tensile or Coulomb strength is exceeded
    (3DEC's Coulomb slip joint). Otherwise it softens: one damage D in [0, 1)
    scales both strengths by (1 - D) and grows with the inelastic opening and
    slip, dD = du_p / opening_to_fail + ds_p / slip_to_fail. With
    ``opening_to_fail = 2 G_I / sigma_T`` the work of a pure opening to failure
    is the mode-I fracture energy G_I, and ``slip_to_fail = 2 G_II / c`` gives
    G_II in pure shear. The inelastic opening u_p stays in the bond
    (sigma_n = -kn (u_n - u_p)); at D = 1 the bond breaks. A softened bond that
    fails in shear while in tension is counted a tensile crack.

    Parameters
    ----------
    u_n : opening displacement (m), positive when the faces separate.
    du_s : shear displacement increment of this step (m).
    tau_old : shear stress of the previous step (Pa).
    kn, ks : normal and shear stiffness (Pa/m).
    tan_phi, cohesion, tensile_strength : strength (residual friction kept after failure).
    bonded : whether the bond is intact.
    allow_failure : if False, intact bonds stay elastic whatever the stress.
    damage, plastic_opening : softening state of the bond (-, m).
    opening_to_fail, slip_to_fail : inelastic opening and slip that exhaust the bond (m).

    Returns
    -------
    sigma_n, tau, new_status, slip_work_density, released_energy_density,
    softening_work_density, damage, plastic_opening
        ``sigma_n`` compression positive; ``new_status`` is INTACT if nothing
        broke this call, else TENSILE or SHEAR; energies per unit area (J/m2):
        friction work, elastic energy released at the break, and work dissipated
        by softening this call.
    """
    sigma_n = -kn * (u_n - plastic_opening) if bonded else -kn * u_n
    tau = tau_old + ks * du_s
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
            if abs(tau) > limit:
                status = SHEAR
                if slip_to_fail > 0.0 and ks * slip_to_fail > cohesion and limit > 0.0:
                    ds = (abs(tau) - limit) / (ks - cohesion / slip_to_fail)
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
                        tau = new_limit if tau > 0.0 else -new_limit
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
        if abs(tau) > limit:
            excess = abs(tau) - limit
            tau = limit if tau > 0.0 else -limit
            if not bonded:
                slip_work = limit * excess / ks
    released = 0.0
    if bonded:
        after = 0.5 * (sigma_n * sigma_n / kn + tau * tau / ks)
        released = before - after
    return sigma_n, tau, status, slip_work, released, softening_work, damage, plastic_opening


@njit(cache=True)
def contact_forces(
    u, v, dt, contact_nodes, normal, tangent, contact_area,
    kn, ks, tan_phi, cohesion, tensile_strength, opening_to_fail, slip_to_fail,
    bonded, status, sigma_n, tau, damage, plastic_opening, pressure_on_contact,
    released, force, failed_now, allow_failure, opening_offset,
):
    """Add contact spring forces and fluid pressure forces to ``force``.

    Relative displacement of the second node with respect to the first:
    opening ``u_n = (u_b - u_a).n - offset``; shear increment ``(v_b - v_a).t dt``.
    ``opening_offset`` is the opening at which a contact was created (zero for
    grain boundaries; the wall misfit for an SCDA plug inserted after loading).
    A fluid pressure ``p`` pushes the two faces apart (force ``p A`` on each).
    Returns the frictional work of this step (J), the number of contacts that
    broke, the work of the fluid pressure on the faces (J, p A du_n) and the
    bond energy of this step (J: dissipated by softening and released at
    breaks), which is also added per contact to ``released``.
    """
    friction_work = 0.0
    fluid_work = 0.0
    bond_work = 0.0
    n_failed = 0
    for c in range(contact_nodes.shape[0]):
        a = contact_nodes[c, 0]
        b = contact_nodes[c, 1]
        nx = normal[c, 0]
        ny = normal[c, 1]
        tx = tangent[c, 0]
        ty = tangent[c, 1]
        u_n = (u[b, 0] - u[a, 0]) * nx + (u[b, 1] - u[a, 1]) * ny - opening_offset[c]
        du_s = ((v[b, 0] - v[a, 0]) * tx + (v[b, 1] - v[a, 1]) * ty) * dt
        du_n = ((v[b, 0] - v[a, 0]) * nx + (v[b, 1] - v[a, 1]) * ny) * dt
        fluid_work += pressure_on_contact[c] * contact_area[c] * du_n
        sn, ts, new_status, w_slip, e_rel, w_soft, d_c, up_c = contact_law(
            u_n, du_s, tau[c], kn[c], ks[c], tan_phi[c], cohesion[c],
            tensile_strength[c], bonded[c], allow_failure, damage[c], plastic_opening[c],
            opening_to_fail[c], slip_to_fail[c],
        )
        damage[c] = d_c
        plastic_opening[c] = up_c
        # A bond's energy: what softening dissipated, plus what its break released.
        bond = (w_soft + e_rel) * contact_area[c]
        released[c] += bond
        bond_work += bond
        if new_status != INTACT:
            bonded[c] = False
            status[c] = new_status
            failed_now[n_failed] = c
            n_failed += 1
        sigma_n[c] = sn
        tau[c] = ts
        friction_work += w_slip * contact_area[c]
        # Traction on face b (first grain pushes b along +n when compressed).
        fn = (sn + pressure_on_contact[c]) * contact_area[c]
        fs = ts * contact_area[c]
        fx = fn * nx - fs * tx
        fy = fn * ny - fs * ty
        force[b, 0] += fx
        force[b, 1] += fy
        force[a, 0] -= fx
        force[a, 1] -= fy
    return friction_work, n_failed, fluid_work, bond_work


@njit(cache=True)
def update_nodes(u, v, force, external, mass, dt, alpha, fixed, prescribed_velocity):
    """Local non-viscous damping and a central-difference step.

    F_d = -alpha |F| sign(v);  v += dt (F + F_d) / m;  u += dt v.
    ``fixed[n, d]`` holds a component at ``prescribed_velocity[n, d]``.
    Returns (boundary work of external forces and supports, damping work,
    sum |unbalanced force| over free components, max |v| (inf if NaN)) of this step.
    """
    w_ext = 0.0
    w_damp = 0.0
    unbalanced = 0.0
    vmax = 0.0
    for n in range(u.shape[0]):
        for d in range(2):
            f = force[n, d] + external[n, d]
            if fixed[n, d]:
                v[n, d] = prescribed_velocity[n, d]
                # The support's reaction balances f and works on the prescribed motion.
                w_ext -= f * v[n, d] * dt
            else:
                unbalanced += abs(f)
                vn = v[n, d]
                # branch-free sign: (vn > 0) - (vn < 0)
                fd = -alpha * abs(f) * ((vn > 0.0) - (vn < 0.0))
                v[n, d] = vn + dt * (f + fd) / mass[n]
                w_damp -= fd * v[n, d] * dt
            w_ext += external[n, d] * v[n, d] * dt
            u[n, d] += dt * v[n, d]
            # not (|v| <= vmax) is also true for NaN
            if not abs(v[n, d]) <= vmax:
                vmax = abs(v[n, d]) if abs(v[n, d]) == abs(v[n, d]) else np.inf
    return w_ext, w_damp, unbalanced, vmax


@njit(cache=True)
def platen_forces(u, node_xy, nodes, axis, side, position, stiffness, force, node_force):
    """Frictionless rigid platen: penalty force on nodes that pass its plane.

    ``side = +1`` for a platen above the specimen (pushes down), ``-1`` below.
    Stores each node's force in ``node_force`` and returns the total force the
    platen exerts on the specimen along ``axis``.
    """
    total = 0.0
    for i in range(nodes.shape[0]):
        n = nodes[i]
        x = node_xy[n, axis] + u[n, axis]
        pen = (x - position) * side
        f = -side * stiffness[i] * pen if pen > 0.0 else 0.0
        force[n, axis] += f
        node_force[i] = f
        total += f
    return total


@njit(cache=True)
def element_strain_energy(u, element_nodes, dndx, dndy, area, lam, mu, thickness,
                          eigenstrain, initial_strain):
    """Elastic strain energy stored in the elements (J)."""
    total = 0.0
    for e in range(element_nodes.shape[0]):
        exx, eyy, gxy = _elastic_strain(u, e, element_nodes, dndx, dndy, eigenstrain,
                                        initial_strain)
        tr = lam[e] * (exx + eyy)
        w = 0.5 * ((tr + 2.0 * mu[e] * exx) * exx + (tr + 2.0 * mu[e] * eyy) * eyy
                   + mu[e] * gxy * gxy)
        total += w * area[e] * thickness
    return total


def contact_strain_energy(sigma_n, tau, kn, ks, area) -> float:
    """Elastic energy stored in the contact springs (J)."""
    return float(np.sum(0.5 * area * (sigma_n**2 / kn + tau**2 / ks)))


@njit(cache=True)
def pore_spring_pressure(u, contact_nodes, normal, contact_area, pore_contact, contact_pore,
                         pore_contact_lower, initial_aperture, pore_held_void, pore_storage,
                         pore_ceiling, pore_void, pressure_on_contact):
    """Set the fluid pressure of the listed pores from their current void.

    Pore ``k``'s void is ``V = sum A max(a0 + u_n, lower)`` over its
    sub-contacts ``pore_contact`` (``initial_aperture`` = a0); its
    pressure is ``max(0, (pore_held_void[k] - V) / pore_storage[k])``, at most
    ``pore_ceiling[k]``: a spring of compliance ``pore_storage`` about the void
    its fluid fills at zero pressure. ``pore_void`` is workspace.
    """
    pore_void[:] = 0.0
    for j in range(pore_contact.shape[0]):
        c = pore_contact[j]
        a = contact_nodes[c, 0]
        b = contact_nodes[c, 1]
        u_n = (u[b, 0] - u[a, 0]) * normal[c, 0] + (u[b, 1] - u[a, 1]) * normal[c, 1]
        aperture = max(initial_aperture + u_n, pore_contact_lower[j])
        pore_void[contact_pore[j]] += contact_area[c] * aperture
    for j in range(pore_contact.shape[0]):
        k = contact_pore[j]
        pressure_on_contact[pore_contact[j]] = min(max(
            (pore_held_void[k] - pore_void[k]) / pore_storage[k], 0.0), pore_ceiling[k])


@njit(cache=True)
def run_steps(
    n_steps, dt, alpha, u, v, force, stress, external, mass, fixed, prescribed_velocity,
    element_nodes, dndx, dndy, area, lam, mu, thickness,
    contact_nodes, normal, tangent, contact_area, kn, ks, tan_phi, cohesion,
    tensile_strength, opening_to_fail, slip_to_fail, bonded, status, sigma_n, tau, damage,
    plastic_opening, pressure_on_contact, released,
    platen_node_xy, platen_nodes, platen_offsets, platen_axis, platen_side,
    platen_position, platen_velocity, platen_stiffness, platen_reaction, platen_node_force,
    failed_contact, failed_step, energies, allow_failure, velocity_limit,
    eigenstrain, eigenstrain_rate, initial_strain, opening_offset,
    pore_contact, contact_pore, pore_contact_lower, initial_aperture, pore_held_void,
    pore_storage, pore_ceiling, pore_void,
):
    """Advance ``n_steps`` explicit steps without returning to Python.

    ``energies`` accumulates [external work, damping work, friction work,
    bond energy (released at breaks and dissipated by softening), platen work,
    expansion work, fluid work, energy removed (not touched here)]. The eigenstrain grows
    by ``eigenstrain_rate dt`` per step; the work it does on the body is
    ``-A t (sxx + syy) d(eigenstrain)``. Broken contacts are appended to
    ``failed_contact`` / ``failed_step`` (step index within this call).
    Returns (number of cracks appended, steps done). The loop stops early,
    after the offending step, when any velocity exceeds ``velocity_limit`` or
    is not finite: a blow-up is caught where it starts. The pores listed by
    ``pore_contact`` (the free pores during injection, else none) have a fluid
    pressure that follows their void at every step (:func:`pore_spring_pressure`).
    """
    n_failed_total = 0
    failed_now = np.empty(contact_nodes.shape[0], dtype=np.int64)
    expanding = np.flatnonzero(eigenstrain_rate)
    for step in range(n_steps):
        for i in range(expanding.shape[0]):
            e = expanding[i]
            eigenstrain[e] += eigenstrain_rate[e] * dt
        force[:, :] = 0.0
        element_forces(u, element_nodes, dndx, dndy, area, lam, mu, thickness, force, stress,
                       eigenstrain, initial_strain)
        for i in range(expanding.shape[0]):
            e = expanding[i]
            energies[5] -= (area[e] * thickness * (stress[e, 0] + stress[e, 1])
                            * eigenstrain_rate[e] * dt)
        if pore_contact.shape[0] > 0:
            pore_spring_pressure(u, contact_nodes, normal, contact_area, pore_contact,
                                 contact_pore, pore_contact_lower, initial_aperture,
                                 pore_held_void, pore_storage, pore_ceiling, pore_void,
                                 pressure_on_contact)
        w_fric, n_failed, w_fluid, w_bond = contact_forces(
            u, v, dt, contact_nodes, normal, tangent, contact_area, kn, ks, tan_phi, cohesion,
            tensile_strength, opening_to_fail, slip_to_fail, bonded, status, sigma_n, tau,
            damage, plastic_opening, pressure_on_contact, released, force, failed_now,
            allow_failure, opening_offset,
        )
        for i in range(n_failed):
            c = failed_now[i]
            failed_contact[n_failed_total] = c
            failed_step[n_failed_total] = step
            n_failed_total += 1
        energies[2] += w_fric
        energies[3] += w_bond
        energies[6] += w_fluid
        for p in range(platen_axis.shape[0]):
            lo = platen_offsets[p]
            hi = platen_offsets[p + 1]
            platen_position[p] += platen_velocity[p] * dt
            platen_reaction[p] = platen_forces(
                u, platen_node_xy, platen_nodes[lo:hi], platen_axis[p], platen_side[p],
                platen_position[p], platen_stiffness[lo:hi], force, platen_node_force[lo:hi],
            )
        w_ext, w_damp, _, vmax = update_nodes(u, v, force, external, mass, dt, alpha, fixed,
                                              prescribed_velocity)
        for p in range(platen_axis.shape[0]):
            ax = platen_axis[p]
            for i in range(platen_offsets[p], platen_offsets[p + 1]):
                energies[4] += platen_node_force[i] * v[platen_nodes[i], ax] * dt
        energies[0] += w_ext
        energies[1] += w_damp
        if vmax > velocity_limit:
            return n_failed_total, step + 1
    return n_failed_total, n_steps
