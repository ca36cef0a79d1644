"""Hydraulic verification in 3D: the cubic law on one grain face, permeability against a0.

Two checks of the grain-face flow graph of
:class:`~grainfrac.geometry.meshing3d.GrainMesh3D` (pipes along the edges of
each face's triangulation, widths from the cotangent weights) through the
production flow network of :mod:`grainfrac.physics.flow` (``grainfrac verify
cubic-law3d``):

Single planar face
    Two box grains side by side share one rectangular face, the plane
    ``x = 0``, of length ``L`` along y and width ``W`` along z, meshed by the
    production mesher (:func:`~grainfrac.geometry.meshing3d.mesh_grains3d`,
    jittered edge points and face lattice, 2D Delaunay). With ``dp`` on the
    ``y+`` edge, 0 on the ``y-`` edge, the ``z`` edges and the rest of the
    specimen sealed, every sub-contact at aperture ``a`` and no mechanics, the
    steady rate is the parallel-plate rate ``q = a^3 / (12 mu) * W * dp / L``
    and the pressure is linear in y. The cotangent weights are the linear
    finite element's, which reproduces a linear pressure exactly, so both
    agree to the solve's round-off, except where the mesher clamps a negative
    weight to zero (an obtuse corner opposite a face-boundary edge; the
    clamped pipe conducts a little more than the linear element). Measured on
    the 40 x 20 mm face at 2 mm zones (about 256 fluid nodes), seeds 0-15:
    rate within 6e-15 and profile within 4e-15 of dp, except seeds 4, 8 and
    10 (one clamped pipe each): rate +1.4e-4, +2.8e-4, +1.7e-4, profile 8e-4,
    1.8e-3, 1e-3 of dp. A transient run from rest (backward-Euler steps of a
    fiftieth of the face's diffusion time ``12 mu L^2 / (a^2 K_w)``, to a
    fifth of it) checks the volume balance: the fluid stored by compression,
    from the pressures and from the network's own content bookkeeping,
    against the net inflow through the two edges summed step by step.
    Measured: 5e-15 to 1.4e-12 of the net inflow (seeds 0-15), which is
    round-off: the stored volume is only ``p / K_w`` ~ 2e-4 of the fluid the
    face holds, whose sums carry ~1e-16 of it.

Permeability of a grain assembly against a0 (paper Sect. 3.2, Eq. 8, Table 4)
    A box of Voronoi grains (the lab specimen's 45 mm height along x, its 22.5
    mm diameter as a 22.5 x 22.5 mm square section, paper grain edges 3-8 mm
    and 2 mm zones; 28 grains at seeds 0-2), no borehole, ``P_in = 8 MPa`` on
    ``x-`` and 0 on ``x+``, the y and z sides sealed, every sub-contact at
    ``a0`` (no mechanics), solved to steady state;
    ``k = Q mu L / (A dP)`` with ``L`` the x extent and ``A`` the y-z
    section. With one aperture everywhere the steady pressures do not depend
    on it and ``Q`` scales as ``a0^3``: the fitted log-log exponent over
    a0 = 0.1-2 um is 3 to round-off (measured 3 + 1.3e-15, 2.2e-15,
    9.8e-15 at seeds 0, 1, 2). The exponent is blind to a constant factor, so
    ``k`` at the paper's a0 = 0.2 um is also compared with the linear-field
    (Snow / Oda) estimate: the linear pressure ``p = P_in (1 - x / L)`` on every
    face gives ``k_lin = a0^3 / 12 * sum_f A_f (1 - n_x^2) / V`` (``A_f``, ``n_f``
    the area and unit normal of each grain face, ``V`` the box volume), an
    upper bound for a network of linear elements (the steady solution
    dissipates least; a clamped weight can lift the network a hair above it).
    Measured at a0 = 0.2 um: k = 8.95e-20, 8.82e-20, 8.94e-20 m2 at seeds 0, 1,
    2, 2.9-3.1 % below ``k_lin``; the lab value (Kumari et al. 2018) is 1e-19 m2.
"""

from __future__ import annotations

import numpy as np

