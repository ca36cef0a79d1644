"""The element layer: linear triangle and tetrahedron through the same kernels.

Patch tests (a uniform strain is reproduced and the elastic constants come back),
and the stable time step against the largest eigenvalue of M^-1 K.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from grainfrac.loading.boundary import Loads
from grainfrac.physics import kernels
from grainfrac.physics.elements import tetrahedron, triangle
from grainfrac.physics.elements.common import (
    element_row_sums,
    element_stiffness,
    lame_parameters,
)
from grainfrac.physics.model import MechanicalModel, model_from_arrays
from grainfrac.physics.solver import MechanicsSolver

QUARTZ_E, QUARTZ_NU, QUARTZ_RHO = 75.6e9, 0.096, 2650.0  # paper Table 2 (quartz grains)


def tet_block(n: int, size: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """A cube of n^3 sub-cubes, each cut into 6 right-handed tetrahedra (Kuhn split)."""
    g = np.linspace(0.0, size, n + 1)
    x = np.array(list(itertools.product(g, g, g)))  # index (i, j, k) -> i (n+1)^2 + j (n+1) + k
    def node(i, j, k):
        return (i * (n + 1) + j) * (n + 1) + k
    cells = []
    for i, j, k in itertools.product(range(n), repeat=3):
        corner = [node(i + a, j + b, k + c) for a, b, c in itertools.product((0, 1), repeat=3)]
        v0, v7 = corner[0], corner[7]
        for perm in itertools.permutations(range(3)):
            step = np.zeros(3, dtype=int)
            path = [v0]
            for axis in perm:
                step[axis] = 1
                path.append(corner[step[0] * 4 + step[1] * 2 + step[2]])
            assert path[-1] == v7
            cells.append(path)
    cells = np.array(cells)
    _, vol = tetrahedron.gradients(x, cells)
    cells[vol < 0] = cells[vol < 0][:, [0, 2, 1, 3]]  # make every one right-handed
    return x, cells


def tri_block(n: int, size: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """A square of n^2 sub-squares, each cut into 2 counter-clockwise triangles."""
    g = np.linspace(0.0, size, n + 1)
    x = np.array(list(itertools.product(g, g)))
    def node(i, j):
        return i * (n + 1) + j
    cells = []
    for i, j in itertools.product(range(n), repeat=2):
        a, b, c, d = node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)
        cells += [[a, b, c], [a, c, d]]
    return x, np.array(cells)


def single_grain_model(x, cells, *, mass_scaling=False, safety=0.5) -> MechanicalModel:
    m = len(cells)
    return model_from_arrays(
        x=x, cells=cells, youngs_modulus=np.full(m, QUARTZ_E),
        poisson_ratio=np.full(m, QUARTZ_NU), density=np.full(m, QUARTZ_RHO),
        contact_nodes=np.zeros((0, 2), np.int64), contact_frame=np.zeros((0, x.shape[1],
                                                                          x.shape[1])),
        contact_area=np.zeros(0), normal_stiffness=np.zeros(0), shear_stiffness=np.zeros(0),
        friction_angle=np.zeros(0), cohesion=np.zeros(0), tensile_strength=np.zeros(0),
        bonded=np.zeros(0, bool), thickness=1.0, mass_scaling=mass_scaling, safety=safety)


@pytest.mark.parametrize("dimension", [2, 3])
def test_patch_uniform_strain_is_reproduced_through_the_kernels(dimension):
    """Boundary nodes held on u = eps x; the free interior relaxes onto the same field."""
    x, cells = tri_block(4) if dimension == 2 else tet_block(3)
    model = single_grain_model(x, cells)
    rng = np.random.default_rng(0)
    eps = 1e-4 * rng.standard_normal((dimension, dimension))
    eps = 0.5 * (eps + eps.T)
    exact = x @ eps.T
    on_boundary = np.any((x < 1e-12) | (x > 0.01 - 1e-12), axis=1)
    loads = Loads.free(model.n_nodes, dimension)
    loads.fixed[on_boundary] = True
    solver = MechanicsSolver(model, loads, damping=0.8)
    solver.u[:] = exact
    solver.u[~on_boundary] = 0.0  # the interior starts far from the answer
    for _ in range(200):
        solver.cycle(500)
        if np.abs(solver.u - exact).max() < 1e-14 * 0.01:
            break
    err_u = np.abs(solver.u - exact).max() / np.abs(exact).max()
    lam, mu = lame_parameters(np.array([QUARTZ_E]), np.array([QUARTZ_NU]))
    expected = lam[0] * np.trace(eps) * np.eye(dimension) + 2 * mu[0] * eps
    s = solver.stress
    if dimension == 2:
        got = np.stack([[s[:, 0], s[:, 2]], [s[:, 2], s[:, 1]]])
    else:
        got = np.stack([[s[:, 0], s[:, 5], s[:, 4]], [s[:, 5], s[:, 1], s[:, 3]],
                        [s[:, 4], s[:, 3], s[:, 2]]])
    err_s = np.abs(got - expected[:, :, None]).max() / np.abs(expected).max()
    print(f"\n{dimension}D patch ({model.n_elements} cells, {int((~on_boundary).sum())} free "
          f"nodes): max |u - eps x| / max|u| {err_u:.1e}, stress error {err_s:.1e} (tol 1e-10)")
    assert (~on_boundary).sum() >= 4
    assert err_u < 1e-10
    assert err_s < 1e-10


def test_tetrahedra_recover_youngs_modulus_and_poisson_ratio():
    """Uniaxial stress: eps = (s/E, -nu s/E, -nu s/E) gives sigma = (s, 0, 0, 0, 0, 0)."""
    x, cells = tet_block(2)
    model = single_grain_model(x, cells)
    solver = MechanicsSolver(model)
    e_xx = 1e-4
    solver.u[:] = x * np.array([e_xx, -QUARTZ_NU * e_xx, -QUARTZ_NU * e_xx])
    forces = np.zeros_like(solver.u)
    kernels.element_forces(solver.node_state(), model.elements, solver.element_state(), forces)
    s = solver.stress
    youngs = s[:, 0] / e_xx
    lateral = np.abs(s[:, 1:]).max() / s[:, 0].max()
    # nu from the lateral strain that keeps the lateral stress zero: lam (exx + 2 eyy) + 2 mu eyy
    lam, mu = model.lam[0], model.mu[0]
    nu = lam / (2 * (lam + mu))
    print(f"\nE {youngs.mean() / 1e9:.6f} GPa vs {QUARTZ_E / 1e9} (spread "
          f"{np.ptp(youngs) / QUARTZ_E:.1e}); lateral / axial stress {lateral:.1e}; nu {nu:.6f}")
    assert np.allclose(youngs, QUARTZ_E, rtol=1e-10)
    assert lateral < 1e-10
    assert nu == pytest.approx(QUARTZ_NU, rel=1e-12)
    # Interior nodes of a uniform stress field carry no net force.
    interior = np.all((x > 1e-12) & (x < 0.01 - 1e-12), axis=1)
    assert np.abs(forces[interior]).max() < 1e-10 * np.abs(forces).max()


@pytest.mark.parametrize("element", [triangle, tetrahedron])
def test_stable_step_against_the_largest_eigenvalue(element):
    """The Gershgorin step is below 2 / sqrt(lambda_max(M^-1 K)) and not far below it;
    a free element vibrates stably at 0.98 of the critical step and runs away at 1.05."""
    rng = np.random.default_rng(3)
    if element is triangle:
        x = np.array([[0.0, 0.0], [2e-3, 0.0], [0.7e-3, 1.8e-3]])
    else:
        x = np.array([[0.0, 0.0, 0.0], [2e-3, 0.0, 0.0], [0.6e-3, 1.9e-3, 0.0],
                      [0.8e-3, 0.6e-3, 1.7e-3]])
    cells = np.arange(len(x))[None, :]
    model = single_grain_model(x, cells, safety=0.5)
    k = element_stiffness(model.grad, model.cell_measure, model.lam, model.mu)[0]
    m = np.repeat(model.real_mass, x.shape[1])
    lam_max = np.max(np.linalg.eigvalsh(k / np.sqrt(np.outer(m, m))))
    critical = 2.0 / np.sqrt(lam_max)
    ratio = model.dt / (model.safety * critical)
    print(f"\n{element.__name__.rsplit('.', 1)[-1]}: Gershgorin step / critical step {ratio:.3f}")
    assert 0.3 < ratio <= 1.0
    for factor, stable in ((0.98, True), (1.05, False)):
        trial = dataclasses.replace(model, dt=factor * critical)
        solver = MechanicsSolver(trial, damping=0.0, velocity_limit=1e3)
        solver.u[:] = 1e-9 * rng.standard_normal(solver.u.shape)
        try:
            solver.cycle(4000)
            grew = bool(np.abs(solver.u).max() > 1e-6)
        except Exception:  # NumericalBlowUp
            grew = True
        assert grew is (not stable), (factor, np.abs(solver.u).max())


@pytest.mark.parametrize("element", [triangle, tetrahedron])
def test_row_sums_kernel_gives_the_matrix_formula_bit_for_bit(element):
    """The stable step and the mass scaling come from the element row sums; the fast
    kernel must give the formula's values exactly, or every documented result moves."""
    rng = np.random.default_rng(5)
    d = element.DIMENSION
    if d == 3:
        x, cells = tet_block(4, 0.004)
    else:
        x = rng.uniform(0.0, 0.01, (60, 2))
        from scipy.spatial import Delaunay
        cells = Delaunay(x).simplices
    x = x + rng.normal(scale=1e-4, size=x.shape)  # irregular shapes, every sign
    grad, volume = element.gradients(x, cells)
    m = len(cells)
    lam, mu = lame_parameters(rng.uniform(20e9, 90e9, m), rng.uniform(0.05, 0.3, m))
    args = (grad, np.abs(volume), lam, mu)
    reference = np.abs(element_stiffness(*args)).sum(axis=2).reshape(grad.shape)
    assert np.array_equal(element_row_sums(*args), reference)
