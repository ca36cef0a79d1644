"""Coupled hydro-mechanics on 3D slabs: the borehole's void, the penny-crack compliance,
the pressurisation of a sealed well, the fluid books and 3D scenario runs."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from headless_chromium import CHROMIUM, assert_renders
from kill_resume import comparable, killed_then_resumed
from scipy.integrate import quad

from grainfrac.assembly import build_specimen
from grainfrac.io.config import validate
from grainfrac.loading.insitu import STRESS_CASES, initialise_in_situ
from grainfrac.physics import flow
from grainfrac.physics.coupled import HydroMechanicalSolver, penny_crack_length
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario
from grainfrac.units import MPA
from grainfrac.viz.report import build_report

SLAB = {"dimension": 3, "seed": 1,
        "specimen": {"shape": "slab", "width_mm": 30, "height_mm": 30, "thickness_mm": 8}}
RATE = 90e-6 / 60  # m3/s, 90 ml/min


@pytest.fixture(scope="module")
def slab():
    return build_specimen(SLAB)


def test_borehole_volume_of_the_undeformed_and_moved_wall(slab):
    mesh = slab.mesh
    loop = flow.borehole_wall_loop(mesh)
    v0 = flow.borehole_volume(mesh, None, loop)
    exact = mesh.grains.solid.borehole_area * mesh.borehole_length
    assert v0 == pytest.approx(exact, rel=1e-12)
    shift = np.zeros_like(mesh.node_x)
    shift[:, :2] = (3e-5, -2e-5)  # rigid translation: same void
    assert flow.borehole_volume(mesh, shift, loop) == pytest.approx(v0, rel=1e-12)
    eps = 1e-3  # uniform in-plane expansion: area x (1 + eps)^2
    grown = flow.borehole_volume(mesh, mesh.node_x * [eps, eps, 0.0], loop)
    assert grown / v0 == pytest.approx((1 + eps) ** 2, rel=1e-12)


def test_the_wall_is_closed_across_crack_mouths(slab):
    """Grains moved apart radially open every mouth: the void grows as a ring of the
    wall's area x d, not by half of it as the grains' own wall faces alone say."""
    mesh = slab.mesh
    d = 1e-6
    u = np.zeros_like(mesh.node_x)
    for g in np.unique(mesh.node_grain):
        on = mesh.node_grain == g
        c = mesh.node_x[on, :2].mean(axis=0)
        u[on, :2] = d * c / np.linalg.norm(c)
    loop = flow.borehole_wall_loop(mesh)
    own = loop[:len(mesh.surface_triangles["borehole"])]
    ring = 2 * math.pi * mesh.borehole_radius * mesh.borehole_length * d
    closed = flow.borehole_volume(mesh, u, loop) - flow.borehole_volume(mesh, None, loop)
    faces_only = flow.borehole_volume(mesh, u, own) - flow.borehole_volume(mesh, None, own)
    print(f"void growth / ring: closed {closed / ring:.3f}, faces only {faces_only / ring:.3f}")
    assert 0.85 < closed / ring < 1.0
    assert faces_only / ring < 0.6


def test_penny_length_gives_the_2d_fraction_of_sneddon():
    """Sneddon's mean openings (per p / E') by quadrature: plane-strain crack of length L,
    4 sqrt(a^2 - x^2), a = L / 2; penny of radius R, (8 / pi) sqrt(R^2 - r^2). The 2D rule
    books L, so a penny must book the same fraction of its own opening."""
    length = 1.0
    a = length / 2
    mean_2d = quad(lambda x: 4 * math.sqrt(a * a - x * x), -a, a)[0] / length
    radius = 0.5
    mean_penny = quad(lambda r: 8 / math.pi * math.sqrt(radius**2 - r * r) * 2 * math.pi * r,
                      0, radius)[0] / (math.pi * radius**2)
    fraction_2d = length / mean_2d
    assert float(penny_crack_length(2 * radius)) / mean_penny == pytest.approx(fraction_2d,
                                                                              rel=1e-9)


@pytest.fixture(scope="module")
def pressurised(slab):
    mech = MechanicsSolver(build_mechanical_model(slab))
    sx, sy, sz = STRESS_CASES["case2"]
    initialise_in_situ(mech, slab.mesh, sx * MPA, sy * MPA, sz * MPA, ratio=1e-4,
                       max_steps=20_000)
    network = flow.build_flow_network(
        slab.mesh, well=True, wall="sealed",
        permeable_sides=dict.fromkeys(("x-", "x+", "y-", "y+"), 0.0))
    coupled = HydroMechanicalSolver(slab, mech, network, flow.FluidProperties())
    coupled.held_at_start = coupled.state.stored(~network.fixed)
    for _ in range(60):
        coupled.advance(1e-5, RATE)
    return coupled


def test_sealed_well_pressurises_as_its_storage_says(pressurised):
    """Before any crack: dp/dt = Q / (V c_w + pi a^2 l / G) (fluid and Lame wall)."""
    c = pressurised
    assert len(c.mechanics.cracks.contact) == 0
    t = c.history.time[-1] - c.history.time[0] + 1e-5
    storage = c.network.well_volume * c.network.well_compressibility + c.wall_compliance
    expected = RATE * t / storage
    print(f"well {c.well_pressure / MPA:.3f} MPa, storage estimate {expected / MPA:.3f} MPa")
    assert c.well_pressure == pytest.approx(expected, rel=0.05)


def test_fluid_volume_balance_closes(pressurised):
    s = pressurised.state
    gained = s.stored(~pressurised.network.fixed) - pressurised.held_at_start
    assert s.injected == pytest.approx(gained + s.outflow, rel=1e-9)


SCENARIO = {
    "name": "tiny-3d", "seed": 1, "dimension": 3,
    "specimen": {"shape": "slab", "width_mm": 26, "height_mm": 26, "thickness_mm": 6,
                 "borehole_diameter_mm": 8},
    "stress": {"case": "case2"},
    "stages": [{"kind": "equilibrate"},
               {"kind": "inject", "rate_ml_per_min": 180.0, "duration_ms": 4.0,
                "stop_after_breakdown_ms": 0.5, "stop_at_boundary": False}],
    "output": {"checkpoint_every_steps": 2000},
}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny3d") / "run"
    scenario = validate(Scenario, SCENARIO)
    return out, run_scenario(scenario, scenario.recipe(), out)


def test_3d_scenario_breaks_down_with_closed_books(reference):
    out, summary = reference
    assert summary["dimension"] == 3
    assert summary["breakdown_pressure_MPa"] is not None
    # The coupling makes no energy (a negative residual) beyond the run's warning
    # threshold. After breakdown a 3D run loses part of the pumped energy from its
    # books: +12.0 % / +12.6 % at the 0.01 / 0.0025 ms fluid step on a 30 x 30 x 8 mm
    # slab (so not the time step; before breakdown the books close to +0.1-0.5 %).
    books = summary["hydraulic_energy_J"]
    print(f"breakdown {summary['breakdown_pressure_MPa']:.3f} MPa, books residual "
          f"{books['residual'] / books['pumped']:+.3f} of the pumped energy")
    assert -0.10 * books["pumped"] < books["residual"] < 0.15 * books["pumped"]
    assert summary["n_radial_fractures_top"] >= 1
    assert summary["fracture_area_m2"] > 0
    assert summary["injection_stop_reason"] == "0.5 ms after breakdown"
    for name in ("fractures3d.png", "fracture_sections.png", "well_pressure.png"):
        assert (out / "figures" / name).stat().st_size > 10_000
    header = (out / "cracks.csv").read_text().splitlines()[0]
    assert header.endswith("z_mm,normal_z,area_mm2")
    assert json.loads((out / "summary.json").read_text())["dimension"] == 3


def test_3d_report_embeds_the_sections_and_the_crack_view(reference, tmp_path):
    out, _ = reference
    page = tmp_path / "report.html"
    build_report([out], page)
    text = page.read_text()
    for figure in ("fracture sections", "fractures3d", "well pressure"):
        assert re.search(rf'<img [^>]*alt="[^"]*: {figure}"', text), figure
    assert "radial fractures, mid-plane (3D)" in text and "ms after breakdown" in text
    if CHROMIUM is not None:  # installed by .ci/run
        assert_renders(page, tmp_path)


@pytest.mark.slow  # two more 3D runs; keeps the default suite near 10 min
def test_3d_resume_after_kill_mid_injection_gives_the_same_result(reference, tmp_path):
    """Killed during injection past a checkpoint: the resumed run ends as the
    uninterrupted one, to the last digit (so the same seed gives the same result)."""
    out = tmp_path / "killed"
    resumed = killed_then_resumed(validate(Scenario, SCENARIO), out, "inject", 40)
    assert comparable(resumed) == comparable(reference[1])
    assert (out / "cracks.csv").read_text() == (reference[0] / "cracks.csv").read_text()


@pytest.mark.parametrize(("change", "field"), [
    ({"stress": {"sigma_x_MPa": 2.5, "sigma_y_MPa": 5.0}}, "stress.sigma_z_MPa"),
])
def test_3d_scenario_errors_name_the_field(change, field):
    with pytest.raises(Exception, match=field.replace(".", r"\.")):
        validate(Scenario, {**SCENARIO, **change})


def test_3d_slab_defaults_to_the_3d_thickness():
    scenario = validate(Scenario, {**SCENARIO, "specimen": {"shape": "slab"}})
    assert scenario.specimen.thickness_mm == 20.0
    assert validate(Scenario, {**SCENARIO, "dimension": 2,
                               "specimen": {"shape": "slab"}}).specimen.thickness_mm == 10.0
