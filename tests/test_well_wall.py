"""The well-wall connections, partial mass scaling and the stop after breakdown.

Three ways the borehole meets the grain boundaries that end on its wall
(``flow.WELL_WALLS``): ``wet`` (the wall's fluid nodes are the well), ``sealed``
(their own unknowns, joined to the well once a wall contact cracks) and
``flow_knots`` (fluid only in the joints, nothing on the wall).
"""

from __future__ import annotations

import numpy as np
import pytest

from grainfrac.analysis.breakdown import breakdown
from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.loading.insitu import STRESS_CASES, initialise_in_situ
from grainfrac.physics import flow
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.scenario import Scenario
from grainfrac.stages import inject
from grainfrac.units import MPA

RATE = 90.0e-6 / 60.0 * 10.0 / 100.0  # m3/s: 90 ml/min in a slab 10x thinner


@pytest.fixture(scope="module")
def assembly():
    slab = {"shape": "slab", "width_mm": 40.0, "height_mm": 40.0}
    config = validate(SpecimenConfig, {"seed": 2, "specimen": slab})
    return build_assembly(config, config.recipe())


def _coupled(assembly, wall: str) -> HydroMechanicalSolver:
    mesh = assembly.mesh
    mechanics = MechanicsSolver(build_mechanical_model(assembly))
    sx, sy, _ = STRESS_CASES["case2"]
    initialise_in_situ(mechanics, mesh, sx * MPA, sy * MPA)
    network = flow.build_flow_network(mesh, well=True, wall=wall,
                                      permeable_sides=dict.fromkeys(("left", "right"), 0.0))
    return HydroMechanicalSolver(assembly, mechanics, network, flow.FluidProperties())


def test_unknown_wall_is_refused(assembly):
    with pytest.raises(ValueError, match="wall: must be one of wet, sealed, flow_knots"):
        flow.build_flow_network(assembly.mesh, wall="dry")


def test_sealed_wall_nodes_are_their_own_unknowns(assembly):
    mesh = assembly.mesh
    wet = flow.build_flow_network(mesh, well=True)
    sealed = flow.build_flow_network(mesh, well=True, wall="sealed")
    wall = mesh.fluid_node_sets["borehole"]
    assert np.all(wet.unknown_of_node[wall] == wet.well_unknown)
    assert len(np.unique(sealed.unknown_of_node[wall])) == len(wall)
    assert sealed.n_unknowns == wet.n_unknowns + len(wall)
    assert sealed.well_volume == wet.well_volume > 0.0
    assert not sealed.mouths.is_open.any()
    knots = flow.build_flow_network(mesh, well=True, wall="flow_knots")
    assert knots.well_volume == 0.0 and not knots.wall_pressurised


def test_a_shut_mouth_passes_no_fluid_and_an_open_one_joins_the_node_to_the_well(assembly):
    """Injected fluid stays in the well while the mouths are shut (the wall nodes keep
    their pressure); once every mouth is open the wall nodes follow the well."""
    net = flow.build_flow_network(assembly.mesh, well=True, wall="sealed")
    fluid = flow.FluidProperties()
    aperture = np.full(assembly.mesh.n_contacts, fluid.initial_aperture)
    state = flow.initial_state(net, aperture, fluid)
    for _ in range(5):
        flow.implicit_step(net, state, aperture, 1e-5, fluid, injection_rate=RATE)
    wall = net.mouths.unknown
    assert state.pressure[net.well_unknown] > 1.0e4  # Pa: the fluid compressed in the well
    assert np.all(state.pressure[wall] == 0.0)
    # Fluid volume balance: everything injected is in the well.
    assert state.content.sum() - flow.storage_volume(net, aperture).sum() == pytest.approx(
        state.injected, rel=1e-9)
    bonded = np.ones(assembly.mesh.n_contacts, dtype=bool)
    bonded[net.mouths.contact_mouth >= 0] = False
    opened = flow.open_mouths(net, aperture, bonded, fluid)
    assert opened.mouths.is_open.all()
    for _ in range(5):
        flow.implicit_step(opened, state, aperture, 1e-5, fluid, injection_rate=RATE)
    well = state.pressure[net.well_unknown]
    # Within a few % of the well: they also feed the grain boundaries behind them.
    assert np.allclose(state.pressure[wall], well, rtol=0.05)
    assert np.all(state.pressure[wall] < well)
    free = ~opened.fixed
    assert state.content[free].sum() + state.outflow - flow.storage_volume(
        opened, aperture)[free].sum() == pytest.approx(state.injected, rel=1e-9)