from grainfrac import materials
from grainfrac.assembly import GrainSpec, SpecimenConfig, build_assembly
from grainfrac.geometry.meshing3d import GrainMesh3D, mesh_grains3d
from grainfrac.geometry.solids3d import BOX_SIDES, box_solid
from grainfrac.geometry.tessellation3d import GrainComplex
from grainfrac.io.config import validate
from grainfrac.physics import flow
from grainfrac.units import ML_PER_MIN, MM
from grainfrac.verification.hydraulic import (
    CUBIC_LAW_TOLERANCE,
    TABLE4_APERTURE_M,
    TABLE4_PRESSURE_IN,
    TABLE4_PRESSURE_OUT,
    side_inflow,
)
from grainfrac.verification.report import Comparison

CASE = "cubic-law3d"
# The conservative backward-Euler step closes the volume balance to round-off
# (measured <= 1.4e-12 of the net inflow; module notes).
BALANCE_TOLERANCE = 1e-9
# The exponent tolerance, 3 +- 0.1, as a relative one.
EXPONENT_TOLERANCE = 0.1 / 3.0
# k at a0 = 0.2 um against the linear-field estimate (measured 3 % below it).
LINEAR_FIELD_TOLERANCE = 0.10
# Steady state in one backward-Euler step: at this many times the explicit limit
# min(V c / sum C) the storage term is 1e-20 of every node's conductance sum, far
# below round-off even for the slowest mode of the network.
STEADY_DT_FACTOR = 1e20
# Transient run: steps of this fraction of the face's diffusion time, this many.
TRANSIENT_STEP_FRACTION = 0.02
TRANSIENT_STEPS = 10

#: The single face: length (along y, between the fixed edges) and width (along z), mm.
FACE_LENGTH_MM = 40.0
FACE_WIDTH_MM = 20.0
#: Depth of the two-grain box across the face (along x), mm.
FACE_BOX_DEPTH_MM = 24.0
#: Initial apertures of the permeability curve (m).
PERMEABILITY_APERTURES = (1e-7, 2e-7, 5e-7, 1e-6, 2e-6)
#: Permeability box (mm): the lab specimen's height along x, its diameter as a square
#: section in y and z (paper Table 4, as :mod:`grainfrac.verification.hydraulic`).
PERMEABILITY_BOX_MM = (45.0, 22.5, 22.5)


