"""Hydraulic verification: the cubic law in one channel, and intact permeability.

Two checks of the grain-boundary flow network of :mod:`grainfrac.physics.flow`:

``cubic-law``
    Two rectangular grains side by side share one straight grain boundary
    (the line ``x = 0`` from the bottom to the top of the specimen). With a
    fixed pressure ``dp`` on the top and 0 on the bottom, every sub-contact at
    aperture ``a`` and no mechanics, the steady flow rate along the channel is
    the parallel-plate (cubic-law) rate ``q = a^3 / (12 mu) * w * dp / L``
    (``w`` the slab thickness, ``L`` the channel length) and the pressure falls
    linearly from top to bottom. The network is run to steady state with the
    production implicit step, so this checks the conductances, the fixed
    pressure rows and the solve together.

Permeability (paper Sect. 3.2, Eq. 8, Table 4)
    Constant-head test on the intact assembly: ``P_in = 8 MPa`` on the top,
    ``P_out = 0`` on the bottom, left and right impermeable, run until the
    pressures stabilise; ``k = Q mu H / (A dP)`` with ``Q`` the flow into the
    top face. The lab specimen (Kumari et al. 2018) is a cylinder of diameter
    22.5 mm and height 45 mm: ``A = pi (22.5 mm)^2 / 4 = 3.98e-4 m2`` and
    ``H = 0.045 m`` are Table 4's values. Its 2D section here is a rectangle
    22.5 mm wide and 45 mm high, 22.5 mm thick, and ``A`` is the section's own
    cross-section ``width x thickness``; ``Q`` is proportional to the
    thickness too, so ``k`` does not depend on it. The assembly is intact and
    unloaded: no mechanics runs, every sub-contact sits at its initial
    aperture ``a0`` (the residual aperture is set to ``a0``, as the paper
    calibrates the residual aperture), which is what the mechanics at zero
    load gives (zero opening, clamped to ``[a_res, a_max]``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from grainfrac import materials
from grainfrac.assembly import GrainSpec, SpecimenConfig, build_assembly
from grainfrac.errors import GrainfracError
from grainfrac.geometry.meshing import GrainMesh, mesh_grains
from grainfrac.geometry.specimens import RectangleSpec, outline
from grainfrac.geometry.tessellation import GrainMap
from grainfrac.physics import flow
from grainfrac.units import ML_PER_MIN, MM, MPA
from grainfrac.verification.report import Comparison

CASE = "cubic-law"
# The tolerance for the cubic-law rate and the linear pressure profile.
CUBIC_LAW_TOLERANCE = 0.01
# Steady state: the largest pressure change in a step, relative to the head, below this.
STEADY_TOLERANCE = 1e-8

# Paper Table 4 (constant-head permeability test) and Sect. 3.2.
TABLE4_PRESSURE_IN = 8.0 * MPA
TABLE4_PRESSURE_OUT = 0.0
TABLE4_AREA_M2 = 3.98e-4  # pi (22.5 mm)^2 / 4, the lab cylinder's cross-section
TABLE4_HEIGHT_M = 0.045
TABLE4_APERTURE_M = 2.0e-7
EXPERIMENTAL_PERMEABILITY_M2 = 1.0e-19  # intact Strathbogie granite, Kumari et al. (2018)
PERMEABILITY_SPECIMEN = RectangleSpec(width_mm=22.5, height_mm=45.0, thickness_mm=22.5)


# -- building blocks -------------------------------------------------------------------------
def two_grain_channel(width_mm: float = 20.0, height_mm: float = 50.0,
                      thickness_mm: float = 10.0, zone_size: float = 2.0 * MM) -> GrainMesh:
    """Mesh of two rectangular grains side by side, split along ``x = 0``.

    The only grain boundary is the straight line ``x = 0`` from the bottom to
    the top of the rectangle: one channel of length ``height``.
    """
    shape = outline(RectangleSpec(width_mm=width_mm, height_mm=height_mm,
                                  thickness_mm=thickness_mm), zone_size)
    w, h = width_mm * MM / 2, height_mm * MM / 2
    vertices = np.array([[-w, -h], [0.0, -h], [w, -h], [w, h], [0.0, h], [-w, h]])
    rings = (np.array([0, 1, 4, 5]), np.array([1, 2, 3, 4]))  # counter-clockwise
    on_boundary = np.ones(len(vertices), dtype=bool)  # every vertex lies on the outline
    return mesh_grains(GrainMap(shape, vertices, rings, on_boundary), zone_size)


def side_inflow(network: flow.FlowNetwork, pressure: np.ndarray, aperture: np.ndarray,
                fluid: flow.FluidProperties, side: str) -> float:
    """Flow rate (m3/s) from the fixed-pressure nodes of ``side`` into the network.

    Positive where fluid enters through that side; the sum of
    ``C (p_side - p_neighbour)`` over the pipes that leave the side's nodes.
    """
    ids = network.unknown_of_node[network.mesh.fluid_node_sets[side]]
    on_side = np.zeros(network.n_unknowns, dtype=bool)
    on_side[ids] = True
    on_side &= network.fixed
    cond = flow.pipe_conductance(network, aperture, fluid)
    i, j = network.pipe_unknowns[:, 0], network.pipe_unknowns[:, 1]
    q_ij = cond * (pressure[i] - pressure[j])  # from i to j
    out = np.where(on_side[i] & ~on_side[j], q_ij, 0.0)
    out -= np.where(on_side[j] & ~on_side[i], q_ij, 0.0)
    return float(out.sum())


def run_to_steady_state(network: flow.FlowNetwork, aperture: np.ndarray,
                        fluid: flow.FluidProperties, *, head: float,
                        tolerance: float = STEADY_TOLERANCE,
                        max_steps: int = 400) -> tuple[flow.FluidState, int]:
    """Implicit steps from rest until no pressure changes by more than ``tolerance * head``.

    The first step is 100 times the explicit stability limit and each next
    one twice the previous (backward Euler is stable at any step and tends to
    the steady solve as the step grows). Returns the state and the steps taken.
    """
    state = flow.initial_state(network, aperture, fluid)
    dt = 100.0 * flow.stable_explicit_dt(network, aperture, fluid)
    for step in range(1, max_steps + 1):
        before = state.pressure.copy()
        flow.implicit_step(network, state, aperture, dt, fluid)
        if np.max(np.abs(state.pressure - before)) < tolerance * head:
            return state, step
        dt *= 2.0
    raise GrainfracError(f"no steady state after {max_steps} implicit steps")


# -- the cubic-law case ------------------------------------------------------------------
def cubic_law(aperture: float = 2e-5, pressure_drop: float = 1e6, seed: int = 0,
              fluid: flow.FluidProperties | None = None) -> list[Comparison]:
    """Steady flow along one straight grain boundary against the cubic law.

    Parameters
    ----------
    aperture
        Hydraulic aperture of every sub-contact (m).
    pressure_drop
        Pressure on the top side (Pa); the bottom side is at 0.
    seed
        Unused (the geometry is deterministic); kept for the verify interface.
    fluid
        Fluid properties (default water, paper Table 4).

    Returns two comparisons, tolerance 1 % each: ``flow_rate_ml_per_min``,
    the steady flow rate (mean of the inflow at the top and the outflow at the
    bottom) against the cubic law, and
    ``pressure_profile_max_deviation_fraction_of_dp``, the largest deviation of
    the channel pressures from the linear profile as a fraction of
    ``pressure_drop``, against 0 (so its error is that fraction itself).
    """
    del seed
    fluid = fluid or flow.FluidProperties()
    mesh = two_grain_channel()
    network = flow.build_flow_network(
        mesh, permeable_sides={"top": pressure_drop, "bottom": 0.0}, well=False)
    apertures = np.full(mesh.n_contacts, aperture)
    state, _ = run_to_steady_state(network, apertures, fluid, head=pressure_drop)

    y = mesh.fluid_node_xy[:, 1]
    length = float(y.max() - y.min())
    expected = aperture**3 / (12.0 * fluid.viscosity) * mesh.thickness * pressure_drop / length
    inflow = side_inflow(network, state.pressure, apertures, fluid, "top")
    outflow = -side_inflow(network, state.pressure, apertures, fluid, "bottom")
    rate = 0.5 * (inflow + outflow)

    linear = pressure_drop * (y - y.min()) / length
    p_nodes = state.pressure[network.unknown_of_node]
    profile_error = float(np.max(np.abs(p_nodes - linear))) / pressure_drop
    return [
        Comparison(CASE, "flow_rate_ml_per_min", rate / ML_PER_MIN, expected / ML_PER_MIN,
                   CUBIC_LAW_TOLERANCE),
        # Against zero the relative error is the absolute value, here a fraction of dp.
        Comparison(CASE, "pressure_profile_max_deviation_fraction_of_dp", profile_error, 0.0,
                   CUBIC_LAW_TOLERANCE),
    ]


# -- permeability (paper Sect. 3.2) ---------------------------------------------------------
def permeability_mesh(recipe: str | materials.RockRecipe = "strathbogie-granite",
                      seed: int = 0, grains: GrainSpec | None = None) -> GrainMesh:
    """The intact assembly of the permeability test (22.5 x 45 mm section, 22.5 mm thick)."""
    config = SpecimenConfig(seed=seed, rock=recipe, specimen=PERMEABILITY_SPECIMEN,
                            grains=grains or GrainSpec())
    return build_assembly(config, config.recipe()).mesh


def measure_permeability(mesh: GrainMesh, initial_aperture: float = TABLE4_APERTURE_M, *,
                         fluid: flow.FluidProperties | None = None,
                         pressure_in: float = TABLE4_PRESSURE_IN,
                         pressure_out: float = TABLE4_PRESSURE_OUT,
                         sealed: np.ndarray | None = None) -> dict:
    """Constant-head test on a meshed rectangle: top at ``pressure_in``, bottom at ``pressure_out``.

    Every sub-contact is at ``initial_aperture`` (intact, unloaded: see the
    module notes); ``sealed`` sub-contacts (intact grain interiors) carry no
    flow. Returns the flow rate into the top (``flow_rate_m3_s``), out of the
    bottom (``outflow_m3_s``), the permeability of Eq. (8) with ``A = width x
    thickness`` and ``H`` the height, and the steps to steady state.
    """
    fluid = replace(fluid or flow.FluidProperties(), initial_aperture=initial_aperture,
                    residual_aperture=initial_aperture)
    network = flow.conducting(flow.build_flow_network(
        mesh, permeable_sides={"top": pressure_in, "bottom": pressure_out}, well=False,
        sealed=sealed))
    aperture = flow.pore_aperture(np.zeros(mesh.n_contacts), fluid)
    head = abs(pressure_in - pressure_out)
    state, steps = run_to_steady_state(network, aperture, fluid, head=head)
    q_in = side_inflow(network, state.pressure, aperture, fluid, "top")
    q_out = -side_inflow(network, state.pressure, aperture, fluid, "bottom")
    lo, hi = mesh.grains.vertices.min(axis=0), mesh.grains.vertices.max(axis=0)
    width, height = float(hi[0] - lo[0]), float(hi[1] - lo[1])
    area = width * mesh.thickness
    k = q_in * fluid.viscosity * height / (area * head)
    return {
        "initial_aperture_m": initial_aperture,
        "permeability_m2": float(k),
        "flow_rate_m3_s": q_in,
        "outflow_m3_s": q_out,
        "mean_flow_per_width_m2_s": q_in / mesh.thickness,
        "steps": steps,
        "area_m2": area,
        "height_m": height,
        "pressure_drop_Pa": head,
        "n_grains": mesh.grains.n_grains,
        "n_fluid_nodes": len(mesh.fluid_node_xy),
    }


def permeability(recipe: str | materials.RockRecipe = "strathbogie-granite",
                 initial_aperture: float = TABLE4_APERTURE_M, seed: int = 0, *,
                 grains: GrainSpec | None = None, fluid: flow.FluidProperties | None = None,
                 pressure_in: float = TABLE4_PRESSURE_IN,
                 pressure_out: float = TABLE4_PRESSURE_OUT) -> dict:
    """Intact permeability (m2) of one assembly by the paper's constant-head test (Eq. 8).

    Builds the 22.5 x 45 mm section (thickness 22.5 mm) with ``recipe`` and
    ``seed`` and runs :func:`measure_permeability`; the result also carries
    ``seed``.
    """
    mesh = permeability_mesh(recipe, seed, grains)
    out = measure_permeability(mesh, initial_aperture, fluid=fluid, pressure_in=pressure_in,
                               pressure_out=pressure_out)
    out["seed"] = seed
    return out


def permeability_curve(apertures=(1e-7, 1.5e-7, 2e-7, 2.5e-7, 3e-7, 4e-7, 5e-7),
                       seeds=(0, 1, 2), *,
                       recipe: str | materials.RockRecipe = "strathbogie-granite",
                       grains: GrainSpec | None = None,
                       fluid: flow.FluidProperties | None = None) -> dict:
    """Permeability against the initial aperture ``a0`` over a few grain structures (Fig. 6d).

    Returns ``initial_aperture_m`` (a), ``seeds`` (s), ``permeability_m2``
    (a x s nested lists), ``mean_m2``, ``min_m2`` and ``max_m2`` per aperture.
    """
    apertures = [float(a) for a in apertures]
    table = np.zeros((len(apertures), len(seeds)))
    for j, seed in enumerate(seeds):
        mesh = permeability_mesh(recipe, seed, grains)
        for i, a0 in enumerate(apertures):
            table[i, j] = measure_permeability(mesh, a0, fluid=fluid)["permeability_m2"]
    return {
        "initial_aperture_m": apertures,
        "seeds": [int(s) for s in seeds],
        "permeability_m2": table.tolist(),
        "mean_m2": table.mean(axis=1).tolist(),
        "min_m2": table.min(axis=1).tolist(),
        "max_m2": table.max(axis=1).tolist(),
        "experimental_m2": EXPERIMENTAL_PERMEABILITY_M2,
    }
