"""How much of kirsch3d's wall error is the linear tetrahedron: a static element study.

``grainfrac verify kirsch3d`` equilibrates the slab by dynamic relaxation; this
script solves the same slab statically (one sparse solve, smoothed-aggregation AMG
with the rigid-body modes, CG to 1e-9), so element formulations can be compared
in seconds to minutes instead of ten minutes each. The grains' contacts are
taken as rigid (the nodes of each sub-contact merged): the verification's contacts
are 100 x stiffer than Table 2, and merging them moves the wall values by about
0.01 % (seed 0: the dynamic run reads -3.8 % / +18.5 % at 0 / 90 deg, this solve
-3.82 % / +18.49 %). The wall values are read exactly as the verification reads
them (:func:`grainfrac.verification.elastic3d.wall_triangles`).

Formulations:

* ``linear``: the constant-strain tetrahedron the mechanics use;
* ``nodal-grain``: nodal-averaged volumetric strain (average nodal pressure,
  Bonet & Burton 1998; Itasca's "nodal mixed discretisation" is of this family):
  each node's volumetric strain is the volume-weighted mean of its tetrahedra's,
  within its grain, and the tetrahedra keep their own deviatoric strain;
* ``nodal-across``: the same averaged across grain boundaries too (what a
  continuum code would do; not available to a grain model, shown for scale).

Usage::

    python benchmarks/kirsch3d_elements.py --zone-size 2 --seeds 0 1 2
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import pyamg
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from grainfrac.loading.boundary3d import far_field_stress_forces3d, surface_triangles
from grainfrac.physics.elements.common import elasticity_matrix, strain_displacement
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.static_equilibrium import rigid_motions
from grainfrac.verification.elastic import kirsch_hoop_stress
from grainfrac.verification.elastic3d import (
    CASE2,
    fit_wall_hoop3d,
    homogeneous_slab3d,
    wall_triangles,
)

FORMULATIONS = ("linear", "nodal-grain", "nodal-across")
_VOLUMETRIC = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])


def stiffness(formulation: str, model, b: np.ndarray, d: np.ndarray,
              merged_cells: np.ndarray, n_merged: int) -> sp.csr_matrix:
    """Global stiffness on the merged nodes (contacts rigid), from the cells' B and D."""
    m = len(merged_cells)
    vol = model.cell_measure
    bulk = model.lam + 2.0 * model.mu / 3.0
    if formulation != "linear":  # the cells keep only their deviatoric stiffness
        d = d - bulk[:, None, None] * np.outer(_VOLUMETRIC, _VOLUMETRIC)[None]
    dof = (3 * merged_cells[:, :, None] + np.arange(3)).reshape(m, 12)
    ke = np.einsum("eik,eij,ejl->ekl", b, d, b) * vol[:, None, None]
    k = sp.csr_matrix((ke.ravel(), (np.repeat(dof, 12, axis=1).ravel(),
                                    np.tile(dof, (1, 12)).ravel())),
                      shape=(3 * n_merged, 3 * n_merged))
    if formulation == "linear":
        return k
    # Nodal volumetric strain theta_a = g_a . u / V_a with g_a = sum_e (V_e / 4) b_e and
    # V_a = sum_e V_e / 4; energy sum_a K_a V_a theta_a^2 / 2.
    owner = model.cells if formulation == "nodal-grain" else merged_cells
    n_owner = model.n_nodes if formulation == "nodal-grain" else n_merged
    quarter = np.repeat(vol / 4.0, 4)
    nodal_volume = np.bincount(owner.ravel(), quarter, minlength=n_owner)
    nodal_bulk = np.bincount(owner.ravel(), quarter * np.repeat(bulk, 4),
                             minlength=n_owner) / nodal_volume
    div = np.einsum("i,eij->ej", _VOLUMETRIC, b) * (vol / 4.0)[:, None]  # (m, 12)
    g = sp.csr_matrix((np.tile(div, (1, 4)).ravel(),
                       (np.repeat(owner, 12, axis=1).ravel(), np.tile(dof, (1, 4)).ravel())),
                      shape=(n_owner, 3 * n_merged))
    return k + g.T @ sp.diags(nodal_bulk / nodal_volume) @ g