def test_a_mouth_opens_by_aperture_and_stays_open(assembly):
    net = flow.build_flow_network(assembly.mesh, well=True, wall="sealed")
    fluid = flow.FluidProperties()
    bonded = np.ones(assembly.mesh.n_contacts, dtype=bool)
    aperture = np.full(assembly.mesh.n_contacts, fluid.initial_aperture)
    c = int(np.flatnonzero(net.mouths.contact_mouth >= 0)[0])
    aperture[c] = fluid.initial_aperture * (1.0 + flow.MOUTH_OPENING_APERTURES) * 0.99
    assert not flow.open_mouths(net, aperture, bonded, fluid).mouths.is_open.any()
    aperture[c] = fluid.initial_aperture * (1.0 + flow.MOUTH_OPENING_APERTURES)
    opened = flow.open_mouths(net, aperture, bonded, fluid)
    assert np.flatnonzero(opened.mouths.is_open).tolist() == [net.mouths.contact_mouth[c]]
    aperture[c] = fluid.initial_aperture
    assert flow.open_mouths(opened, aperture, bonded, fluid).mouths.is_open.sum() == 1


@pytest.mark.parametrize("wall", ["sealed", "flow_knots"])
def test_injected_fluid_is_conserved_through_the_coupling(assembly, wall):
    """Content changes only by flow: what the free nodes gained plus what left through
    the permeable sides is what was injected."""
    hm = _coupled(assembly, wall)
    free = ~hm.network.fixed
    start = hm.state.content[free].sum()
    for _ in range(20):
        hm.advance(1e-5, RATE)
    s = hm.state
    assert s.injected == pytest.approx(20 * 1e-5 * RATE, rel=0.02)
    assert s.content[free].sum() - start + s.outflow == pytest.approx(s.injected, rel=1e-9)
    assert hm.well_pressure > 0.0
    if wall == "flow_knots":
        assert hm.well_unit_forces is None and hm.well_void() == 0.0
        assert hm.state.wall_work == 0.0
    else:
        assert hm.well_unit_forces is not None
        assert (hm.mouths_open is not None) and not hm.mouths_open.any()


def test_the_mouths_survive_a_checkpoint(assembly):
    hm = _coupled(assembly, "sealed")
    saved = np.zeros(len(hm.mouths_open), dtype=bool)
    saved[[0, 2]] = True
    hm.mouths_open = saved
    assert hm.mouths_open.tolist() == saved.tolist()
    assert hm.network.mouths.is_open.sum() == 2
    assert _coupled(assembly, "wet").mouths_open is None


def test_scenario_names_the_well_wall_and_its_choices():
    base = {"stages": [{"kind": "equilibrate"}]}
    assert Scenario.model_validate(base).fluid.well_wall == "sealed"
    with pytest.raises(ValueError, match="well_wall"):
        Scenario.model_validate({**base, "fluid": {"well_wall": "dry"}})


@pytest.mark.parametrize("fraction", [0.0, 0.25, 0.5, 1.0])
def test_partial_mass_scaling_adds_that_fraction_of_the_mass(assembly, fraction):
    full = build_mechanical_model(assembly)
    real = build_mechanical_model(assembly, mass_scaling=False)
    model = build_mechanical_model(assembly, mass_scaling=fraction)
    added_full = np.sum(full.mass - full.real_mass)
    assert np.sum(model.mass - model.real_mass) == pytest.approx(fraction * added_full,
                                                                 rel=1e-6, abs=1e-12)
    assert real.dt <= model.dt <= full.dt
    if fraction == 1.0:
        assert model.dt == full.dt and np.array_equal(model.mass, full.mass)
    if fraction == 0.0:
        assert model.dt == real.dt


class _Clock:
    """A stand-in world whose well pressure follows a given history."""

    def __init__(self, pressure):
        self.pressure = pressure
        self.solver = self
        self.coupled = self
        self.time = 0.0
        self.step = 0

    @property
    def well_pressure(self) -> float:
        return float(self.pressure[self.step])

    def advance(self, dt: float, rate: float) -> None:
        self.step += 1
        self.time = self.step * 1e-3


def test_the_stage_stops_after_the_breakdown_the_summary_reports():
    """The stage's breakdown is the one summaries report (the same 5 % drop), and the
    stage ends ``stop_after_breakdown_ms`` after it."""
    t = np.arange(200) * 1e-3
    p = np.where(t < 0.05, t, 0.05 - 0.4 * (t - 0.05)) * 1e8
    scenario = Scenario.model_validate({"stages": [
        {"kind": "equilibrate"},
        {"kind": "inject", "rate_ml_per_min": 1.0, "duration_ms": 200.0,
         "stop_at_boundary": False, "stop_after_breakdown_ms": 10.0}]})
    world = _Clock(p)
    stage = inject.Inject(scenario.stages[1], scenario.fluid, state=inject.InjectState())
    stage.state.start_time = 0.0
    while not stage.finished():
        stage.advance(world)
    found = breakdown(t, p)
    assert stage.state.breakdown_after == pytest.approx(t[found.drop_index])
    assert world.time == pytest.approx(t[found.drop_index] + 10e-3)
