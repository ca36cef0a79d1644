"""Elastic verification: a hole under far-field stress (Kirsch) and a pressurised hole (Lame).

Both cases build the default slab (100 x 100 mm, 10 mm borehole at the
origin) from :func:`grainfrac.materials.homogeneous_recipe`: every grain
quartz (E = 27.37 GPa, nu = 0.21, read from the assembly), no Weibull scatter,
contacts 100 x stiffer than Table 2 and unbreakable, so the assembly should
behave as one linear elastic continuum in plane strain. The references are the
infinite-plate solutions; the slab is finite (outer half-width b = 50 mm =
10 a), and what that costs is stated case by case.

Sign convention: tension positive (as the mechanics); the far-field stresses
and the borehole pressure are given as compressive magnitudes (Pa), as in the
configs.

Wall values from the wall edges
-------------------------------
Linear triangles carry one constant stress each, and the hoop stress falls
steeply away from the wall (Kirsch: terms in a^2/r^2 and a^4/r^4), so no
element holds "the wall value" and extrapolating element stresses to r = a
amplifies their scatter. Instead the hoop stress at the wall is recovered from
the displacements, which are the solver's primary (and more accurate)
unknowns: along a borehole-wall element edge the displacement is linear, so
the edge's stretch ``(u1 - u0) . t / L`` is exactly the tangential (hoop)
strain of the element it bounds. At a wall loaded only by a normal traction
``sigma_rr`` (0 for Kirsch, -p for Lame) plane-strain Hooke's law gives

    sigma_tt = E / (1 - nu^2) * eps_tt + nu / (1 - nu) * sigma_rr.

Each edge spans a small arc (5-20 degrees), so its value is an arc average;
the hoop stress around the wall is fitted by weighted least squares
(weights: edge length) with the arc-averaged Fourier basis
1, cos 2t, sin 2t, cos 4t, sin 4t. The 0/2 harmonics are the complete form of
any traction-free-hole solution under uniform far-field stress (Kirsch is
``P + Q cos 2t``); the 4th harmonics absorb the square slab's own
perturbation; the sine terms absorb mesh asymmetry. The fit is evaluated at
0 and 90 degrees; with even harmonics only, 0 and 180 (90 and 270) degrees
are averaged implicitly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly
from grainfrac.errors import GrainfracError
from grainfrac.io.config import validate
from grainfrac.materials import homogeneous_recipe
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.stages import Driver, Equilibrate, World
from grainfrac.units import MPA
from grainfrac.verification.report import Comparison

UM = 1.0e-6  # m per micrometre (displacements are reported in um)

#: Tolerances (relative) of the compared quantities.
KIRSCH_WALL_TOLERANCE = 0.10
KIRSCH_DECAY_TOLERANCE = 0.10
LAME_DISPLACEMENT_TOLERANCE = 0.05
LAME_WALL_HOOP_TOLERANCE = 0.10

#: Sector half-angle (deg) and radial half-width (in units of a) of the element
#: bands used for the decay of the hoop stress with distance.
SECTOR_HALF_ANGLE_DEG = 15.0
BAND_HALF_WIDTH = 0.25
DECAY_RADII = (2, 3, 4)


class VerificationError(GrainfracError):
    """A verification case could not be run (e.g. the solver did not equilibrate)."""


@dataclass(frozen=True)
class WallEdges:
    """Borehole-wall element edges: angular spans (rad) about the centre and hoop stresses."""

    theta0: np.ndarray
    theta1: np.ndarray
    length: np.ndarray
    hoop_stress: np.ndarray  # Pa, tension positive


# -- analytical solutions ------------------------------------------------------------

def kirsch_hoop_stress(r, theta, radius: float, sigma_xx: float, sigma_yy: float):
    """Kirsch hoop stress (Pa, tension positive) around a traction-free hole.

    ``sigma_xx``, ``sigma_yy``: far-field stresses, tension positive (a
    compressive far field is negative); ``theta`` from the x axis.
    """
    q = (radius / np.asarray(r)) ** 2
    return (0.5 * (sigma_xx + sigma_yy) * (1 + q)
            - 0.5 * (sigma_xx - sigma_yy) * (1 + 3 * q * q) * np.cos(2 * np.asarray(theta)))


def lame_wall_displacement(pressure: float, radius: float, youngs_modulus: float,
                           poisson_ratio: float) -> float:
    """Radial wall displacement (m) of a hole of ``radius`` in an infinite plane-strain plate.

    Internal pressure ``p``: sigma_rr = -p a^2/r^2, sigma_tt = +p a^2/r^2,
    sigma_zz = nu (sigma_rr + sigma_tt) = 0, so u_r(a) = p a (1 + nu) / E.
    """
    return pressure * radius * (1 + poisson_ratio) / youngs_modulus


def thick_cylinder_wall_displacement(pressure: float, radius: float, outer_radius: float,
                                     youngs_modulus: float, poisson_ratio: float) -> float:
    """Plane-strain thick cylinder (inner ``radius``, free outer radius ``b``): u_r at the wall.

    u_r(a) = p a (1 + nu) / E * ((1 - 2 nu) a^2 + b^2) / (b^2 - a^2); tends to
    :func:`lame_wall_displacement` as b -> infinity (correction ~ (2 - 2 nu)(a/b)^2).
    """
    a2, b2 = radius**2, outer_radius**2
    return (pressure * radius * (1 + poisson_ratio) / youngs_modulus
            * ((1 - 2 * poisson_ratio) * a2 + b2) / (b2 - a2))


# -- model and measurements -----------------------------------------------------------

def homogeneous_slab(seed: int = 0, zone_size_mm: float = 2.0) -> GrainAssembly:
    """The default slab with a borehole, built from the homogeneous quartz recipe."""
    config = validate(SpecimenConfig, {"seed": seed, "grains": {"zone_size_mm": zone_size_mm}})
    return build_assembly(config, homogeneous_recipe())


def _borehole(assembly: GrainAssembly) -> tuple[np.ndarray, float]:
    shape = assembly.mesh.grains.outline
    if shape.borehole_radius <= 0:
        raise VerificationError("the specimen has no borehole")
    return np.asarray(shape.borehole_center, dtype=float), float(shape.borehole_radius)


def equilibrated_slab(assembly: GrainAssembly, stage: Equilibrate) -> MechanicsSolver:
    """The slab's mechanics after ``stage`` on the driver; raises if it did not settle."""
    solver = MechanicsSolver(build_mechanical_model(assembly))
    Driver([stage], World(assembly, solver)).execute()
    achieved = stage.state.unbalanced_force_ratio
    if not stage.state.converged:
        raise VerificationError(
            f"no equilibrium: unbalanced-force ratio {achieved:.3g} > {stage.ratio:.3g} "
            f"after {solver.step_count} steps"
        )
    return solver


