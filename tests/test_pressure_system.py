"""The pressure system's linear solves: conjugate gradients against the factorisation."""

import numpy as np
import scipy.sparse as sp

from grainfrac.physics import flow, pressure_system
from grainfrac.physics.pressure_system import LowRank


def grain_boundary_system(n: int = 400, seed: int = 0):
    """A pressure matrix like a fracturing network's: storage of intact pores
    (1e-19 m3/Pa) and of open ones (1e-16), dt C of pipes spread over six decades,
    and two cracks whose shared opening modes are low-rank terms."""
    rng = np.random.default_rng(seed)
    storage = np.where(rng.random(n) < 0.8, 1e-19, 1e-16)
    i = rng.integers(0, n, 4 * n)
    j = (i + rng.integers(1, 30, 4 * n)) % n
    conductance = 10.0 ** rng.uniform(-22, -16, 4 * n)
    lap = sp.coo_matrix((np.concatenate((conductance, conductance, -conductance, -conductance)),
                         (np.concatenate((i, j, i, j)), np.concatenate((i, j, j, i)))),
                        shape=(n, n)).tocsr()
    a = (sp.diags(storage) + lap).tocsr()
    modes = sp.random(n, 2, density=0.2, random_state=seed, format="csc") * 1e-6
    kappa = np.array([2e-8, 5e-8])  # m3/Pa per m2 of open area squared
    pressure = rng.uniform(0.0, 2e7, n)
    low_rank = LowRank(modes, kappa)
    b = a @ pressure + low_rank @ pressure
    return a, b, low_rank, pressure


def test_conjugate_gradients_meet_the_node_tolerance_and_match_the_factorisation():
    a, b, low_rank, _ = grain_boundary_system()
    direct = pressure_system.woodbury_solve(a.tocsc(), b, low_rank)
    x = pressure_system.conjugate_gradients(a, b, low_rank, np.zeros(len(b)))
    assert x is not None
    diagonal = a.diagonal() + low_rank.diagonal()
    residual = (b - a @ x - low_rank @ x) / diagonal
    assert np.max(np.abs(residual)) <= pressure_system.PRESSURE_TOLERANCE
    # A 1 Pa Jacobi correction everywhere bounds the error by the system's conditioning;
    # on this one the pressures agree to 1e-5 of the largest.
    assert np.max(np.abs(x - direct)) < 1e-5 * np.max(np.abs(direct))


def test_a_warm_start_at_the_answer_takes_no_iteration():
    a, b, low_rank, _ = grain_boundary_system()
    direct = pressure_system.woodbury_solve(a.tocsc(), b, low_rank)
    x = pressure_system.conjugate_gradients(a, b, low_rank, direct, max_iterations=0)
    assert x is not None and np.array_equal(x, direct)


def test_solve_falls_back_to_the_factorisation_when_iterations_run_out(monkeypatch):
    a, b, low_rank, _ = grain_boundary_system()
    free = np.ones(len(b), dtype=bool)
    monkeypatch.setattr(pressure_system, "ITERATIVE_MIN_UNKNOWNS", 0)
    monkeypatch.setattr(pressure_system, "MAX_ITERATIONS", 1)
    x = pressure_system.solve_free(a, b, free, np.zeros(len(b)), low_rank)
    assert np.array_equal(x, pressure_system.woodbury_solve(a.tocsc(), b, low_rank))


def test_held_entries_are_masked_out_not_sliced_out():
    """Conjugate gradients on the whole system with some entries held give the free
    block's solution with the held values moved to the right-hand side."""
    a, b, low_rank, pressure = grain_boundary_system(seed=2)
    free = np.random.default_rng(2).random(len(b)) < 0.7
    held = ~free
    start = np.where(free, 0.0, pressure)
    x = pressure_system.conjugate_gradients(a, b, low_rank, start, free=free)
    assert x is not None and np.array_equal(x[held], pressure[held])
    direct = pressure_system.solve_free(a, b, free, start, low_rank)
    assert np.max(np.abs(x - direct)) < 1e-5 * np.max(np.abs(direct))


def test_the_active_set_solve_is_the_same_iterative_or_direct(monkeypatch):
    """The no-suction rounds with conjugate gradients end on the same dry set and the
    same pressures (within the 1 Pa tolerance) as with the factorisation."""
    a, b, low_rank, _ = grain_boundary_system(seed=1)
    rhs = b - 3e-13  # takes some nodes below zero: held dry
    n = len(rhs)
    fixed = np.zeros(n, dtype=bool)
    fixed[:5] = True
    shared = flow.SharedCompliance(sp.csr_matrix((n, n)), low_rank.modes.tocsc(),
                                   low_rank.kappa)
    direct, dry = flow._solve_without_suction(a, rhs, fixed, np.zeros(n), shared)
    assert dry.any()
    monkeypatch.setattr(pressure_system, "ITERATIVE_MIN_UNKNOWNS", 0)
    iterative, dry_iterative = flow._solve_without_suction(a, rhs, fixed, np.zeros(n), shared)
    assert np.array_equal(dry, dry_iterative)
    assert np.max(np.abs(iterative - direct)) < 1e-5 * np.max(direct)