# -- building blocks -------------------------------------------------------------------------
def two_grain_box(length_mm: float = FACE_LENGTH_MM, width_mm: float = FACE_WIDTH_MM,
                  depth_mm: float = FACE_BOX_DEPTH_MM) -> GrainComplex:
    """Two box grains sharing the single rectangular face ``x = 0``.

    The box spans ``depth`` along x (centred), ``length`` along y (centred)
    and ``width`` along z (from 0), as :func:`~grainfrac.geometry.solids3d.box_solid`
    places a slab. Grain 0 is ``x < 0``, grain 1 ``x > 0``; each is three
    slab pieces along x, so the grain face between them is one polygon.
    Three pieces and not one: :meth:`GrainComplex.face_grains` looks up the
    side codes ``-1 - k`` of surface faces in the piece table before discarding
    them, which raises on a complex of fewer than six pieces.
    """
    # No borehole: box_solid's zone size (which sizes borehole facets) plays no part.
    solid = box_solid("slab", depth_mm, length_mm, width_mm, 0.0, zone_size=1.0)
    xs = np.linspace(solid.lo[0], solid.hi[0], 7)
    grid = (xs, np.array([solid.lo[1], solid.hi[1]]), np.array([solid.lo[2], solid.hi[2]]))
    shape = tuple(len(g) for g in grid)
    vertices = np.stack(np.meshgrid(*grid, indexing="ij"), axis=-1).reshape(-1, 3)

    faces, face_pieces, face_normal = [], [], []
    n_pieces = len(xs) - 1
    piece_faces: list[list[int]] = [[] for _ in range(n_pieces)]

    def add(axis: int, at: int, span: tuple, sign: float, inside: int, outside: int) -> None:
        # Corners counter-clockwise about +e_axis (e_i x e_j = e_axis), reversed for a
        # face whose outward normal (out of ``inside``) is -e_axis.
        i, j = (axis + 1) % 3, (axis + 2) % 3
        ring = []
        for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
            idx = [0, 0, 0]
            idx[axis], idx[i], idx[j] = at, span[i][a], span[j][b]
            ring.append(int(np.ravel_multi_index(idx, shape)))
        normal = np.zeros(3)
        normal[axis] = sign
        for p in (inside, outside):
            if p >= 0:
                piece_faces[p].append(len(faces))
        faces.append(np.array(ring if sign > 0 else ring[::-1]))
        face_pieces.append((inside, outside))
        face_normal.append(normal)

    def side(name: str) -> int:
        return -1 - BOX_SIDES.index(name)

    for p in range(n_pieces):
        span = ((p, p + 1), (0, 1), (0, 1))
        if p == 0:
            add(0, 0, span, -1.0, 0, side("x-"))
        add(0, p + 1, span, 1.0, p, p + 1 if p + 1 < n_pieces else side("x+"))
        for axis, name in ((1, "y"), (2, "z")):
            add(axis, 0, span, -1.0, p, side(f"{name}-"))
            add(axis, 1, span, 1.0, p, side(f"{name}+"))
    centres = 0.5 * (xs[:-1] + xs[1:])
    return GrainComplex(
        solid=solid,
        vertices=vertices,
        faces=tuple(faces),
        face_pieces=np.array(face_pieces, dtype=np.int64),
        face_normal=np.array(face_normal),
        piece_grain=(np.arange(n_pieces) >= n_pieces // 2).astype(np.int64),
        piece_faces=tuple(np.array(f, dtype=np.int64) for f in piece_faces),
        seeds=np.column_stack((centres, np.full(n_pieces, 0.5 * (solid.lo[1] + solid.hi[1])),
                               np.full(n_pieces, 0.5 * (solid.lo[2] + solid.hi[2])))),
        piece_ring=np.zeros(n_pieces, dtype=bool),
    )


def two_grain_face(length_mm: float = FACE_LENGTH_MM, width_mm: float = FACE_WIDTH_MM,
                   zone_size: float = 2.0 * MM, seed: int = 0) -> GrainMesh3D:
    """The production mesh of :func:`two_grain_box`: the face's points are jittered
    with the random generator of ``seed``, so each seed is another triangulation."""
    return mesh_grains3d(two_grain_box(length_mm, width_mm), zone_size,
                         np.random.default_rng(seed))


def steady_state(network: flow.FlowNetwork, aperture: np.ndarray,
                 fluid: flow.FluidProperties) -> flow.FluidState:
    """Steady pressures in one production implicit step from rest.

    The step is ``STEADY_DT_FACTOR`` times the explicit stability limit, so the
    storage term drops below round-off and the solve is the steady one
    (fixed pressures, no flow through the other sides). Only the pressures are
    meaningful afterwards: the step's content update multiplies the solve's
    round-off residual by the huge step.
    """
    state = flow.initial_state(network, aperture, fluid)
    dt = STEADY_DT_FACTOR * flow.stable_explicit_dt(network, aperture, fluid)
    flow.implicit_step(network, state, aperture, dt, fluid)
    return state


def _eos_stored(network: flow.FlowNetwork, state: flow.FluidState, aperture: np.ndarray,
                fluid: flow.FluidProperties) -> float:
    """Fluid held by the free unknowns from their pressures (m3 at reference density):
    ``sum V (1 + p / Kw)``, independent of the content bookkeeping."""
    v = flow.storage_volume(network, aperture)
    free = ~network.fixed
    return float(np.sum(v[free] * (1.0 + state.pressure[free] / fluid.bulk_modulus)))


# -- the single face ---------------------------------------------------------------------
def face_flow(mesh: GrainMesh3D, aperture: float, pressure_drop: float,
              fluid: flow.FluidProperties) -> dict:
    """Steady flow across the face of :func:`two_grain_face`, ``y+`` at ``pressure_drop``.

    Returns the steady rate (``rate_m3_s``, the mean of the inflow at ``y+``
    and the outflow at ``y-``), both of them, the cubic-law rate
    (``expected_m3_s``) and the largest deviation of the node pressures from
    the linear profile as a fraction of ``pressure_drop``
    (``profile_error``).
    """
    network = flow.build_flow_network(
        mesh, permeable_sides={"y+": pressure_drop, "y-": 0.0}, well=False)
    apertures = np.full(mesh.n_contacts, aperture)
    state = steady_state(network, apertures, fluid)
    solid = mesh.grains.solid
    length, width = float(solid.extent[1]), float(solid.extent[2])
    inflow = side_inflow(network, state.pressure, apertures, fluid, "y+")
    outflow = -side_inflow(network, state.pressure, apertures, fluid, "y-")
    y = mesh.fluid_node_x[:, 1]
    linear = pressure_drop * (y - solid.lo[1]) / length
    profile = state.pressure[network.unknown_of_node]
    return {
        "rate_m3_s": 0.5 * (inflow + outflow),
        "inflow_m3_s": inflow,
        "outflow_m3_s": outflow,
        "expected_m3_s": aperture**3 / (12.0 * fluid.viscosity) * width * pressure_drop / length,
        "profile_error": float(np.max(np.abs(profile - linear))) / pressure_drop,
    }


def face_volume_balance(mesh: GrainMesh3D, aperture: float, pressure_drop: float,
                        fluid: flow.FluidProperties, *, steps: int = TRANSIENT_STEPS,
                        step_fraction: float = TRANSIENT_STEP_FRACTION) -> dict:
    """Transient filling of the face from rest: the volume balance of the production step.

    ``y+`` jumps to ``pressure_drop`` at t = 0 (``y-`` stays at 0); ``steps``
    backward-Euler steps of ``step_fraction`` of the face's diffusion time
    ``T = L^2 / D``, ``D = a^2 Kw / (12 mu)`` (parallel plates with rigid walls:
    conductance ``a^3 / (12 mu)`` over storage ``a / Kw`` per unit area).
    Returns the fluid stored meanwhile (``stored_m3``, from the pressures by the
    equation of state), the same from the network's content bookkeeping
    (``stored_content_m3``), the net inflow through the two edges summed over
    the steps from their pipe flows (``net_inflow_m3``), the net inflow that
    the network booked (``booked_inflow_m3``, minus its outflow) and the
    largest of the three mismatches with ``net_inflow_m3`` as a fraction of
    it (``balance_error``).
    """
    network = flow.build_flow_network(
        mesh, permeable_sides={"y+": pressure_drop, "y-": 0.0}, well=False)
    apertures = np.full(mesh.n_contacts, aperture)
    length = float(mesh.grains.solid.extent[1])
    diffusivity = aperture**2 * fluid.bulk_modulus / (12.0 * fluid.viscosity)
    dt = step_fraction * length**2 / diffusivity
    state = flow.initial_state(network, apertures, fluid)
    free = ~network.fixed
    eos0, content0 = _eos_stored(network, state, apertures, fluid), state.stored(free)
    net_inflow = 0.0
    for _ in range(steps):
        flow.implicit_step(network, state, apertures, dt, fluid)
        # Backward Euler: the step's flows are those of its new pressures.
        net_inflow += dt * (side_inflow(network, state.pressure, apertures, fluid, "y+")
                            + side_inflow(network, state.pressure, apertures, fluid, "y-"))
    stored = _eos_stored(network, state, apertures, fluid) - eos0
    stored_content = state.stored(free) - content0
    booked = state.injected - state.outflow
    error = max(abs(x - net_inflow) for x in (stored, stored_content, booked)) / abs(net_inflow)
    return {
        "stored_m3": stored,
        "stored_content_m3": stored_content,
        "net_inflow_m3": net_inflow,
        "booked_inflow_m3": booked,
        "balance_error": error,
        "time_s": steps * dt,
        "mean_pressure_fraction": float(np.mean(state.pressure[free])) / pressure_drop,
    }


def face_rows(seed: int = 0, *, aperture: float = 2e-5, pressure_drop: float = 1e6,
              fluid: flow.FluidProperties | None = None) -> list[Comparison]:
    """The single-face comparisons of :func:`cubic_law3d` on the mesh of ``seed``."""
    fluid = fluid or flow.FluidProperties()
    mesh = two_grain_face(seed=seed)
    steady = face_flow(mesh, aperture, pressure_drop, fluid)
    balance = face_volume_balance(mesh, aperture, pressure_drop, fluid)
    return [
        Comparison(CASE, "face_flow_rate_ml_per_min", steady["rate_m3_s"] / ML_PER_MIN,
                   steady["expected_m3_s"] / ML_PER_MIN, CUBIC_LAW_TOLERANCE),
        # Against zero the relative error is the absolute value, here a fraction of dp.
        Comparison(CASE, "face_pressure_profile_max_deviation_fraction_of_dp",
                   steady["profile_error"], 0.0, CUBIC_LAW_TOLERANCE),
        # A fraction of the fluid that entered, against zero.
        Comparison(CASE, "face_transient_volume_balance_error_fraction",
                   balance["balance_error"], 0.0, BALANCE_TOLERANCE),
    ]


# -- permeability of a grain assembly -----------------------------------------------------
def permeability_box(seed: int = 0, *,
                     recipe: str | materials.RockRecipe = "strathbogie-granite",
                     grains: GrainSpec | None = None,
                     box_mm: tuple[float, float, float] = PERMEABILITY_BOX_MM) -> GrainMesh3D:
    """The 3D mesh of the permeability box (x, y, z extents in mm, no borehole)."""
    config = validate(SpecimenConfig, {
        "dimension": 3, "seed": seed, "rock": recipe,
        "specimen": {"shape": "slab", "width_mm": box_mm[0], "height_mm": box_mm[1],
                     "thickness_mm": box_mm[2], "borehole_diameter_mm": 0.0},
        "grains": (grains or GrainSpec()).model_dump(),
    })
    return build_assembly(config, config.recipe()).mesh


def linear_field_permeability(mesh: GrainMesh3D, initial_aperture: float,
                              axis: int = 0) -> float:
    """Permeability along ``axis`` (m2) of the grain faces under the linear pressure field.

    Every grain face at ``initial_aperture`` carries the cubic-law flux of the
    applied gradient projected onto its plane: ``k_lin = a^3 / 12 * sum_f A_f
    (1 - n_axis^2) / V`` (Snow / Oda), from the grain complex's own polygons and
    the solid's volume ``V``, not the mesh.
    """
    cx = mesh.grains
    faces = cx.interface_faces()
    area = cx.face_areas()[faces]
    n_axis = cx.face_normal[faces, axis]
    return (initial_aperture**3 / 12.0 * float(np.sum(area * (1.0 - n_axis**2)))
            / cx.solid.volume)


def measure_permeability3d(mesh: GrainMesh3D, initial_aperture: float = TABLE4_APERTURE_M, *,
                           fluid: flow.FluidProperties | None = None,
                           pressure_in: float = TABLE4_PRESSURE_IN,
                           pressure_out: float = TABLE4_PRESSURE_OUT,
                           inlet: str = "x-", outlet: str = "x+") -> dict:
    """Constant-head test (paper Eq. 8) on a 3D prism: ``inlet`` at ``pressure_in``,
    ``outlet`` at ``pressure_out``.

    ``inlet`` and ``outlet`` are the two flat end sides of one axis (``x-``/``x+``
    of the permeability box, ``z+``/``z-`` of the lab cylinder). Every sub-contact
    at ``initial_aperture``, the other sides sealed, steady state by
    :func:`steady_state`. Returns the inflow at the inlet (``flow_rate_m3_s``),
    the outflow at the outlet, ``k = Q mu L / (A dP)`` (``permeability_m2``, ``L``
    the length between the ends, ``A = V / L`` the solid's section) and the
    linear-field estimate (``linear_field_m2``).
    """
    fluid = fluid or flow.FluidProperties()
    solid = mesh.grains.solid
    ends = {f.name: f for f in solid.flat_sides}
    for role, name in (("inlet", inlet), ("outlet", outlet)):
        if name not in ends:
            raise ValueError(f"{role}: {name!r} is not a flat side of the {solid.kind} "
                             f"(flat sides: {', '.join(ends)})")
    axis = ends[inlet].axis
    if ends[outlet].axis != axis or inlet == outlet:
        raise ValueError(f"outlet: must be the side opposite {inlet!r} (got {outlet!r})")
    network = flow.build_flow_network(
        mesh, permeable_sides={inlet: pressure_in, outlet: pressure_out}, well=False)
    aperture = np.full(mesh.n_contacts, initial_aperture)
    state = steady_state(network, aperture, fluid)
    q_in = side_inflow(network, state.pressure, aperture, fluid, inlet)
    q_out = -side_inflow(network, state.pressure, aperture, fluid, outlet)
    length = float(solid.extent[axis])
    area = solid.volume / length
    head = abs(pressure_in - pressure_out)
    return {
        "initial_aperture_m": initial_aperture,
        "permeability_m2": q_in * fluid.viscosity * length / (area * head),
        "linear_field_m2": linear_field_permeability(mesh, initial_aperture, axis),
        "flow_rate_m3_s": q_in,
        "outflow_m3_s": q_out,
        "area_m2": area,
        "length_m": length,
        "pressure_drop_Pa": head,
        "n_grains": mesh.grains.n_grains,
        "n_fluid_nodes": len(mesh.fluid_node_x),
    }


def permeability_exponent(apertures, permeabilities) -> float:
    """Slope of ``log k`` against ``log a0`` (least squares)."""
    return float(np.polyfit(np.log(apertures), np.log(permeabilities), 1)[0])


def permeability_rows(seed: int = 0, *, apertures=PERMEABILITY_APERTURES,
                      fluid: flow.FluidProperties | None = None,
                      box_mm: tuple[float, float, float] = PERMEABILITY_BOX_MM,
                      ) -> list[Comparison]:
    """The permeability comparisons of :func:`cubic_law3d` on the box of ``seed``."""
    mesh = permeability_box(seed, box_mm=box_mm)
    runs = [measure_permeability3d(mesh, a0, fluid=fluid) for a0 in apertures]
    exponent = permeability_exponent(apertures, [r["permeability_m2"] for r in runs])
    table4 = measure_permeability3d(mesh, TABLE4_APERTURE_M, fluid=fluid)
    a0_um = f"{TABLE4_APERTURE_M * 1e6:g}".replace(".", "_")
    return [
        Comparison(CASE, "permeability_exponent_in_a0", exponent, 3.0, EXPONENT_TOLERANCE),
        Comparison(CASE, f"permeability_a0_{a0_um}um_m2", table4["permeability_m2"],
                   table4["linear_field_m2"], LINEAR_FIELD_TOLERANCE),
    ]


# -- the case ---------------------------------------------------------------------------
def cubic_law3d(seed: int = 0, *, aperture: float = 2e-5, pressure_drop: float = 1e6,
                apertures=PERMEABILITY_APERTURES,
                fluid: flow.FluidProperties | None = None) -> list[Comparison]:
    """The 3D cubic law on one grain face and the permeability of a 3D assembly.

    Parameters
    ----------
    seed
        Jitter of the single face's mesh, and the grain structure of the box.
    aperture
        Aperture of every sub-contact of the single face (m).
    pressure_drop
        Pressure on the face's ``y+`` edge (Pa); its ``y-`` edge is at 0.
    apertures
        Initial apertures of the permeability fit (m).
    fluid
        Fluid properties (default water, paper Table 4).

    Returns five comparisons (module notes): ``face_flow_rate_ml_per_min``
    against the cubic law and ``face_pressure_profile_max_deviation_fraction_of_dp``
    against 0 (1 % each), ``face_transient_volume_balance_error_fraction``
    against 0 (``BALANCE_TOLERANCE``), ``permeability_exponent_in_a0`` against
    3 (+- 0.1) and ``permeability_a0_0_2um_m2`` against the linear-field
    estimate (10 %).
    """
    return (face_rows(seed, aperture=aperture, pressure_drop=pressure_drop, fluid=fluid)
            + permeability_rows(seed, apertures=apertures, fluid=fluid))