def wall_edges(assembly: GrainAssembly, u: np.ndarray, wall_normal_stress: float = 0.0
               ) -> WallEdges:
    """Hoop stress of every borehole-wall edge from its stretch (see module doc).

    ``wall_normal_stress``: the radial stress the wall carries (Pa, tension
    positive): 0 for a traction-free wall, ``-p`` under a borehole pressure p.
    """
    mesh = assembly.mesh
    centre, _ = _borehole(assembly)
    faces = mesh.boundary_faces["borehole"]
    n0, n1 = faces.nodes[:, 0], faces.nodes[:, 1]
    p0, p1 = mesh.node_xy[n0] - centre, mesh.node_xy[n1] - centre
    chord = p1 - p0
    length = np.hypot(chord[:, 0], chord[:, 1])
    strain = np.sum((u[n1] - u[n0]) * chord, axis=1) / length**2
    grain = mesh.node_grain[n0]
    e, nu = assembly.grain_youngs_modulus[grain], assembly.grain_poisson_ratio[grain]
    hoop = e / (1 - nu**2) * strain + nu / (1 - nu) * wall_normal_stress
    theta0 = np.arctan2(p0[:, 1], p0[:, 0])
    span = np.angle(np.exp(1j * (np.arctan2(p1[:, 1], p1[:, 0]) - theta0)))
    return WallEdges(theta0, theta0 + span, length, hoop)


