"""The pressure system ``(A + modes diag(kappa) modes^T) x = b``: its pipe Laplacian and
its linear solves.

``A`` (storage plus a graph Laplacian, plus the explicit blocks of small cracks) is
symmetric positive definite, and so is the low-rank term of the large cracks' shared
opening modes (:class:`grainfrac.physics.flow.SharedCompliance`). Small systems are
factorised (SuperLU, with the modes by the Sherman-Morrison-Woodbury identity); large
ones are solved by conjugate gradients with a Jacobi preconditioner, started from the
last pressures.

Why the switch: a sparse direct factorisation of a 3D grain-boundary network fills
badly. The 100 mm cube's network (61,295 unknowns) took 6.6 s to factorise once, and a
fluid step factorises once per round of the active set, against 42 ms of explicit
mechanics per fluid step on an H100. Its matrix is dominated by the pores' storage and
compliance, so conjugate gradients started from the last step's pressures converge in
tens of iterations: replayed on 30 fluid steps of a 50 mm cube (8,869 unknowns), 2.3
ms a solve against 116 ms factorised; on the cube's network ~16 iterations a step.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from grainfrac.physics.coupling_kernels import laplacian_data

# Systems of at least this many free unknowns are solved iteratively. Below it the
# factorisation is cheap (a 3D 100 x 100 x 20 mm slab's 12,473 unknowns), and every
# documented result of the smaller specimens stays as the direct solve gave it.
ITERATIVE_MIN_UNKNOWNS = 20_000
# Conjugate gradients stop when no node's residual (a fluid volume, m3) is more than
# this pressure (Pa) times its diagonal (its storage plus its pipes' dt C): the
# pressure correction one more Jacobi sweep would make is below it everywhere. The
# same 1 Pa as the active set's release test (flow._solve_without_suction). The
# fluid's volume balance does not depend on it: content changes by the flows of the
# pressures solved, whatever they are.
PRESSURE_TOLERANCE = 1.0  # Pa
# Iterations before the solve falls back to a factorisation.
MAX_ITERATIONS = 5000


def laplacian(n: int, ends: np.ndarray, cond: np.ndarray) -> sp.csr_matrix:
    """The graph Laplacian (n x n) of the pipes ``ends`` (k, 2) with conductances ``cond``.

    Once the same pipes come twice in a row, their pattern is kept while they stay
    (:class:`_LaplacianPattern`): converting the entries to a sparse matrix anew took
    28 ms of the 100 mm cube's ~100 ms of host work per fluid step, the kept pattern
    9 ms.
    """
    global _last_pipes, _last_pattern
    # Read once: runs in threads of one process (a Dask worker's) swap these references.
    pattern, pipes = _last_pattern, _last_pipes
    if pattern is not None and pattern.serves(n, ends):
        return pattern.matrix(cond)
    if pipes is not None and pipes[0] == n and np.array_equal(pipes[1], ends):
        pattern = _last_pattern = _LaplacianPattern(n, ends)
        return pattern.matrix(cond)
    _last_pipes = (n, np.array(ends))
    return _converted_laplacian(n, ends, cond)


def _converted_laplacian(n: int, ends: np.ndarray, cond: np.ndarray) -> sp.csr_matrix:
    """The Laplacian by scipy's conversion of its entries (the reference)."""
    values, rows, cols = _laplacian_entries(ends, cond)
    return sp.coo_matrix((values, (rows, cols)), shape=(n, n)).tocsr()


def _laplacian_entries(ends: np.ndarray, cond: np.ndarray):
    """The Laplacian's (value, row, column) entries, duplicates included."""
    i, j = ends[:, 0], ends[:, 1]
    return (np.concatenate((cond, cond, -cond, -cond)),
            np.concatenate((i, j, i, j)), np.concatenate((i, j, j, i)))


