"""Elastic verification in 3D: uniform stress (patch), pressurised hole (Lame), Kirsch.

Every case builds a 3D slab (:class:`~grainfrac.assembly.SpecimenConfig` with
``dimension = 3``) from :func:`grainfrac.materials.homogeneous_recipe`: every
grain quartz (E = 27.37 GPa, nu = 0.21, read from the assembly), no Weibull
scatter, contacts stiffer than Table 2 by a stated factor and unbreakable. The
loads are the nodal forces of :mod:`grainfrac.loading.boundary3d` (uniform
tractions on the surface triangles); the solver is stepped with bonds held
elastic to an unbalanced-force ratio ``ratio``: by default after a static solve of
the equilibrium (``equilibrium = "static"``, :func:`equilibrate3d`), or from the
unloaded state by the explicit steps alone (``"explicit"``).

Sign convention: tension positive (as the mechanics); far-field stresses and
the borehole pressure are compressive magnitudes (Pa), as in the configs.
Stress components in Voigt order xx, yy, zz, yz, xz, xy.

The :class:`~grainfrac.stages.Equilibrate` stage applies 2D far fields only (no
sigma_z), so these cases load and equilibrate the solver directly, with the
same bonds-elastic rule as :func:`grainfrac.loading.insitu.initialise_in_situ`.

Wall hoop stress from the wall triangles
----------------------------------------
As in 2D (:mod:`grainfrac.verification.elastic`), the wall value comes from the
displacements: on a borehole-wall triangle the displacement is linear, so its
surface gradient gives the exact tangential strains of the tetrahedron it
bounds, the hoop strain ``eps_tt = t . (grad u) t`` (``t = e_z x n``,
horizontal along the facet) and ``eps_zz``. With the wall traction
``sigma_rr`` (0, or ``-p`` under a pressure) 3D Hooke's law gives

    sigma_tt = E / (1 - nu^2) (eps_tt + nu eps_zz) + nu / (1 - nu) sigma_rr.

Each triangle's value stands for its area; the hoop stress around the wall is
fitted by weighted least squares with the basis 1, cos 2t, sin 2t, cos 4t,
sin 4t averaged over each triangle's area (a 15 x 15 sub-triangle rule), as
the 2D case fits edge arcs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly
from grainfrac.geometry.solids3d import BOREHOLE
from grainfrac.io.config import validate
from grainfrac.loading.boundary3d import (
    far_field_stress_forces3d,
    normal_pressure_forces3d,
    surface_triangles,
)
from grainfrac.materials import homogeneous_recipe
from grainfrac.physics import static_equilibrium
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import MPA
from grainfrac.verification.elastic import (
    DECAY_RADII,
    UM,
    VerificationError,
    hoop_decay_rows,
    kirsch_hoop_stress,
    lame_wall_displacement,
)
from grainfrac.verification.report import Comparison

#: Tolerances: relative, except the patch test's (dimensionless, against 0).
PATCH_TOLERANCE = 1e-6
LAME3D_TOLERANCE = 0.05
KIRSCH3D_WALL_TOLERANCE = 0.10
KIRSCH3D_DECAY_TOLERANCE = 0.05

#: Paper Table 6 case 2 (compressive Pa).
CASE2 = (2.5e6, 5.0e6, 1.0e6)
#: ``kirsch3d``'s zone size on the borehole wall (mm) unless told: the linear
#: tetrahedron needs about 1 mm there for the wall rows (decision record 0023).
KIRSCH3D_WALL_ZONE_MM = 1.0

_SUBDIVISIONS = 15  # per triangle side, for the area averages of the Fourier basis


@dataclass(frozen=True)
class Equilibrium:
    """An equilibrated 3D solver and what it reached."""

    assembly: GrainAssembly
    solver: MechanicsSolver
    unbalanced_force_ratio: float
    steps: int


# -- model ----------------------------------------------------------------------------

def homogeneous_slab3d(width_mm: float, height_mm: float, thickness_mm: float,
                       borehole_diameter_mm: float, *, seed: int = 0,
                       zone_size_mm: float = 2.0, stiffness_factor: float = 100.0,
                       wall_zone_size_mm: float | None = None) -> GrainAssembly:
    """A 3D slab (a block without a borehole when its diameter is 0) of homogeneous quartz.

    ``stiffness_factor`` multiplies the Table 2 quartz-quartz contact stiffnesses;
    ``wall_zone_size_mm`` refines the zones at the borehole wall.
    """
    grains = {"zone_size_mm": zone_size_mm}
    if wall_zone_size_mm is not None:
        grains["wall_zone_size_mm"] = wall_zone_size_mm
    config = validate(SpecimenConfig, {
        "dimension": 3, "seed": seed,
        "specimen": {"shape": "slab", "width_mm": width_mm, "height_mm": height_mm,
                     "thickness_mm": thickness_mm, "borehole_diameter_mm": borehole_diameter_mm},
        "grains": grains,
    })
    return build_assembly(config, homogeneous_recipe(stiffness_factor=stiffness_factor))


def equilibrate3d(assembly: GrainAssembly, external: np.ndarray, ratio: float,
                  max_steps: int, fixed: np.ndarray | None = None,
                  method: str = "static") -> Equilibrium:
    """Apply nodal forces ``external`` (and ``fixed`` components), step with the bonds
    held elastic until the unbalanced-force ratio is below ``ratio``; raise if not.

    ``method``: ``"static"`` solves the equilibrium first
    (:func:`grainfrac.physics.static_equilibrium.settle`) and steps only if that
    leaves the ratio above ``ratio``; ``"explicit"`` steps from the unloaded state."""
    static_equilibrium.check_method(method)
    solver = MechanicsSolver(build_mechanical_model(assembly))
    solver.loads.external[:] = external
    if fixed is not None:
        solver.loads.fixed[:] = fixed
    solver.allow_failure = False
    achieved = static_equilibrium.equilibrate(solver, ratio, max_steps, method)
    solver.allow_failure = True
    if not achieved < ratio:
        raise VerificationError(
            f"no equilibrium: unbalanced-force ratio {achieved:.3g} > {ratio:.3g} after "
            f"{solver.step_count} steps")
    return Equilibrium(assembly, solver, achieved, solver.step_count)


def _props(assembly: GrainAssembly, nodes: np.ndarray) -> tuple[float, float]:
    grain = assembly.mesh.node_grain[nodes]
    return (float(np.mean(assembly.grain_youngs_modulus[grain])),
            float(np.mean(assembly.grain_poisson_ratio[grain])))


# -- wall measurements ----------------------------------------------------------------

@dataclass(frozen=True)
class WallTriangles:
    """Borehole-wall triangles: area-averaged Fourier basis, areas, centroid z, hoop stress."""

    basis: np.ndarray  # (t, 5): mean of 1, cos 2t, sin 2t, cos 4t, sin 4t over the triangle
    area: np.ndarray
    z: np.ndarray
    hoop_stress: np.ndarray  # Pa, tension positive


def _fourier(theta: np.ndarray) -> np.ndarray:
    return np.stack([np.ones_like(theta), np.cos(2 * theta), np.sin(2 * theta),
                     np.cos(4 * theta), np.sin(4 * theta)], axis=-1)


def _sub_triangle_points(n: int) -> np.ndarray:
    """Barycentric centroids ``(n^2, 3)`` of the n^2 equal sub-triangles of a triangle."""
    pts = []
    for i in range(n):
        for j in range(n - i):
            pts.append((i + 1 / 3, j + 1 / 3))  # upward sub-triangle
            if i + j < n - 1:
                pts.append((i + 2 / 3, j + 2 / 3))  # downward
    ij = np.array(pts) / n
    return np.column_stack((ij, 1.0 - ij.sum(axis=1)))


def wall_triangles(assembly: GrainAssembly, u: np.ndarray, wall_normal_stress: float = 0.0
                   ) -> WallTriangles:
    """Hoop stress of every borehole-wall triangle from its surface strains (module doc)."""
    mesh = assembly.mesh
    tri, area, normal = surface_triangles(mesh, BOREHOLE)
    x = mesh.node_x[tri]  # (t, 3, 3)
    ez = np.array([0.0, 0.0, 1.0])
    tangent = np.cross(np.broadcast_to(ez, normal.shape), normal)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    # In-plane coordinates (along t, along z) of the corners; the displacement is linear
    # in them, so two edge differences determine its two directional derivatives.
    d = x[:, 1:] - x[:, :1]  # (t, 2, 3)
    coords = np.stack((np.einsum("tkj,tj->tk", d, tangent), d[:, :, 2]), axis=2)  # (t, 2, 2)
    du = u[tri[:, 1:]] - u[tri[:, :1]]  # (t, 2, 3)
    grad = np.linalg.solve(coords, du)  # (t, 2, 3): rows d u / d s_t, d u / d z
    eps_tt = np.einsum("tj,tj->t", grad[:, 0], tangent)
    eps_zz = grad[:, 1, 2]
    e, nu = _props(assembly, tri[:, 0])
    hoop = e / (1 - nu**2) * (eps_tt + nu * eps_zz) + nu / (1 - nu) * wall_normal_stress
    bary = _sub_triangle_points(_SUBDIVISIONS)
    q = np.einsum("sk,tkj->tsj", bary, x)
    basis = _fourier(np.arctan2(q[..., 1], q[..., 0])).mean(axis=1)
    return WallTriangles(basis, area, x[:, :, 2].mean(axis=1), hoop)


def fit_wall_hoop3d(wall: WallTriangles, select: np.ndarray, angles_deg) -> np.ndarray:
    """Area-weighted least-squares Fourier fit of the selected triangles' hoop stress,
    evaluated at ``angles_deg`` (Pa)."""
    if np.count_nonzero(select) < 10:
        raise VerificationError("too few borehole-wall triangles to fit the hoop stress")
    w = np.sqrt(wall.area[select])
    coef = np.linalg.lstsq(wall.basis[select] * w[:, None], wall.hoop_stress[select] * w,
                           rcond=None)[0]
    return _fourier(np.radians(np.asarray(angles_deg, dtype=float))) @ coef


def element_polar3d(assembly: GrainAssembly, stress: np.ndarray):
    """Element centroid radius from the z axis (m), angle (rad), z (m), hoop stress (Pa)
    and volume (m3)."""
    mesh = assembly.mesh
    c = mesh.node_x[mesh.element_nodes].mean(axis=1)
    r = np.hypot(c[:, 0], c[:, 1])
    theta = np.arctan2(c[:, 1], c[:, 0])
    s, co = np.sin(theta), np.cos(theta)
    hoop = stress[:, 0] * s**2 + stress[:, 1] * co**2 - 2 * stress[:, 5] * s * co
    return r, theta, c[:, 2], hoop, mesh.element_volumes()


# -- cases ----------------------------------------------------------------------------

def patch3d(sigma_x: float = CASE2[0], sigma_y: float = CASE2[1], sigma_z: float = CASE2[2],
            seed: int = 0, *, size_mm: float = 20.0, zone_size_mm: float = 3.0,
            stiffness_factor: float = 1000.0, ratio: float = 1e-8,
            max_steps: int = 1_000_000, equilibrium: str = "static") -> list[Comparison]:
    """Uniform stress in a block of tetrahedral grains with bonded contacts.

    A ``size_mm`` cube of homogeneous quartz grains (no borehole), the in-situ
    stresses ``sigma_x``, ``sigma_y``, ``sigma_z`` (compressive Pa; default paper
    Table 6 case 2) on its six faces, nothing fixed (the loads have no net force
    or moment). The continuum answer is the uniform stress
    ``s = diag(-sigma_x, -sigma_y, -sigma_z)`` everywhere. Run twice: contacts
    ``stiffness_factor`` (F) and 10 F times the Table 2 quartz-quartz stiffness.

    Contact compliance: with compliant contacts uniform stress is NOT the exact
    discrete solution (the contact openings s.n / k differ from face to face and do
    not close around a grain edge, so the grains strain non-uniformly). The
    element-stress error is first order in 1 / k. Measured (20 mm block, 3 mm
    zones, seed 0: 16 grains, 2608 tets), max over elements and components of
    |s_e - s| / max|s|: F = 10: 1.02e-2, 100: 1.07e-3, 1000: 1.07e-4,
    1e4: 1.07e-5. Mass scaling keeps the time step, but the steps to equilibrium
    grow as sqrt(k) (to ratio 1e-7: F = 100: 11 400; 1000: 35 400; to 1e-5 at
    1e4: 67 000; 1e5: 148 000 to 1e-4 only), so meeting 1e-6 element by element
    at finite stiffness (F >= 1e6) is out of reach of a test. Compared instead
    (dimensionless, tolerances as stated):

    * ``mean_stress_error`` (1e-6, against 0), at F: max over the six components
      of |<s_e> - s| / max|s|, <s_e> the volume average of the element stresses.
      At equilibrium it is exactly s for any contact stiffness: for a linear
      element ``sum_a x_a (x) f_a = V s_e``, the two nodes of a sub-contact sit at
      one point so contact forces cancel in the sum, and the consistent face loads
      (A/3 per corner) give ``sum x (x) f_ext = V s`` on a box. Only the
      unbalanced force remains: it checks the loads, elements and equilibrium.
    * ``unbalanced_force_ratio`` (against 0, tolerance ``ratio``): reached at F.
    * ``element_error_order_in_compliance`` (1 +- 5 %): log10 of the ratio of the
      element errors at F and 10 F, which is 1 when the error is all contact
      compliance.
    * ``extrapolated_element_stress_error`` (1e-6, against 0): every element's
      stress extrapolated to rigid contacts (Richardson, first order in 1 / k):
      ``s_inf = (10 s_e(10 F) - s_e(F)) / 9``; max |s_inf - s| / max|s|.
    """
    runs = []
    for factor in (stiffness_factor, 10.0 * stiffness_factor):
        assembly = homogeneous_slab3d(size_mm, size_mm, size_mm, 0.0, seed=seed,
                                      zone_size_mm=zone_size_mm, stiffness_factor=factor)
        mesh = assembly.mesh
        runs.append(equilibrate3d(
            assembly, far_field_stress_forces3d(mesh, sigma_x, sigma_y, sigma_z), ratio,
            max_steps, method=equilibrium))
    applied = np.array([-sigma_x, -sigma_y, -sigma_z, 0.0, 0.0, 0.0])
    scale = float(np.abs(applied).max())
    vol = runs[0].assembly.mesh.element_volumes()
    coarse, stiff = runs[0].solver.stress, runs[1].solver.stress
    mean = (coarse * vol[:, None]).sum(axis=0) / vol.sum()
    err = [float(np.abs(s - applied).max()) / scale for s in (coarse, stiff)]
    extrapolated = (10.0 * stiff - coarse) / 9.0
    return [
        Comparison("patch3d", "mean_stress_error", float(np.abs(mean - applied).max()) / scale,
                   0.0, PATCH_TOLERANCE),
        Comparison("patch3d", "unbalanced_force_ratio", runs[0].unbalanced_force_ratio, 0.0,
                   ratio),
        Comparison("patch3d", "element_error_order_in_compliance",
                   math.log10(err[0] / err[1]), 1.0, 0.05),
        Comparison("patch3d", "extrapolated_element_stress_error",
                   float(np.abs(extrapolated - applied).max()) / scale, 0.0, PATCH_TOLERANCE),
    ]


def lame3d(pressure: float = 10e6, seed: int = 0, *, width_mm: float = 100.0,
           thickness_mm: float = 20.0, borehole_diameter_mm: float = 10.0,
           zone_size_mm: float = 2.0, ratio: float = 1e-5,
           max_steps: int = 400_000, equilibrium: str = "static") -> list[Comparison]:
    """Borehole wall displacement under internal pressure vs the Lame solution.

    Loading: pressure ``p`` on the borehole wall; the top and bottom (``z-``,
    ``z+``) held in z (frictionless rollers), everything else free. A prism with
    roller ends is in exact plane strain, so the 2D solution is the 3D one:
    u_r(a) = p a (1 + nu) / E (:func:`~grainfrac.verification.elastic.lame_wall_displacement`,
    hole in an infinite plate). For this load sigma_rr + sigma_tt = 0, so
    sigma_zz = 0 and the plane-stress answer (free top and bottom) is the same in
    an infinite plate; the rollers make the finite slab exact plane strain too.

    Compared: ``radial_displacement_wall_um`` (5 %): mean radial displacement of
    the borehole-wall nodes about the z axis.

    Finite slab: as in 2D, the free square outer boundary (half-width b) adds
    about (2 - 2 nu)(a/b)^2 (the plane-strain thick cylinder): +1.6 % at
    b = 10 a; not corrected for. Measured (seed 0, 2 mm zones, 10 mm borehole):
    40 mm slab 6 mm thick: +3.1 %; 40 x 4 mm: +3.0 %; 30 x 4 mm: +9.9 % (b = 3 a).
    """
    assembly = homogeneous_slab3d(width_mm, width_mm, thickness_mm, borehole_diameter_mm,
                                  seed=seed, zone_size_mm=zone_size_mm)
    mesh = assembly.mesh
    fixed = np.zeros((mesh.n_nodes, 3), dtype=bool)
    for side in ("z-", "z+"):
        fixed[mesh.node_sets[side], 2] = True
    eq = equilibrate3d(assembly, normal_pressure_forces3d(mesh, BOREHOLE, pressure), ratio,
                       max_steps, fixed=fixed, method=equilibrium)
    a = float(mesh.grains.solid.borehole_radius)
    nodes = mesh.node_sets[BOREHOLE]
    rel = mesh.node_x[nodes, :2]
    radial = np.sum(eq.solver.u[nodes, :2] * rel, axis=1) / np.hypot(rel[:, 0], rel[:, 1])
    e, nu = _props(assembly, nodes)
    return [Comparison("lame3d", "radial_displacement_wall_um", float(radial.mean()) / UM,
                       lame_wall_displacement(pressure, a, e, nu) / UM, LAME3D_TOLERANCE)]


def kirsch3d(sigma_x: float = CASE2[0], sigma_y: float = CASE2[1], sigma_z: float = CASE2[2],
             seed: int = 0, *, width_mm: float = 100.0, thickness_mm: float = 20.0,
             borehole_diameter_mm: float = 10.0, zone_size_mm: float = 2.0,
             wall_zone_size_mm: float | None = None, ratio: float = 1e-5,
             max_steps: int = 400_000, plane_strain: bool = False,
             equilibrium: str = "static") -> list[Comparison]:
    """Hoop stress around the borehole on the mid-plane under the in-situ stresses.

    Loading: ``sigma_x``, ``sigma_y``, ``sigma_z`` (compressive Pa, default paper
    Table 6 case 2: 2.5, 5, 1 MPa) on the six faces, borehole free, nothing fixed.

    Reference: Kirsch (:func:`~grainfrac.verification.elastic.kirsch_hoop_stress`).
    In generalised plane strain the in-plane stresses do not depend on sigma_z
    (it adds a uniform sigma_zz), so the 2D solution is the reference; the free
    top and bottom make the slab a thick plate instead, whose 3D correction
    (Sternberg & Sadowsky 1949: a few percent on the mid-plane for a thickness of
    a few radii) is part of the measured error.

    ``wall_zone_size_mm`` (``--wall-zone-size``) is the zone size at the borehole wall
    (:class:`~grainfrac.geometry.zone_sizes.ZoneSizes`): by default
    :data:`KIRSCH3D_WALL_ZONE_MM` (1 mm), or the zone size if that is finer; the zone
    size itself leaves the wall unrefined. The wall rows read the triangles within one
    wall zone of the mid-plane.

    With ``plane_strain`` (``grainfrac verify kirsch3d-plane-strain``) the top and
    bottom faces are rollers (their nodes held along z, ``sigma_z`` not applied):
    the slab is then in plane strain, where Kirsch is the exact solution at every
    height, so the rows measure the discretisation alone (case name
    ``kirsch3d-plane-strain``; its wall is unrefined unless told).

    Compared:

    * ``hoop_stress_wall_{0,90}deg_MPa`` (10 %): Fourier fit (module doc) of the
      wall triangles with centroids within one zone of the mid-plane.
    * ``hoop_stress_{2,3,4}a_{0,90}deg_MPa`` (5 %): volume-weighted mean hoop
      stress of the elements whose centroids are within +-15 deg of 0/180
      (90/270) deg, within +-0.25 a of r = 2a, 3a, 4a and within a quarter of the
      thickness of the mid-plane, against the volume-weighted mean of Kirsch at
      the same centroids. Only radii with (k + 1) a inside the slab's half-width
      are compared (all three on the default slab).

    Accuracy: at 90 deg the hoop stress is the mean (-7.5 MPa) plus the cos 2 theta
    amplitude (5 MPa), so the amplitude's error, second order in the zone size, counts
    twice there. At 2 mm zones throughout the wall reads 13-22 % off at 90 deg (seeds
    0-3); with 1 mm zones at the wall, within 2.3 %. The decay bands need the full slab
    (on 40 mm slabs the 4a band at 90 deg touches the sides). Measured figures: the
    how-to "Run in 3D", section "Verification in 3D", and decision record 0023.
    """
    if wall_zone_size_mm is None:
        wall_zone_size_mm = min(KIRSCH3D_WALL_ZONE_MM, zone_size_mm)
    assembly = homogeneous_slab3d(width_mm, width_mm, thickness_mm, borehole_diameter_mm,
                                  seed=seed, zone_size_mm=zone_size_mm,
                                  wall_zone_size_mm=wall_zone_size_mm)
    mesh = assembly.mesh
    solid = mesh.grains.solid
    a = float(solid.borehole_radius)
    z_mid = 0.5 * float(solid.lo[2] + solid.hi[2])
    case = "kirsch3d-plane-strain" if plane_strain else "kirsch3d"
    fixed = None
    if plane_strain:
        fixed = np.zeros((mesh.n_nodes, 3), dtype=bool)
        for side in ("z-", "z+"):
            fixed[np.unique(surface_triangles(mesh, side)[0]), 2] = True
    external = far_field_stress_forces3d(mesh, sigma_x, sigma_y, 0.0 if plane_strain else sigma_z)
    eq = equilibrate3d(assembly, external, ratio, max_steps, fixed=fixed, method=equilibrium)
    sxx, syy = -sigma_x, -sigma_y
    rows: list[Comparison] = []
    wall = wall_triangles(assembly, eq.solver.u)
    near = np.abs(wall.z - z_mid) <= mesh.wall_zone_size
    for angle, sim in zip((0, 90), fit_wall_hoop3d(wall, near, (0.0, 90.0)), strict=True):
        exact = float(kirsch_hoop_stress(a, math.radians(angle), a, sxx, syy))
        rows.append(Comparison(case, f"hoop_stress_wall_{angle}deg_MPa", float(sim) / MPA,
                               exact / MPA, KIRSCH3D_WALL_TOLERANCE))
    r, theta, z, hoop, vol = element_polar3d(assembly, eq.solver.stress)
    mid = np.abs(z - z_mid) <= 0.25 * float(solid.extent[2])
    half_width = 0.5 * float(min(solid.extent[0], solid.extent[1]))
    radii = [k for k in DECAY_RADII if (k + 1) * a <= half_width]  # bands clear of the sides
    rows += hoop_decay_rows(case, r, theta, hoop, vol, a, (sxx, syy), radii,
                            KIRSCH3D_DECAY_TOLERANCE, where=mid)
    return rows


def kirsch3d_plane_strain(seed: int = 0, *, zone_size_mm: float = 2.0,
                          wall_zone_size_mm: float | None = None,
                          equilibrium: str = "static", **options) -> list[Comparison]:
    """:func:`kirsch3d` with rollers on the top and bottom faces (plane strain); the wall
    is meshed at the zone size unless ``wall_zone_size_mm`` is given."""
    return kirsch3d(seed=seed, zone_size_mm=zone_size_mm,
                    wall_zone_size_mm=wall_zone_size_mm or zone_size_mm, plane_strain=True,
                    equilibrium=equilibrium, **options)