def _arc_basis(theta0: np.ndarray, theta1: np.ndarray) -> np.ndarray:
    """Arc averages of 1, cos 2t, sin 2t, cos 4t, sin 4t over each [theta0, theta1]."""
    span = theta1 - theta0
    cols = [np.ones_like(span)]
    for n in (2, 4):
        cols.append((np.sin(n * theta1) - np.sin(n * theta0)) / (n * span))
        cols.append((np.cos(n * theta0) - np.cos(n * theta1)) / (n * span))
    return np.column_stack(cols)


def fit_wall_hoop(edges: WallEdges, angles_deg) -> np.ndarray:
    """Least-squares Fourier fit of the wall hoop stress, evaluated at ``angles_deg`` (Pa)."""
    basis = _arc_basis(edges.theta0, edges.theta1)
    w = np.sqrt(edges.length)
    coef = np.linalg.lstsq(basis * w[:, None], edges.hoop_stress * w, rcond=None)[0]
    t = np.radians(np.asarray(angles_deg, dtype=float))
    at = np.column_stack([np.ones_like(t), np.cos(2 * t), np.sin(2 * t), np.cos(4 * t),
                          np.sin(4 * t)])
    return at @ coef


def element_polar(assembly: GrainAssembly, stress: np.ndarray):
    """Element centroid radius (m), angle (rad) and hoop stress (Pa), and element areas."""
    mesh = assembly.mesh
    centre, _ = _borehole(assembly)
    p = mesh.node_xy[mesh.element_nodes]
    cen = p.mean(axis=1) - centre
    r = np.hypot(cen[:, 0], cen[:, 1])
    theta = np.arctan2(cen[:, 1], cen[:, 0])
    s, c = np.sin(theta), np.cos(theta)
    hoop = stress[:, 0] * s**2 + stress[:, 1] * c**2 - 2 * stress[:, 2] * s * c
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return r, theta, hoop, area


def sector_band(r, theta, radius: float, k: float, angle_deg: float) -> np.ndarray:
    """Elements within the band |r - k a| <= BAND_HALF_WIDTH a and within
    SECTOR_HALF_ANGLE_DEG of ``angle_deg`` or of the opposite direction."""
    offset = np.angle(np.exp(2j * (theta - np.radians(angle_deg)))) / 2
    return ((np.abs(offset) <= np.radians(SECTOR_HALF_ANGLE_DEG))
            & (np.abs(r / radius - k) <= BAND_HALF_WIDTH))


# -- cases ----------------------------------------------------------------------------