class _LaplacianPattern:
    """Where each Laplacian entry lands in the sparse matrix, and in which order the
    entries of a position are added: scipy's own (rows in input order, then its sort
    of each row's columns, then duplicates added left to right), so that the matrix
    is scipy's conversion bit for bit. That is checked when the pattern is made; a
    scipy that converts otherwise makes the pattern fall back to its conversion."""

    def __init__(self, n: int, ends: np.ndarray):
        self.n, self.ends = n, np.array(ends)
        _, rows, cols = _laplacian_entries(self.ends, np.ones(len(self.ends)))
        # Rows in input order (a stable sort), then scipy's sort within each row,
        # carried out on the entries' numbers to learn where each one goes.
        by_row = np.argsort(rows, kind="stable")
        indptr = np.concatenate(([0], np.cumsum(np.bincount(rows, minlength=n))))
        unsorted = sp.csr_matrix((by_row.astype(float), cols[by_row], indptr), shape=(n, n))
        unsorted.has_sorted_indices = False
        unsorted.sort_indices()
        self.order = unsorted.data.astype(np.int64)
        row_of = np.repeat(np.arange(n), np.diff(unsorted.indptr))
        new = np.ones(len(self.order), dtype=bool)
        new[1:] = (unsorted.indices[1:] != unsorted.indices[:-1]) | (row_of[1:] != row_of[:-1])
        self.slot = np.cumsum(new) - 1
        self.indices = unsorted.indices[new]
        self.indptr = np.concatenate(([0], np.cumsum(np.bincount(row_of[new], minlength=n))))
        probe = np.random.default_rng(0).uniform(0.5, 2.0, len(self.ends))
        self.exact = True
        reference = _converted_laplacian(n, self.ends, probe)
        mine = self.matrix(probe)
        self.exact = all(np.array_equal(getattr(mine, a), getattr(reference, a))
                         for a in ("indptr", "indices", "data"))

    def serves(self, n: int, ends: np.ndarray) -> bool:
        return n == self.n and (ends is self.ends or np.array_equal(ends, self.ends))

    def matrix(self, cond: np.ndarray) -> sp.csr_matrix:
        if not self.exact:
            return _converted_laplacian(self.n, self.ends, cond)
        data = laplacian_data(np.asarray(cond, dtype=float), self.order, self.slot,
                              len(self.indices))
        out = sp.csr_matrix((data, self.indices.copy(), self.indptr.copy()),
                            shape=(self.n, self.n))
        out.has_canonical_format = True
        return out


# The pipes of the last Laplacian made without a pattern, and the pattern in use.
_last_pipes: tuple[int, np.ndarray] | None = None
_last_pattern: _LaplacianPattern | None = None


class LowRank:
    """``modes diag(kappa) modes^T`` (modes sparse n x K, kappa K)."""

    def __init__(self, modes: sp.spmatrix, kappa: np.ndarray):
        self.modes = modes
        self.kappa = np.asarray(kappa, dtype=float)

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        return self.modes @ (self.kappa * (self.modes.T @ x))

    def diagonal(self) -> np.ndarray:
        return self.modes.multiply(self.modes) @ self.kappa


def solve_free(a: sp.csr_matrix, b: np.ndarray, free: np.ndarray, p: np.ndarray,
               low_rank: LowRank | None = None, diagonal: np.ndarray | None = None
               ) -> np.ndarray:
    """``p`` with its ``free`` entries solved from ``(a + low_rank) p = b`` on the free
    rows and its other entries held as given.

    From ``ITERATIVE_MIN_UNKNOWNS`` free unknowns up by :func:`conjugate_gradients`
    on the whole system (the held entries masked, starting from ``p``; ``diagonal``,
    the system's, if the caller has it), else (or if they do not converge) by a
    factorisation of the free block.
    """
    if np.count_nonzero(free) >= ITERATIVE_MIN_UNKNOWNS:
        x = conjugate_gradients(a, b, low_rank, p, free=free, diagonal=diagonal,
                                max_iterations=MAX_ITERATIONS)
        if x is not None:
            return x
    held = ~free
    rows = a[free]
    a_ff = sp.csc_matrix(rows[:, free])
    b_f = b[free] - rows[:, held] @ p[held]
    out = p.copy()
    if low_rank is None:
        out[free] = factorised(a_ff).solve(b_f)
    else:
        modes = low_rank.modes
        b_f -= modes[free] @ (low_rank.kappa * (modes[held].T @ p[held]))
        out[free] = woodbury_solve(a_ff, b_f, LowRank(modes[free], low_rank.kappa))
    return out