def wall_errors(seed: int, zone_size_mm: float, formulations, plane_strain: bool,
                wall_zone_size_mm: float | None, exact: list[float]) -> None:
    """Solve the default kirsch3d slab once per formulation and print the wall rows."""
    start = time.perf_counter()
    assembly = homogeneous_slab3d(100.0, 100.0, 20.0, 10.0, seed=seed, zone_size_mm=zone_size_mm,
                                  wall_zone_size_mm=wall_zone_size_mm)
    mesh = assembly.mesh
    model = build_mechanical_model(assembly)
    pairs = model.contact_nodes
    n_merged, merged = connected_components(
        sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                      shape=(model.n_nodes, model.n_nodes)), directed=False)
    cells = merged[model.cells]
    load = np.zeros((n_merged, 3))
    np.add.at(load, merged, far_field_stress_forces3d(
        mesh, CASE2[0], CASE2[1], 0.0 if plane_strain else CASE2[2]))
    fixed = np.zeros((n_merged, 3), dtype=bool)
    if plane_strain:
        for side in ("z-", "z+"):
            fixed[merged[np.unique(surface_triangles(mesh, side)[0])], 2] = True
    free = ~fixed.ravel()
    x = np.zeros((n_merged, 3))
    x[merged] = model.x
    solid = mesh.grains.solid
    z_mid = 0.5 * float(solid.lo[2] + solid.hi[2])
    print(f"seed {seed}, {zone_size_mm:g} mm zones"
          + (f" ({wall_zone_size_mm:g} mm at the wall)" if wall_zone_size_mm else "")
          + (", plane strain" if plane_strain else "")
          + f": {model.n_elements:,} tetrahedra, {model.n_nodes:,} nodes "
          f"({n_merged:,} merged); built in {time.perf_counter() - start:.0f} s", flush=True)
    b = strain_displacement(model.grad)
    d = elasticity_matrix(model.lam, model.mu, 3)
    for formulation in formulations:
        start = time.perf_counter()
        k = stiffness(formulation, model, b, d, cells, n_merged).tocsr()[free][:, free]
        # Planar loading leaves the in-plane rigid motions free; a 1e-10 shift pins them.
        k = (k + sp.identity(k.shape[0]) * (1e-10 * k.diagonal().max())).tocsr()
        k.sum_duplicates()
        solver = pyamg.smoothed_aggregation_solver(k, B=rigid_motions(x, 3)[free],
                                                   symmetry="symmetric", max_coarse=500,
                                                   coarse_solver="splu")
        residuals: list[float] = []
        u = np.zeros(3 * n_merged)
        u[free] = solver.solve(load.ravel()[free], tol=1e-9, accel="cg", maxiter=500,
                               residuals=residuals)
        if residuals[-1] > 1e-8 * residuals[0]:
            raise RuntimeError(f"{formulation}: CG stopped at residual "
                               f"{residuals[-1] / residuals[0]:.2e}")
        wall = wall_triangles(assembly, u.reshape(n_merged, 3)[merged])
        near = np.abs(wall.z - z_mid) <= mesh.wall_zone_size
        sim = fit_wall_hoop3d(wall, near, (0.0, 90.0))
        errors = " / ".join(f"{s / 1e6:.3f} MPa ({100 * (s / e - 1):+.2f} %)"
                            for s, e in zip(sim, exact, strict=True))
        print(f"  {formulation:13s} wall 0 / 90 deg: {errors}  "
              f"[{len(residuals) - 1} CG iterations, {time.perf_counter() - start:.0f} s]",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--zone-size", type=float, default=2.0, help="mm (default 2)")
    parser.add_argument("--wall-zone-size", type=float, default=None, help="mm at the wall")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--formulations", nargs="+", choices=FORMULATIONS,
                        default=list(FORMULATIONS))
    parser.add_argument("--plane-strain", action="store_true",
                        help="top and bottom held in z, sigma_z not applied")
    args = parser.parse_args()
    # At the wall Kirsch does not depend on the radius.
    exact = [kirsch_hoop_stress(1.0, math.radians(t), 1.0, -CASE2[0], -CASE2[1])
             for t in (0.0, 90.0)]
    print(f"Kirsch at the wall, Case 2: {exact[0] / 1e6:.2f} / {exact[1] / 1e6:.2f} MPa "
          "at 0 / 90 deg")
    for seed in args.seeds:
        wall_errors(seed, args.zone_size, args.formulations, args.plane_strain,
                    args.wall_zone_size, exact)


if __name__ == "__main__":
    main()