def kirsch(sigma_x: float = 2.5e6, sigma_y: float = 5.0e6, seed: int = 0, *,
           zone_size_mm: float = 1.4, ratio: float = 1e-5,
           max_steps: int = 400_000, equilibrium: str = "static") -> list[Comparison]:
    """Hoop stress around the borehole under far-field stress vs the Kirsch solution.

    Loading: the production path, the :class:`~grainfrac.stages.Equilibrate` stage
    (uniform normal tractions ``sigma_x`` on left/right, ``sigma_y`` on top/bottom,
    compressive Pa; default paper Table 6 case 2, 2.5 / 5 MPa), equilibrated to an
    unbalanced-force ratio ``ratio``, by its static solve then explicit steps
    (``equilibrium = "static"``) or by the explicit steps alone (``"explicit"``).

    Reference (infinite plate, tension positive, far field s_xx = -sigma_x,
    s_yy = -sigma_y, t from the x axis)::

        s_tt(r, t) = (s_xx + s_yy)/2 (1 + a^2/r^2) - (s_xx - s_yy)/2 (1 + 3 a^4/r^4) cos 2t
        s_tt(a, t) = (s_xx + s_yy) - 2 (s_xx - s_yy) cos 2t

    so at the wall t = 0: 3 s_yy - s_xx = -(3 sigma_y - sigma_x) = -12.5 MPa and
    t = 90 deg: 3 s_xx - s_yy = -(3 sigma_x - sigma_y) = -2.5 MPa.

    Compared (tolerance 10 % each):

    * ``hoop_stress_wall_{0,90}deg_MPa``: the wall value from the wall-edge
      strains and the Fourier fit (module doc) against the values above.
    * ``hoop_stress_{2,3,4}a_{0,90}deg_MPa``: area-weighted mean hoop stress of
      the elements whose centroids lie within +-15 deg of 0/180 (90/270) deg
      and within +-0.25 a of r = 2a, 3a, 4a, against the area-weighted mean of
      the Kirsch solution at the same centroids (like for like, no
      interpolation).

    Mesh: the zone size defaults to 1.4 mm (the paper's refined zone size),
    not the 2 mm default. Measured wall errors (0 / 90 deg, seed 0): 2.0 mm:
    -6.2 % / +16.4 %; 1.4 mm: -2.9 % / +2.8 % (seeds 1-3: -2.4 / +5.5,
    -2.4 / +5.1, -2.3 / +5.1 %); 1.2 mm: -1.5 % / +7.5 %; 1.0 mm: 0.0 % / +3.0 %.
    The 90 deg value is a small difference of large terms (3 s_xx - s_yy), so
    any absolute error there is magnified ~5x relative to the 0 deg value; on
    the 2 mm mesh (about 31 wall edges) it is not resolved. The band means
    agree within ~1 % on every mesh. Alternative wall estimators were tried and
    rejected: a fit of A + B a^2/r^2 + C a^4/r^4 to element centroid stresses
    in a sector amplifies the scatter of the wall elements (errors of
    20-60 %), and a Michell-form fit over an annulus of element stresses
    stays biased by about -8 % at 90 deg even on the 1 mm mesh.

    Finite slab: the reference is the infinite plate. The hole's perturbation
    (~(a/r)^2 of the far field) is not zero at the slab edge (r = b = 10 a),
    and the uniform tractions applied there do not cancel it; the resulting
    correction field is of order (a/b)^2 = 1 % of the far-field stresses,
    concentrated up to ~3x at the wall: ~0.05-0.15 MPa, i.e. up to a few
    percent of the 90 deg value and well under 1 % of the 0 deg value. It is
    part of the measured error and not corrected for (on a 60 mm slab the
    90 deg band at 4a already drifts by +5 %).
    """
    assembly = homogeneous_slab(seed, zone_size_mm)
    _, a = _borehole(assembly)
    solver = equilibrated_slab(assembly, Equilibrate(sigma_x, sigma_y, ratio, max_steps,
                                                     method=equilibrium))
    sxx, syy = -sigma_x, -sigma_y

    rows: list[Comparison] = []
    wall = fit_wall_hoop(wall_edges(assembly, solver.u), (0.0, 90.0))
    for angle, sim in zip((0, 90), wall, strict=True):
        exact = float(kirsch_hoop_stress(a, np.radians(angle), a, sxx, syy))
        rows.append(Comparison("kirsch", f"hoop_stress_wall_{angle}deg_MPa", float(sim) / MPA,
                               exact / MPA, KIRSCH_WALL_TOLERANCE))

    r, theta, hoop, area = element_polar(assembly, solver.stress)
    rows += hoop_decay_rows("kirsch", r, theta, hoop, area, a, (sxx, syy), DECAY_RADII,
                            KIRSCH_DECAY_TOLERANCE)
    return rows


def hoop_decay_rows(case: str, r, theta, hoop, weight, radius: float, far_field,
                    radii, tolerance: float, where=None) -> list[Comparison]:
    """Measure-weighted hoop stress of the elements in bands at ``k`` radii on the 0 and
    90 degree axes against Kirsch at the same centroids (``far_field = (sxx, syy)``);
    ``where`` restricts the elements (e.g. to a 3D slab's mid-plane)."""
    exact = kirsch_hoop_stress(r, theta, radius, *far_field)
    rows = []
    for angle in (0, 90):
        for k in radii:
            sel = sector_band(r, theta, radius, k, angle)
            if where is not None:
                sel &= where
            if not sel.any():
                raise VerificationError(f"no elements near r = {k}a, {angle} deg")
            sim = np.average(hoop[sel], weights=weight[sel])
            ref = np.average(exact[sel], weights=weight[sel])
            rows.append(Comparison(case, f"hoop_stress_{k}a_{angle}deg_MPa",
                                   float(sim) / MPA, float(ref) / MPA, tolerance))
    return rows