def factorised(a: sp.csc_matrix):
    """SuperLU factors of a pressure system, which is symmetric: ordered by minimum degree
    on A + A^T with diagonal pivots. On a 3D slab's grain-face network (12,473 unknowns)
    L + U hold 1.28 million entries against 2.48 million with SuperLU's default column
    ordering (COLAMD); the 100 mm cube's first injection step (61,295 unknowns, the whole
    network conducting) took 6.6 s against 16.5 s, to the same well pressure."""
    return splu(a, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True})


def woodbury_solve(a: sp.csc_matrix, b: np.ndarray, low_rank: LowRank) -> np.ndarray:
    """``(a + modes diag(kappa) modes^T)^-1 b`` by the Sherman-Morrison-Woodbury identity:
    ``y - Z (diag(1/kappa) + modes^T Z)^-1 modes^T y`` with ``y = a^-1 b`` and
    ``Z = a^-1 modes``; one factorisation of the sparse ``a``."""
    lu = factorised(a)
    y = lu.solve(b)
    modes = low_rank.modes
    used = np.flatnonzero(modes.getnnz(axis=0))  # cracks with a node in this system
    if len(used) == 0:
        return y
    u = modes[:, used].toarray()
    z = lu.solve(u)
    capacitance = np.diag(1.0 / low_rank.kappa[used]) + u.T @ z
    return y - z @ np.linalg.solve(capacitance, u.T @ y)


def conjugate_gradients(a: sp.csr_matrix, b: np.ndarray, low_rank: LowRank | None,
                        guess: np.ndarray, free: np.ndarray | None = None,
                        diagonal: np.ndarray | None = None,
                        tolerance: float = PRESSURE_TOLERANCE,
                        max_iterations: int = MAX_ITERATIONS) -> np.ndarray | None:
    """Jacobi-preconditioned conjugate gradients from ``guess``; None if the residual
    test (``PRESSURE_TOLERANCE``, per node) is not met in ``max_iterations``.

    ``free`` (bool), if given: only those entries are solved for, on their rows; the
    others keep their ``guess`` values (``diagonal``: the system's, found here if not
    given). The search directions are zero there, so this
    is conjugate gradients on the free block without slicing it out (which cost more
    than the iterations on the 100 mm cube).

    Written out rather than scipy's ``cg`` for its stopping test: a norm of the
    residual lets the nodes of small storage (intact pores, 1e-19 m3/Pa) keep
    pressure errors that the crack nodes' large residuals hide.
    """
    def apply(x):
        return a @ x if low_rank is None else a @ x + low_rank @ x

    mask = np.ones(len(b)) if free is None else free.astype(float)
    if diagonal is None:
        diagonal = a.diagonal() if low_rank is None else a.diagonal() + low_rank.diagonal()
    x = np.array(guess, dtype=float)
    r = (b - apply(x)) * mask
    z = r / diagonal
    if np.max(np.abs(z), initial=0.0) <= tolerance:
        return x
    d = z.copy()
    rz = r @ z
    for _ in range(max_iterations):
        q = apply(d) * mask
        alpha = rz / (d @ q)
        x += alpha * d
        r -= alpha * q
        z = r / diagonal
        if np.max(np.abs(z)) <= tolerance:
            # The recurrence's residual drifts from the true one over many iterations.
            if np.max(np.abs((b - apply(x)) * mask / diagonal)) <= tolerance:
                return x
        rz_next = r @ z
        d = z + (rz_next / rz) * d
        rz = rz_next
    return None
