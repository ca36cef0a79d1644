"""``grainfrac verify penny``: a penny-shaped hydraulic fracture in 3D against the M-vertex.

The hybrid paper's verification of 3DEC (sect. 4.2, Fig. 8), repeated with grainfrac's
3D coupling: a 60 mm cube of polyhedral grains (E = 40 MPa, nu = 0.22) whose horizontal
mid-plane is made of grain faces; a 10 mm diameter disc of that plane is cut (its
sub-contacts start broken); fluid (mu = 1e-3 Pa s) is injected at Q0 = 1e-5 m3/s into
the disc's centre; the minimum and initial hydraulic aperture is 3 um and the maximum
100 um; fluid flows only in broken sub-contacts. The plane's sub-contacts have no
strength (zero toughness: the M-vertex), those off the plane cannot break. Compared
with the zero-order M-vertex solution of Savitski & Detournay (2002)
(:mod:`grainfrac.verification.penny_reference`) at 1, 2 and 4 ms: the radius, the
opening at the injection point and the net pressure at half the radius, and checked:
nothing opens off the plane, the fluid volume balance, the fluid's energy books.

How the simulated quantities are read (one realisation of the grains):

- **radius**: that of the disc with the area of the plane's sub-contacts open by more
  than ``OPENING_THRESHOLD`` of the opening at the injection point (as the KGD case
  reads its tip) that hold fluid (the M-vertex has no lag; the open, dry rim ahead of
  the fluid is reported apart);
- **opening at the well**: the mean opening of the plane's sub-contacts at the
  injection point (their change since injection began);
- **pressure at half the radius**: the mean fluid pressure, less the confinement, of
  the plane's sub-contacts within half a zone of half the measured radius, against the
  reference at half its own radius (both at rho = 1/2);
- **opening off the plane**: the largest separation (faces apart, not their change
  since injection) of a sub-contact off the plane. The confinement presses every
  contact shut by ``sigma_0 / kn`` (5 um at 2 mm zones); where the fracture unloads a
  grain boundary off the plane it springs back by up to that much
  (``off_plane_relief``: 6 % of the opening at the well at 2 mm zones, on vertical
  faces beside the plane near the tip) while its faces still press on each other.
  That is the contact spring's elastic relief, not an opening. The faces that do come
  apart are bonded vertical faces where they meet the open plane, pulled by its
  flanks (measured in docs/decisions/0018-3d-hydromechanics.md).

The cube is confined by an isotropic stress (1 MPa, five to ten times the net
pressures) that holds the plane shut where the fluid has not arrived: the M-vertex
has no fluid lag. The paper does not state its model's confinement. The cut disc
starts full of fluid at the confinement, its faces settled under it (a fracture with
no net pressure); the fluid's books start there.

The confinement presses the plane's broken sub-contacts ``sigma_0 / kn`` past their
3 um floor (5 um at 2 mm zones). Their voids follow the faces through that closure
(:attr:`~grainfrac.physics.flow.FluidProperties.closure_storage`): the fluid that lifts
the faces fills the volume they part by. The M-vertex's medium has no joints, and the
contact springs here are the model's (``CONTACT_STIFFNESS_ZONES``); held at the floor
instead, the voids stayed put while the pressure did work on the faces, and the
books showed that as energy made in proportion to the confinement (-12 % of the
pumped energy at 2 mm zones; measured in docs/decisions/0018-3d-hydromechanics.md).

The cube is not infinite: at 4 ms the reference radius is 14.8 mm, a quarter of the
cube's side, so the free faces soften the response a little (the fracture opens
wider than in an infinite medium).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from grainfrac import materials
from grainfrac.assembly import GrainAssembly, SpecimenConfig, build_assembly
from grainfrac.errors import GrainfracError
from grainfrac.geometry.meshing3d import penny_injection_node, penny_plane_contacts
from grainfrac.io.config import validate
from grainfrac.loading.insitu import initialise_in_situ
from grainfrac.physics import flow
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.physics.kinematics import contact_opening
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.units import MM, MPA
from grainfrac.verification.penny_reference import CASE, KPA, UM, Fig8Case, PennyMVertex
from grainfrac.verification.report import Comparison

#: Tolerances of the issue: radius 10 %, opening at the well 15 %, pressure at R/2 20 %.
RADIUS_TOLERANCE = 0.10
OPENING_TOLERANCE = 0.15
PRESSURE_TOLERANCE = 0.20
#: Off the plane nothing may open by more than this fraction of the opening at the well.
OFF_PLANE_FRACTION = 0.01
#: The fluid volume balance closes to round-off.
VOLUME_BALANCE_TOLERANCE = 1e-9
#: The fluid's energy books close within this fraction of the pumped energy.
BOOKS_TOLERANCE = 0.05
#: A plane sub-contact belongs to the fracture when it is open by more than this
#: fraction of the opening at the injection point.
OPENING_THRESHOLD = 0.05
#: Contact stiffness (kn = ks) x E / zone size: stiff enough that the contacts add
#: about 1/10 of a zone's compliance, soft enough not to set the time step.
CONTACT_STIFFNESS_ZONES = 10.0


@dataclass(frozen=True)
class PennyConfig(Fig8Case):
    """The Fig. 8 case, its grains and its stepping (SI)."""

    # 1 mm: at 2 mm zones the radius at 1 ms, 1.5 zones past the cut disc, is read off
    # rings of grain faces that open a zone at a time (+7 to +16 % over 0.8-1.2 ms,
    # seed 0; decision record 0018); the paper does not state its penny model's zones.
    zone_size: float = 1 * MM
    grain_edges: tuple[float, float] = (3 * MM, 8 * MM)
    fluid_step: float = 1.0e-5  # s
    bulk_modulus: float = 2.0e9  # water (Pa)
    # Isotropic confinement (Pa): holds the plane shut where the fluid has not
    # arrived, as the M-vertex (no fluid lag) assumes; the pressure compared is the
    # net pressure above it. Without it the zero-strength plane opened dry far ahead
    # of the fluid (measured: the whole plane open at 1 ms, 4 mm zones).
    confinement: float = 1.0 * MPA
    in_situ_ratio: float = 1e-5
    in_situ_max_steps: int = 100_000
    # The cut disc starts full of fluid at the confinement (a fracture with no net
    # pressure), not dry and pressed shut: injected into a dry disc, the fluid first
    # spiked the well to 7-8 MPa and blew the faces open, making 3.4 mJ of the books'
    # 11.6 mJ (2 mm zones, seed 0).
    fill_disc: bool = True
    # The plane's voids follow its faces through the confinement's closure (module doc).
    closure_storage: bool = True
    # Fluid steps redone until the pressures fit the voids the mechanics realised
    # (HydroMechanicalSolver fixed_stress_iterations; 0: the plain staggered step,
    # whose books showed 4-9 % of the pumped energy made at the injection start).
    fixed_stress_iterations: int = 8


@dataclass(frozen=True)
class PennyMeasure:
    """The simulated fracture at one time since injection began (SI)."""

    time: float
    radius: float
    dry_rim: float  # open but dry: radius of all the open plane less ``radius``
    opening_well: float
    pressure_half_radius: float
    max_off_plane_opening: float  # largest separation off the plane (m, >= 0)
    off_plane_relief: float  # largest |change of opening| off the plane since injection (m)
    injected: float
    stored_gain: float
    energy: dict[str, float] = field(default_factory=dict)


def penny_recipe(config: PennyConfig) -> materials.RockRecipe:
    """One mineral of the case's E and nu, contacts of ``CONTACT_STIFFNESS_ZONES`` E / zone
    that never break (the plane's are weakened on the model, :func:`penny_run`)."""
    base = materials.homogeneous_recipe("quartz", stiffness_factor=1.0)
    mineral = {**base.minerals[0].model_dump(), "youngs_modulus_GPa": config.young / 1e9,
               "poisson_ratio": config.poisson}
    code = base.minerals[0].code
    stiffness = CONTACT_STIFFNESS_ZONES * config.young / config.zone_size / 1e9  # GPa/m
    contact = {**base.contact(f"{code}-{code}").model_dump(),
               "normal_stiffness_GPa_per_m": stiffness, "shear_stiffness_GPa_per_m": stiffness}
    return materials.RockRecipe.model_validate({
        "name": "penny-block", "minerals": [mineral], "contacts": {f"{code}-{code}": contact},
        "weibull": {"enabled": False}})


def penny_assembly(config: PennyConfig, seed: int = 0) -> GrainAssembly:
    """The cut cube of grains of :func:`penny_recipe`."""
    spec = validate(SpecimenConfig, {
        "seed": seed, "dimension": 3,
        "specimen": {"shape": "penny", "size_mm": config.cube_side / MM,
                     "disc_diameter_mm": config.starter_crack_diameter / MM},
        "grains": {"zone_size_mm": config.zone_size / MM,
                   "min_edge_mm": config.grain_edges[0] / MM,
                   "max_edge_mm": config.grain_edges[1] / MM},
    })
    return build_assembly(spec, penny_recipe(config))


@dataclass
class PennyRun:
    """A penny run: the case, its assembly's plane and the measured states."""

    config: PennyConfig
    n_elements: int
    n_plane_contacts: int
    disc_area: float
    states: list[PennyMeasure] = field(default_factory=list)

    @property
    def reference(self) -> PennyMVertex:
        return self.config.reference()


def penny_run(config: PennyConfig | None = None, seed: int = 0,
              assembly: GrainAssembly | None = None) -> PennyRun:
    """Build the cube, cut the disc, inject at its centre and measure at ``config.times``.

    ``assembly``: the cube as :func:`penny_assembly` built it for this ``config``'s
    geometry and ``seed``, to share between runs that differ in their numerics only
    (it is read, not changed; its build is most of a coarse run's time).
    """
    config = config or PennyConfig()
    if assembly is None:
        assembly = penny_assembly(config, seed)
    mesh = assembly.mesh
    on_plane, in_disc = penny_plane_contacts(mesh)
    mech = MechanicsSolver(build_mechanical_model(assembly))
    m = mech.model
    # The plane: no strength, no friction (zero toughness); the disc is cut from the start.
    m.tensile_strength[on_plane] = 0.0
    m.cohesion[on_plane] = 0.0
    m.tan_friction[on_plane] = 0.0
    mech.bonded[in_disc] = False
    # Confine: start from the uniform strain of the isotropic stress and settle.
    s0 = config.confinement
    lam = config.young * config.poisson / ((1 + config.poisson) * (1 - 2 * config.poisson))
    shear = config.young / (2 * (1 + config.poisson))
    mech.u[:] = -s0 / (3 * lam + 2 * shear) * mesh.node_x
    settled = initialise_in_situ(mech, mesh, s0, s0, s0, ratio=config.in_situ_ratio,
                                 max_steps=config.in_situ_max_steps)
    if not settled.converged:
        raise GrainfracError(f"penny: the confinement did not settle (unbalanced-force "
                             f"ratio {settled.unbalanced_force_ratio:.3g} after "
                             f"{settled.steps} steps)")
    fluid = flow.FluidProperties(viscosity=config.viscosity, bulk_modulus=config.bulk_modulus,
                                 initial_aperture=config.initial_aperture,
                                 residual_aperture=config.initial_aperture,
                                 maximum_aperture=config.maximum_aperture,
                                 closure_storage=config.closure_storage)
    # Flow only in broken sub-contacts: every one is sealed until it breaks.
    injection = penny_injection_node(mesh)
    network = flow.build_flow_network(
        mesh, well=True, wall="flow_knots", well_nodes=[injection],
        sealed=np.ones(mesh.n_contacts, dtype=bool), well_compressibility=1 / config.bulk_modulus)
    hm = HydroMechanicalSolver(assembly, mech, network, fluid,
                               fixed_stress_iterations=config.fixed_stress_iterations)
    if config.fill_disc:
        _fill_disc(hm, in_disc, config)
    run = PennyRun(config, mesh.n_elements, int(on_plane.sum()),
                   float(mesh.contact_area[in_disc].sum()))
    opening0 = contact_opening(assembly, mech.u)
    held0 = hm.state.stored(~network.fixed)
    well = mesh.contact_fluid_node == injection
    r = np.hypot(mesh.contact_x[:, 0], mesh.contact_x[:, 1])
    start = mech.time
    for t in sorted(config.times):
        while mech.time - start < t - 0.5 * m.dt:
            hm.advance(min(config.fluid_step, t - (mech.time - start)), config.rate)
        separation = contact_opening(assembly, mech.u)
        opening = separation - opening0
        w_well = float(np.mean(opening[well & on_plane]))
        # The M-vertex has no fluid lag: the fracture is where the plane is open and
        # holds fluid (a dry, open rim ahead of the fluid is left out).
        wet = mech.contact_pressure[:mesh.n_contacts] > 0.0
        open_ = on_plane & (opening > OPENING_THRESHOLD * w_well)
        radius = math.sqrt(float(mesh.contact_area[open_ & wet].sum()) / math.pi)
        dry_rim = math.sqrt(float(mesh.contact_area[open_].sum()) / math.pi) - radius
        half = on_plane & (np.abs(r - 0.5 * radius) < 0.5 * config.zone_size)
        pressure = float(np.mean(mech.contact_pressure[:mesh.n_contacts][half])) - s0
        run.states.append(PennyMeasure(
            time=mech.time - start, radius=radius, dry_rim=dry_rim, opening_well=w_well,
            pressure_half_radius=pressure,
            max_off_plane_opening=float(np.max(separation[~on_plane], initial=0.0)),
            off_plane_relief=float(np.max(np.abs(opening[~on_plane]))),
            injected=float(hm.state.injected),
            stored_gain=hm.state.stored(~network.fixed) - held0 + hm.state.outflow,
            energy=hm.hydraulic_energy()))
    return run


def _fill_disc(hm: HydroMechanicalSolver, in_disc: np.ndarray, config: PennyConfig) -> None:
    """Fill the cut disc with fluid at the confinement and let its faces settle: the
    fluid then holds them at their initial aperture, under no effective stress."""
    mech = hm.mechanics
    pressure = np.zeros(hm.network.n_unknowns)
    pressure[np.unique(hm.network.contact_unknown[in_disc])] = config.confinement
    hm.saturate(pressure)
    mech.allow_failure = False
    try:
        achieved = mech.equilibrate(ratio=config.in_situ_ratio,
                                    max_steps=config.in_situ_max_steps)
    finally:
        mech.allow_failure = True
    if not achieved < config.in_situ_ratio:
        raise GrainfracError(f"penny: the filled disc did not settle (unbalanced-force "
                             f"ratio {achieved:.3g} after {config.in_situ_max_steps} steps)")
    hm.saturate(pressure)  # at the settled apertures: the books start here


def penny(seed: int = 0, *, zone_size_mm: float | None = None,
          config: PennyConfig | None = None) -> list[Comparison]:
    """The penny-shaped fracture against the M-vertex (module doc): radius, opening at the
    well and net pressure at half the radius at 1, 2 and 4 ms; off-plane opening, volume
    balance and the fluid's energy books. ``zone_size_mm`` (``--zone-size``) replaces the
    config's zone size (default 1 mm; about 30 min on two threads; 2 mm about 4 min)."""
    config = config or PennyConfig()
    if zone_size_mm is not None:
        config = replace(config, zone_size=zone_size_mm * MM)
    run = penny_run(config, seed)
    ref = run.reference
    rows: list[Comparison] = []
    for s in run.states:
        tag = f"t{s.time * 1e3:.0f}ms"
        rows += [
            Comparison(CASE, f"{tag}_radius_mm", s.radius / MM, float(ref.radius(s.time)) / MM,
                       RADIUS_TOLERANCE),
            Comparison(CASE, f"{tag}_opening_well_um", s.opening_well / UM,
                       float(ref.opening_at_well(s.time)) / UM, OPENING_TOLERANCE),
            Comparison(CASE, f"{tag}_net_pressure_half_radius_kPa",
                       s.pressure_half_radius / KPA,
                       float(ref.pressure_at_half_radius(s.time)) / KPA, PRESSURE_TOLERANCE),
        ]
    last = run.states[-1]
    books = last.energy
    off_plane = max(s.max_off_plane_opening / s.opening_well for s in run.states)
    rows += [
        # Compared as 1 + x against 1: the relative error is x (the largest at any time).
        Comparison(CASE, "off_plane_separation_over_well_opening", 1.0 + off_plane, 1.0,
                   OFF_PLANE_FRACTION),
        Comparison(CASE, "fluid_volume_stored_plus_outflow_m3", last.stored_gain,
                   last.injected, VOLUME_BALANCE_TOLERANCE),
        Comparison(CASE, "fluid_energy_accounted_J", books["pumped"] - books["residual"],
                   books["pumped"], BOOKS_TOLERANCE),
    ]
    return rows
