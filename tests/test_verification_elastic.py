"""Elastic verification cases (Kirsch, Lame) and the ``grainfrac verify`` command.

Each real case runs once (module-scoped fixtures); every comparison prints its
simulated and analytical values next to the error and tolerance (run
``pytest -s`` to see them). The CLI formatting tests use a fast fake case.
"""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from grainfrac import verification
from grainfrac.cli import app
from grainfrac.verification import elastic
from grainfrac.verification.report import ROW_KEYS, Comparison, all_passed

runner = CliRunner()


def _show(rows: list[Comparison]) -> None:
    for c in rows:
        print(f"\n{c.case:7s} {c.quantity:30s} simulated {c.simulated:10.4f}  analytical "
              f"{c.analytical:10.4f}  error {100 * c.relative_error:6.2f} %  tolerance "
              f"{100 * c.tolerance:4.1f} %  {'PASS' if c.passed else 'FAIL'}", end="")
    print()


@pytest.fixture(scope="module")
def kirsch_rows() -> list[Comparison]:
    return elastic.kirsch(seed=0)


@pytest.fixture(scope="module")
def lame_rows() -> list[Comparison]:
    return elastic.lame(seed=0)


def test_kirsch_hoop_stress_matches_analytical(kirsch_rows):
    _show(kirsch_rows)
    quantities = {c.quantity: c for c in kirsch_rows}
    assert set(quantities) == {
        "hoop_stress_wall_0deg_MPa", "hoop_stress_wall_90deg_MPa",
        *(f"hoop_stress_{k}a_{t}deg_MPa" for k in (2, 3, 4) for t in (0, 90)),
    }
    # paper Table 6 case 2 at the wall: -(3 * 5 - 2.5) and -(3 * 2.5 - 5) MPa
    assert quantities["hoop_stress_wall_0deg_MPa"].analytical == pytest.approx(-12.5)
    assert quantities["hoop_stress_wall_90deg_MPa"].analytical == pytest.approx(-2.5)
    for c in kirsch_rows:
        assert c.passed, c.as_row()


def test_lame_wall_displacement_matches_analytical(lame_rows):
    _show(lame_rows)
    u = next(c for c in lame_rows if c.quantity == "radial_displacement_wall_um")
    # quartz, plane strain: p a (1 + nu) / E = 10 MPa * 5 mm * 1.21 / 27.37 GPa
    assert u.analytical == pytest.approx(10e6 * 5e-3 * 1.21 / 27.37e9 / 1e-6, rel=1e-9)
    for c in lame_rows:
        assert c.passed, c.as_row()


def test_kirsch_formula_at_the_wall_and_far_away():
    a = 5e-3
    sxx, syy = -2.5e6, -5e6
    assert elastic.kirsch_hoop_stress(a, 0.0, a, sxx, syy) == pytest.approx(3 * syy - sxx)
    assert elastic.kirsch_hoop_stress(a, math.pi / 2, a, sxx, syy) == pytest.approx(
        3 * sxx - syy)
    # far away the hoop stress is the far-field normal stress across the ray
    assert elastic.kirsch_hoop_stress(1e3, 0.0, a, sxx, syy) == pytest.approx(syy, rel=1e-6)
    # thick cylinder -> infinite plate as the outer radius grows
    inf = elastic.lame_wall_displacement(1e6, a, 27.37e9, 0.21)
    assert elastic.thick_cylinder_wall_displacement(1e6, a, 1e3, 27.37e9, 0.21) == (
        pytest.approx(inf, rel=1e-6))


def test_comparison_row_format():
    ok = Comparison("fake", "x_MPa", 1.05, 1.0, 0.1)
    bad = Comparison("fake", "y_MPa", float("nan"), 2.0, 0.1)
    assert tuple(ok.as_row()) == ROW_KEYS
    assert ok.relative_error == pytest.approx(0.05) and ok.passed
    assert not bad.passed and bad.as_row()["relative_error"] is None
    json.dumps(bad.as_row(), allow_nan=False)
    assert all_passed([ok]) and not all_passed([ok, bad]) and not all_passed([])


def _fake_case(seed: int = 0) -> list[Comparison]:
    return [Comparison("fake", "hoop_stress_wall_0deg_MPa", -12.0, -12.5, 0.1),
            Comparison("fake", "hoop_stress_2a_0deg_MPa", -6.0 - seed, -6.1, 0.1)]


def test_cli_verify_json_rows(monkeypatch):
    monkeypatch.setitem(verification.CASES, "fake", _fake_case)
    result = runner.invoke(app, ["verify", "fake", "--json"])
    assert result.exit_code == 0, result.output
    rows = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    assert len(rows) == 2
    for row in rows:
        assert set(row) == set(ROW_KEYS)
        assert row["case"] == "fake" and row["passed"] is True


def test_cli_verify_table_and_failure_exit_code(monkeypatch):
    monkeypatch.setitem(verification.CASES, "fake", _fake_case)
    result = runner.invoke(app, ["verify", "fake"])
    assert result.exit_code == 0, result.output
    assert "PASS" in result.output and "FAIL" not in result.output
    assert "verification: fake" in result.output
    # seed 5 moves the second quantity to -11 vs -6.1: that row fails, exit code 1
    result = runner.invoke(app, ["verify", "fake", "--seed", "5", "--json"])
    assert result.exit_code == 1, result.output
    rows = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    assert [r["passed"] for r in rows] == [True, False]


def test_cli_verify_unknown_case():
    result = runner.invoke(app, ["verify", "no-such-case"])
    assert result.exit_code == 2
    assert "kirsch" in result.output and "lame" in result.output


def test_cli_verify_real_case_json(kirsch_rows, monkeypatch):
    """The real registry entry, without re-running it: the fixture's rows go through the CLI."""
    calls = []

    def cached(seed: int = 0) -> list[Comparison]:
        calls.append(seed)
        return kirsch_rows

    monkeypatch.setitem(verification.CASES, "kirsch", cached)
    result = runner.invoke(app, ["verify", "kirsch", "--json"])
    assert result.exit_code == 0, result.output
    rows = [json.loads(line) for line in result.stdout.splitlines() if line.strip()]
    assert calls == [0]
    assert [r["quantity"] for r in rows] == [c.quantity for c in kirsch_rows]
    for row in rows:
        assert tuple(row) == ROW_KEYS and row["passed"] is True