def lame(pressure: float = 10e6, seed: int = 0, *, zone_size_mm: float = 1.4,
         ratio: float = 1e-5, max_steps: int = 400_000,
         equilibrium: str = "static") -> list[Comparison]:
    """Borehole wall displacement under internal pressure vs the Lame solution.

    Loading: a pressure ``pressure`` (Pa) on the borehole wall (the
    :class:`~grainfrac.stages.Equilibrate` stage's ``wall_pressure``), no far field,
    outer sides free and nothing fixed. The pressure on a closed wall has no
    net force or moment, so no rigid-body motion is driven.

    Reference (hole in an infinite plane-strain plate): u_r(a) = p a (1 + nu) / E,
    sigma_tt(a) = +p (tension). E and nu are read from the assembly.

    Compared:

    * ``radial_displacement_wall_um`` (tolerance 5 %): mean radial displacement
      (about the borehole centre) of the borehole-wall nodes.
    * ``hoop_stress_wall_MPa`` (tolerance 10 %): the length-weighted mean of the
      wall-edge hoop stresses (module doc, with sigma_rr = -p at the wall)
      against +p.

    Finite slab: the outer boundary is a free 100 mm square, not infinitely
    far. A plane-strain thick cylinder with a free outer radius b stiffens
    less than an infinite plate: u_a grows by ((1 - 2 nu) a^2 + b^2) / (b^2 - a^2),
    a correction of ~(2 - 2 nu)(a/b)^2: +1.6 % for b = 50 mm (half-width)
    and +1.3 % for b = 56 mm (the circle of the slab's area). No correction is
    applied: the infinite-plate value is the reference and this bias is part of
    the measured error.

    Mesh: 1.4 mm zones, as for :func:`kirsch`. Linear triangles are too stiff
    on a coarse mesh, so u_a converges from below while the finite slab pushes
    it up. Measured u_a errors (seed 0 unless stated): 2.0 mm: -4.0 % (seeds
    1, 2: -3.6, -4.2 %); 1.4 mm: -1.0 % (seeds 1, 2: -1.1, -1.0 %); 1.0 mm:
    +0.2 %. That is a discretisation error of about -5.5 % (h / 2 mm)^2 on top
    of the +1.5 % finite-slab bias; the 2 mm default mesh would sit too close
    to the 5 % tolerance. Tighter equilibrium (ratio 1e-6, 1e-7) changes
    nothing in the 4th digit.
    """
    assembly = homogeneous_slab(seed, zone_size_mm)
    mesh = assembly.mesh
    centre, a = _borehole(assembly)
    solver = equilibrated_slab(assembly, Equilibrate(0.0, 0.0, ratio, max_steps,
                                                     wall_pressure=pressure,
                                                     method=equilibrium))

    nodes = mesh.node_sets["borehole"]
    rel = mesh.node_xy[nodes] - centre
    radial = np.sum(solver.u[nodes] * rel, axis=1) / np.hypot(rel[:, 0], rel[:, 1])
    grain = mesh.node_grain[nodes]
    e = float(np.mean(assembly.grain_youngs_modulus[grain]))
    nu = float(np.mean(assembly.grain_poisson_ratio[grain]))
    u_exact = lame_wall_displacement(pressure, a, e, nu)

    edges = wall_edges(assembly, solver.u, wall_normal_stress=-pressure)
    hoop = np.average(edges.hoop_stress, weights=edges.length)
    return [
        Comparison("lame", "radial_displacement_wall_um", float(radial.mean()) / UM,
                   u_exact / UM, LAME_DISPLACEMENT_TOLERANCE),
        Comparison("lame", "hoop_stress_wall_MPa", float(hoop) / MPA, pressure / MPA,
                   LAME_WALL_HOOP_TOLERANCE),
    ]
