"""A static solve for the equilibrium of the loaded, bonded assembly.

Dynamic relaxation reaches the in-situ equilibrium of a slab in tens of thousands of
explicit steps, and hundreds of thousands on a refined one: the stress wave has to
cross the specimen many times before local damping takes its energy. With the bonds
held elastic that equilibrium is the solution of one linear system, ``K du = r``:
``K`` the grains' element stiffness plus every sub-contact's springs
(``A (kn n n^T + ks sum_k t_k t_k^T)`` between its two nodes), ``r`` the unbalanced
force of the current state (external loads plus the internal forces the explicit
kernels compute). :func:`settle` solves it, moves the nodes by ``du``, adds the shear
springs' share to the contacts' shear stresses as the explicit steps would have, and
evaluates the forces once with the same kernels: its result is judged by the same
unbalanced-force ratio as dynamic relaxation's. Contacts that the law does not keep
linear (unbonded fissures that open or slip) are springs in the solve; the explicit
steps that follow settle what that leaves.

Small systems are factorised; large ones (3D) are solved by conjugate gradients with
a smoothed-aggregation AMG preconditioner (pyamg) whose near-null space is the rigid
motions.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from grainfrac.errors import GrainfracError
from grainfrac.physics import kernels
from grainfrac.physics.elements.common import elasticity_matrix, strain_displacement
from grainfrac.physics.records import ContactState

# How an equilibrium is reached: dynamic relaxation alone, or this solve first.
METHODS = ("explicit", "static")

# Degrees of freedom from which the solve is iterative (a 2D default slab has ~8,400).
ITERATIVE_MIN_DOFS = 60_000
# Relative residual of the iterative solve: far below the 1e-5 unbalanced-force ratio
# the equilibrium is judged by.
RESIDUAL_TOLERANCE = 1e-9
# A shift of this fraction of the largest diagonal makes K definite for the
# factorisation where the loads leave rigid motions free (a slab under far-field stress
# only); refinements against K itself take its error out.
RIGID_SHIFT = 1e-10
REFINEMENTS = 8
# Conjugate-gradient iterations of one iterative solve (the 3D Kirsch slab of 214,665
# degrees of freedom takes about 260).
MAX_ITERATIONS = 2000


def check_method(method: str) -> str:
    """``method`` if it is one of :data:`METHODS`; a ``ValueError`` naming them if not."""
    if method not in METHODS:
        raise ValueError(f"equilibrium method must be one of {', '.join(METHODS)}, "
                         f"got {method!r}")
    return method


def equilibrate(solver, ratio: float, max_steps: int, method: str = "static") -> float:
    """Bring ``solver`` under its loads to an unbalanced-force ratio below ``ratio``: by
    :func:`settle` first (``method = "static"``), then by explicit steps
    (:meth:`MechanicsSolver.equilibrate`, at most ``max_steps``) while it is above.
    Returns the ratio reached."""
    check_method(method)
    achieved = settle(solver) if method == "static" else np.inf
    if not achieved < ratio:
        achieved = solver.equilibrate(ratio=ratio, max_steps=max_steps)
    return achieved


def settle(solver) -> float:
    """Move ``solver`` to the static equilibrium of its loads with the bonds held
    elastic; returns the unbalanced-force ratio reached (0 motion left).

    The energy books take the jump as dynamic relaxation would: the loads' work on
    the displacement goes into ``boundary_work`` (and the contact pressures' into
    ``fluid_work``), and what the springs do not store into ``damping_work``, the
    energy local damping would have taken on the way.
    """
    m, loads = solver.model, solver.loads
    if loads.platens:
        raise GrainfracError("a static equilibrium needs loads without platens (their "
                             "contact is one-sided); equilibrate by explicit steps")
    if np.any(loads.prescribed_velocity[loads.fixed] != 0.0):
        raise GrainfracError("a static equilibrium needs supports at rest (a prescribed "
                             "velocity moves them); equilibrate by explicit steps")
    n, d = m.n_nodes, m.dimension
    # The residual on a copy of the contact state: the law may clip unbonded shear.
    trial = ContactState(*(np.array(a) for a in solver.contact_state()))
    residual = (loads.external + internal_forces(solver, trial)).ravel()
    free = ~loads.fixed.ravel()
    k = stiffness_matrix(m)
    if not free.all():  # slicing copies the matrix twice
        k = k[free][:, free]
    du = np.zeros(n * d)
    du[free] = _solve(k, residual[free], rigid_motions(m.x, d)[free])
    du = du.reshape(n, d)
    stored_before = solver.grain_strain_energy() + solver.contact_strain_energy()
    kinetic_before = solver.kinetic_energy()
    a, b = m.contact_nodes[:, 0], m.contact_nodes[:, 1]
    relative = du[b] - du[a]
    opening = np.einsum("ci,ci->c", relative, m.contact_frame[:, 0])
    for t in range(d - 1):  # the shear springs' increments, as the steps add them
        solver.tau[:, t] += m.shear_stiffness * np.einsum("ci,ci->c", relative,
                                                          m.contact_frame[:, t + 1])
    solver.u += du
    solver.v[:] = 0.0
    internal_forces(solver)
    books = solver.energies[0]
    boundary = float(np.sum(loads.external * du))
    fluid = float(np.sum(solver.contact_pressure * m.contact_area * opening))
    stored = solver.grain_strain_energy() + solver.contact_strain_energy()
    books["boundary_work"] += boundary
    books["fluid_work"] += fluid
    books["damping_work"] += boundary + fluid + kinetic_before - (stored - stored_before)
    solver.note_state_edit()
    return solver.unbalanced_force_ratio()


def stiffness_matrix(model) -> sp.csr_matrix:
    """The assembly's stiffness ``(n d, n d)`` (N/m): elements and contact springs,
    degrees of freedom node by node."""
    n, d = model.n_nodes, model.dimension
    per_cell = (d + 1) * d
    # 32-bit indices: the 100 mm cube's 138 million element entries are its peak memory.
    index = np.int32 if n * d < 2**31 else np.int64
    cell_dof = (d * model.cells[:, :, None] + np.arange(d)).reshape(len(model.cells), -1)
    cell_dof = cell_dof.astype(index)
    # B^T (D B) as two batched products: the three-operand einsum of
    # ``element_stiffness`` took 13 s on a 3D Kirsch slab.
    b = strain_displacement(model.grad)
    db = np.matmul(elasticity_matrix(model.lam, model.mu, d), b)
    ke = np.matmul(b.transpose(0, 2, 1), db)
    del b, db
    ke *= model.cell_measure[:, None, None]
    rows = [np.repeat(cell_dof, per_cell, axis=1).ravel()]
    cols = [np.tile(cell_dof, (1, per_cell)).ravel()]
    vals = [ke.ravel()]
    frame = model.contact_frame  # (c, d, d): normal, then tangents
    spring = np.concatenate(([model.normal_stiffness], [model.shear_stiffness] * (d - 1)))
    kc = np.einsum("kc,cki,ckj->cij", spring, frame, frame) * model.contact_area[:, None, None]
    a, b = model.contact_nodes[:, 0], model.contact_nodes[:, 1]
    for first, second, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
        r = d * first[:, None, None] + np.arange(d)[None, :, None]
        c = d * second[:, None, None] + np.arange(d)[None, None, :]
        rows.append(np.broadcast_to(r, kc.shape).ravel().astype(index))
        cols.append(np.broadcast_to(c, kc.shape).ravel().astype(index))
        vals.append(sign * kc.ravel())
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n * d, n * d)).tocsr()


def internal_forces(solver, contact_state=None) -> np.ndarray:
    """The forces the explicit kernels put on the nodes in the current state
    (``solver.force`` is written), with the contacts' stresses evaluated by the law
    at no motion; ``contact_state``: the record to evaluate them in (default the
    solver's own)."""
    m = solver.model
    state = solver.contact_state() if contact_state is None else contact_state
    solver.force[:] = 0.0
    kernels.element_forces(solver.node_state(), m.elements, solver.element_state(),
                           solver.force)
    kernels.contact_forces(solver.node_state(), m.contacts, state, 0.0, False,
                           np.empty(m.n_contacts, dtype=np.int64))
    return solver.force


def _solve(k: sp.csr_matrix, r: np.ndarray, rigid: np.ndarray) -> np.ndarray:
    """``k^-1 r`` on the part of ``r`` that the rigid motions do not carry.

    Factorised: ``k`` shifted by ``RIGID_SHIFT`` of its largest diagonal is definite,
    and refinement against ``k`` itself takes the shift's error out (``shift du``, a
    ratio of 4e-6 on a 40 mm slab). Iterative: smoothed-aggregation AMG with the rigid
    motions (``rigid``) as its near-null space preconditions conjugate gradients on
    ``k`` itself, which the loads' balance keeps consistent.
    """
    if k.shape[0] < ITERATIVE_MIN_DOFS:
        shifted = k + sp.identity(k.shape[0], format="csr") * (RIGID_SHIFT * k.diagonal().max())
        solve = splu(shifted.tocsc(), permc_spec="MMD_AT_PLUS_A",
                     options={"SymmetricMode": True}).solve
    else:
        import pyamg

        amg = pyamg.smoothed_aggregation_solver(k, B=rigid, symmetry="symmetric",
                                                max_coarse=500)

        def solve(b: np.ndarray) -> np.ndarray:
            return amg.solve(b, tol=RESIDUAL_TOLERANCE, accel="cg", maxiter=MAX_ITERATIONS)
    target = RESIDUAL_TOLERANCE * np.linalg.norm(r)
    du = np.zeros_like(r)
    residual = r
    for _ in range(REFINEMENTS):
        du += solve(residual)
        residual = r - k @ du
        if np.linalg.norm(residual) <= target:
            return du
    raise GrainfracError(
        f"the static solve stopped at a relative residual "
        f"{np.linalg.norm(residual) / np.linalg.norm(r):.2e} (needed {RESIDUAL_TOLERANCE:g}) "
        f"after {REFINEMENTS} rounds; equilibrate by explicit steps")


def rigid_motions(x: np.ndarray, dimension: int) -> np.ndarray:
    """Rigid translations and rotations of nodes at ``x``, ``(n d, modes)``."""
    n = len(x)
    if dimension == 2:
        r = np.zeros((n, 2, 3))
        r[:, 0, 0] = r[:, 1, 1] = 1.0
        r[:, 0, 2], r[:, 1, 2] = -x[:, 1], x[:, 0]
        return r.reshape(-1, 3)
    r = np.zeros((n, 3, 6))
    for i in range(3):
        r[:, i, i] = 1.0
    r[:, 0, 3], r[:, 1, 3] = -x[:, 1], x[:, 0]
    r[:, 1, 4], r[:, 2, 4] = -x[:, 2], x[:, 1]
    r[:, 0, 5], r[:, 2, 5] = x[:, 2], -x[:, 0]
    return r.reshape(-1, 6)
