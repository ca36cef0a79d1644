"""3D hydraulic verification (``grainfrac verify cubic-law3d``): the cubic law on one grain
face, the volume balance of a transient run, permeability against a0 on a 3D assembly.

Each test prints what it observed next to its tolerance (run with ``-s``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from grainfrac.cli import app
from grainfrac.physics import flow
from grainfrac.verification import CASES, ROW_KEYS
from grainfrac.verification import hydraulic3d as h3

runner = CliRunner()
FLUID = flow.FluidProperties()
APERTURE = 2e-5  # m, the single face
DP = 1e6  # Pa
# Seed whose face triangulation has one pipe clamped to zero width (module notes).
CLAMPED_SEED = 8


@pytest.fixture(scope="module")
def face():
    return h3.two_grain_face(seed=0)


@pytest.fixture(scope="module")
def box():
    return h3.permeability_box(seed=0)


def test_case_is_registered():
    assert CASES["cubic-law3d"] is h3.cubic_law3d


def test_two_grain_box_is_one_planar_face(face):
    cx = face.grains
    length, width = h3.FACE_LENGTH_MM * 1e-3, h3.FACE_WIDTH_MM * 1e-3
    depth = h3.FACE_BOX_DEPTH_MM * 1e-3
    assert cx.n_grains == 2 and len(cx.interface_faces()) == 1
    assert cx.piece_volumes() == pytest.approx(np.full(6, depth * length * width / 6),
                                               rel=1e-12)
    assert face.n_interfaces == 1
    # Every fluid node lies on the face, whose tributary areas add up to it.
    assert np.all(face.fluid_node_x[:, 0] == 0.0)
    assert face.contact_area.sum() == pytest.approx(length * width, rel=1e-12)
    for side, y in (("y-", -length / 2), ("y+", length / 2)):
        nodes = face.fluid_node_sets[side]
        assert len(nodes) > 5 and np.allclose(face.fluid_node_x[nodes, 1], y)
    network = flow.build_flow_network(face, permeable_sides={"y+": DP, "y-": 0.0}, well=False)
    assert network.n_unknowns == len(face.fluid_node_x) and network.well_unknown == -1


def test_single_face_cubic_law(face):
    """Linear elements reproduce the linear pressure: exact up to round-off on a mesh
    without clamped weights (seed 0 has none)."""
    assert not np.any(face.pipe_width == 0.0)
    out = h3.face_flow(face, APERTURE, DP, FLUID)
    error = out["rate_m3_s"] / out["expected_m3_s"] - 1.0
    print(f"\nsingle face: rate {out['rate_m3_s']:.6e} m3/s, cubic law "
          f"{out['expected_m3_s']:.6e} (error {error:.1e}, tolerance 1 %); profile "
          f"deviation {out['profile_error']:.1e} of dp; in/out "
          f"{out['inflow_m3_s'] / out['outflow_m3_s'] - 1:.1e}")
    assert abs(error) < h3.CUBIC_LAW_TOLERANCE
    assert out["profile_error"] < h3.CUBIC_LAW_TOLERANCE
    assert abs(error) < 1e-12 and out["profile_error"] < 1e-12


def test_single_face_with_a_clamped_pipe():
    """A negative cotangent weight clamped to zero adds conductance: the rate rises a
    little above the cubic law (Rayleigh monotonicity), well within 1 %."""
    mesh = h3.two_grain_face(seed=CLAMPED_SEED)
    assert np.count_nonzero(mesh.pipe_width == 0.0) >= 1
    out = h3.face_flow(mesh, APERTURE, DP, FLUID)
    error = out["rate_m3_s"] / out["expected_m3_s"] - 1.0
    print(f"\nclamped seed {CLAMPED_SEED}: rate error {error:.2e}, profile deviation "
          f"{out['profile_error']:.2e} of dp (tolerance 1 %)")
    assert -1e-12 < error < h3.CUBIC_LAW_TOLERANCE
    assert out["profile_error"] < h3.CUBIC_LAW_TOLERANCE


def test_transient_volume_balance(face):
    out = h3.face_volume_balance(face, APERTURE, DP, FLUID)
    print(f"\ntransient face, {out['time_s']:.2e} s: stored {out['stored_m3']:.6e} m3 "
          f"(content {out['stored_content_m3']:.6e}), net inflow {out['net_inflow_m3']:.6e}, "
          f"booked {out['booked_inflow_m3']:.6e}; balance error {out['balance_error']:.1e} "
          f"(tolerance {h3.BALANCE_TOLERANCE:g}); mean pressure "
          f"{out['mean_pressure_fraction']:.3f} dp")
    # Mid-transient (neither still at rest nor already steady): the balance is a real one.
    assert 0.1 < out["mean_pressure_fraction"] < 0.9
    assert out["net_inflow_m3"] > 0
    assert out["balance_error"] < h3.BALANCE_TOLERANCE


def test_permeability_scales_as_a0_cubed(box):
    runs = [h3.measure_permeability3d(box, a0) for a0 in h3.PERMEABILITY_APERTURES]
    k = [r["permeability_m2"] for r in runs]
    exponent = h3.permeability_exponent(h3.PERMEABILITY_APERTURES, k)
    print(f"\n3D box ({runs[0]['n_grains']} grains, {runs[0]['n_fluid_nodes']} fluid nodes): "
          + ", ".join(f"a0 {a:.1e} m: k {v:.3e} m2"
                      for a, v in zip(h3.PERMEABILITY_APERTURES, k, strict=True))
          + f"; exponent 3 {exponent - 3:+.1e} (tolerance 0.1)")
    assert runs[0]["n_grains"] >= 20
    assert abs(exponent - 3.0) < 0.1
    # One aperture everywhere: the steady pressures do not depend on it.
    assert abs(exponent - 3.0) < 1e-10
    for r in runs:  # steady: what enters at x- leaves at x+
        assert r["outflow_m3_s"] == pytest.approx(r["flow_rate_m3_s"], rel=1e-10)


def test_permeability_at_table4_aperture(box):
    out = h3.measure_permeability3d(box, h3.TABLE4_APERTURE_M)
    ratio = out["permeability_m2"] / out["linear_field_m2"]
    print(f"\nk at a0 = 0.2 um: {out['permeability_m2']:.3e} m2 (lab 1e-19); linear-field "
          f"estimate {out['linear_field_m2']:.3e} m2, ratio {ratio:.4f} (tolerance 10 %)")
    assert out["pressure_drop_Pa"] == 8e6
    assert out["length_m"] == pytest.approx(0.045) and out["area_m2"] == pytest.approx(0.0225**2)
    # The linear field is an upper bound for linear elements (a clamped weight may lift
    # the network a hair above it); a well-connected grain network comes close to it.
    assert 1.0 - h3.LINEAR_FIELD_TOLERANCE < ratio < 1.0 + 1e-3
    assert 1e-20 < out["permeability_m2"] < 1e-18


def test_cli_verify_cubic_law3d_json():
    result = runner.invoke(app, ["verify", "cubic-law3d", "--json"])
    assert result.exit_code == 0, result.output
    rows = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    for row in rows:
        print(row)
        assert tuple(row) == ROW_KEYS
        assert row["case"] == "cubic-law3d" and row["passed"] is True
    assert [r["quantity"] for r in rows] == [
        "face_flow_rate_ml_per_min",
        "face_pressure_profile_max_deviation_fraction_of_dp",
        "face_transient_volume_balance_error_fraction",
        "permeability_exponent_in_a0",
        "permeability_a0_0_2um_m2",
    ]
