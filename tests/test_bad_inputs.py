"""A hostile user's inputs (issue 42): every one rejected before compute with a line
naming the field, or accepted because it is valid; never a traceback, never a hang.

Every case runs a real command line through typer's CliRunner, with the run
itself (:class:`grainfrac.run.Run`, which builds the specimen) replaced by a
stub: reaching the stub means the input and the run directory were accepted,
so nothing here computes.
"""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
from typer.testing import CliRunner

from grainfrac import simulation
from grainfrac.cli import app

BASE = """\
name = "bad-input"
seed = 1

[specimen]
shape = "slab"
width_mm = 30.0
height_mm = 30.0
thickness_mm = 10.0
borehole_diameter_mm = 6.0

[grains]
min_edge_mm = 3.0
max_edge_mm = 8.0
zone_size_mm = 2.0
lloyd_iterations = 30

[fissures]
fraction = 0.0

[stress]
sigma_x_MPa = 2.5
sigma_y_MPa = 5.0

[fluid]
viscosity_Pa_s = 0.001
bulk_modulus_GPa = 2.0
boundary_pressure_MPa = 0.0

[output]
snapshot_every_ms = 0.5
checkpoint_every_minutes = 5.0

[[stages]]
kind = "equilibrate"
unbalanced_ratio = 1e-5
max_steps = 400

[[stages]]
kind = "inject"
rate_ml_per_min = 90.0
duration_ms = 0.05
time_step_ms = 0.01
"""

REJECT, EITHER = "reject", "either"


def _set(key: str, value: str) -> str:
    lines = BASE.splitlines()
    (i,) = [n for n, line in enumerate(lines) if line.startswith(f"{key} = ")]
    lines[i] = f"{key} = {value}"
    return "\n".join(lines) + "\n"


def _drop(key: str) -> str:
    return "\n".join(ln for ln in BASE.splitlines() if not ln.startswith(f"{key} = ")) + "\n"


def _after(anchor: str, line: str) -> str:
    return BASE.replace(anchor + "\n", anchor + "\n" + line + "\n", 1)


# Fields with a lower bound, each given values no such field accepts or that are
# sizes / durations out of reach; (field, value, expected).
NUMERIC = ["seed", "width_mm", "height_mm", "thickness_mm", "borehole_diameter_mm",
           "min_edge_mm", "max_edge_mm", "zone_size_mm", "lloyd_iterations", "fraction",
           "sigma_x_MPa", "viscosity_Pa_s", "bulk_modulus_GPa", "snapshot_every_ms",
           "checkpoint_every_minutes", "unbalanced_ratio", "max_steps", "rate_ml_per_min",
           "duration_ms", "time_step_ms"]
CASES: list[tuple[str, str, str, str]] = []  # (id, toml text, field named, expected)
for key in NUMERIC:
    for value in ("-1", "inf", "nan", '"text"', "-inf"):
        CASES.append((f"{key}={value}", _set(key, value), key, REJECT))
    for value in ("0", "1e300"):
        CASES.append((f"{key}={value}", _set(key, value), key, EITHER))
CASES += [
    ("zone-0.01", _set("zone_size_mm", "0.01"), "zone_size_mm", REJECT),
    ("zone-above-grains", _set("zone_size_mm", "9.0"), "zone_size_mm", REJECT),
    ("borehole-0.5mm", _set("borehole_diameter_mm", "0.5"), "borehole_diameter_mm", REJECT),
    ("borehole-metres", _set("borehole_diameter_mm", "0.012"), "borehole_diameter_mm", REJECT),
    ("borehole-wider-than-slab", _set("borehole_diameter_mm", "40.0"), "borehole", REJECT),
    ("duration-1e300", _set("duration_ms", "1e300"), "duration_ms", REJECT),
    ("width-1e300", _set("width_mm", "1e300"), "width_mm", REJECT),
    ("edges-swapped", _set("min_edge_mm", "9.0"), "min_edge_mm", REJECT),
    ("fraction-1", _set("fraction", "1.0"), "fraction", REJECT),
    ("ratio-1", _set("unbalanced_ratio", "1.0"), "unbalanced_ratio", REJECT),
    ("max-steps-float", _set("max_steps", "1.5"), "max_steps", REJECT),
    ("seed-float", _set("seed", "0.5"), "seed", REJECT),
    ("seed-bool", _set("seed", "true"), "seed", EITHER),
    ("shape-unknown", _set("shape", '"sphere"'), "specimen", REJECT),
    ("shape-disk", _set("shape", '"disk"'), "specimen", REJECT),
    ("name-table", _set("name", "{a = 1}"), "name", REJECT),
    ("time-step-above-duration", _set("time_step_ms", "0.1"), "time_step_ms", REJECT),
    ("volume-huge", _after("time_step_ms = 0.01", "volume_ml = 1e300"), "volume_ml", REJECT),
    ("max-step-below-step", _after("time_step_ms = 0.01", "max_time_step_ms = 0.005"),
     "max_time_step_ms", REJECT),
    ("no-stages", BASE.split("[[stages]]")[0], "stages", REJECT),
    ("inject-first", BASE.replace('kind = "equilibrate"\nunbalanced_ratio = 1e-5\n'
                                  "max_steps = 400\n\n[[stages]]\n", "", 1)
     .replace("[[stages]]\n", "[[stages]]\n", 1), "stages.0", REJECT),
    ("kind-missing", BASE.replace('kind = "inject"\n', ""), "stages.1.kind", REJECT),
    ("kind-typo", BASE.replace('kind = "inject"', 'kind = "injct"'), "stages.1.kind", REJECT),
    ("kind-number", BASE.replace('kind = "inject"', "kind = 3"), "stages.1.kind", REJECT),
    ("stages-not-tables", BASE.split("[[stages]]")[0] + "stages = [1, 2]\n", "stages",
     REJECT),
    ("no-duration", _drop("duration_ms"), "duration_ms", REJECT),
    ("no-rate", _drop("rate_ml_per_min"), "rate_ml_per_min", REJECT),
    ("stress-case-and-values", _after("[stress]", 'case = "case1"'), "stress", REJECT),
    ("stress-case-unknown", _after("[stress]", 'case = "case9"').replace(
        "sigma_x_MPa = 2.5\nsigma_y_MPa = 5.0\n", ""), "stress.case", REJECT),
    ("stress-half", _drop("sigma_y_MPa"), "sigma_y_MPa", REJECT),
    ("permeable-side-unknown", _after("[fluid]", 'permeable_sides = ["north"]'),
     "permeable_sides", REJECT),
    ("permeable-side-twice", _after("[fluid]", 'permeable_sides = ["left", "left"]'),
     "permeable_sides", REJECT),
    ("apertures-inverted", _after("[fluid]", "residual_aperture_m = 1e-3"),
     "residual_aperture_m", REJECT),
    ("rock-unknown", _after('name = "bad-input"', 'rock = "basalt-of-mars"'), "rock", REJECT),
    ("rock-missing-file", _after('name = "bad-input"', 'rock = "nope.toml"'), "rock", REJECT),
    ("rock-empty-table", _after("seed = 1", "rock = {}"), "rock", REJECT),
    ("scda-before-nothing", BASE.replace('kind = "inject"', 'kind = "drill_out"'),
     "stages.1", REJECT),
    ("equilibrate-twice", BASE.replace('kind = "inject"\nrate_ml_per_min = 90.0\n'
                                       "duration_ms = 0.05\ntime_step_ms = 0.01\n",
                                       'kind = "equilibrate"\n'), "stages.1", REJECT),
    ("valid", BASE, "", EITHER),
]
# Unknown keys: each named, with the key it was probably meant to be.
TYPOS = [("seed", "sed"), ("width_mm", "widht_mm"), ("zone_size_mm", "zone_size"),
         ("viscosity_Pa_s", "viscosity"), ("duration_ms", "duration"),
         ("max_steps", "max_step"), ("snapshot_every_ms", "snapshot_every"),
         ("fraction", "fractoin"), ("sigma_x_MPa", "sigma_x"), ("rate_ml_per_min", "rate")]
for right, wrong in TYPOS:
    CASES.append((f"typo-{wrong}", BASE.replace(f"{right} = ", f"{wrong} = ", 1),
                  f"did you mean '{right}'", REJECT))
CASES += [
    ("section-typo", BASE.replace("[fissures]", "[fisures]"), "did you mean 'fissures'",
     REJECT),
    ("invalid-toml", BASE + "this is = = not toml\n", "invalid TOML", REJECT),
    ("duplicate-key", BASE.replace("seed = 1", "seed = 1\nseed = 2"), "invalid TOML", REJECT),
    ("empty-file", "", "stages", REJECT),
]

runner = CliRunner()


class _WouldCompute(Exception):
    """The input was accepted: the run would start here."""


def _stub(*args, **kwargs):
    raise _WouldCompute


class _Hang(Exception):
    pass


def _invoke(args: list[str], seconds: int = 60):
    def alarm(signum, frame):
        raise _Hang(f"no answer within {seconds} s: {args}")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        return runner.invoke(app, args)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def _assert_rejected_naming(result, field: str) -> None:
    assert result.exit_code not in (0, None), result.output
    assert "Traceback" not in result.output, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), \
        repr(result.exception)
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert lines and any(field in ln for ln in lines), result.output


@pytest.mark.parametrize("text,field,expected",
                         [pytest.param(t, f, e, id=i) for i, t, f, e in CASES])
def test_a_bad_scenario_is_refused_before_compute_naming_the_field(tmp_path, monkeypatch,
                                                                  text, field, expected):
    monkeypatch.setattr(simulation, "Run", _stub)
    path = tmp_path / "scenario.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    result = _invoke(["run", str(path), "--out", str(out)])
    if isinstance(result.exception, _WouldCompute):
        assert expected == EITHER, f"accepted: {text}"
        return
    _assert_rejected_naming(result, field)
    assert not out.exists()  # nothing was started


def test_there_are_at_least_a_hundred_cases():
    assert len(CASES) + len(CLI_CASES) >= 100


def _cli_cases(tmp: Path) -> dict[str, tuple[list[str], str]]:
    good = tmp / "good.toml"
    good.write_text(BASE, encoding="utf-8")
    latin = tmp / "latin1.toml"
    latin.write_bytes(BASE.replace("bad-input", "caf\u00e9").encode("latin-1"))
    blocker = tmp / "a-file"
    blocker.write_text("x")
    folder = tmp / "folder.toml"
    folder.mkdir(exist_ok=True)
    return {
        "non-utf8-file": (["run", str(latin), "--out", str(tmp / "o1")], "UTF-8"),
        "missing-file": (["run", str(tmp / "none.toml"), "--out", str(tmp / "o2")],
                         "file not found"),
        "directory-as-file": (["run", str(folder), "--out", str(tmp / "o3")], "not a file"),
        "out-is-a-file": (["run", str(good), "--out", str(blocker)], "a file is in the way"),
        "out-under-a-file": (["run", str(good), "--out", str(blocker / "x")],
                             "a file is in the way"),
        "resume-nothing": (["run", "--resume", "--out", str(tmp / "o4")], "no run to continue"),
        "resume-and-overwrite": (["run", str(good), "--resume", "--overwrite", "--out",
                                  str(tmp / "o5")], "--overwrite"),
        "seed-negative": (["run", str(good), "--seed", "-1", "--out", str(tmp / "o6")],
                          "seed"),
        "seed-text": (["run", str(good), "--seed", "abc", "--out", str(tmp / "o7")], "seed"),
        "no-scenario": (["run", "--out", str(tmp / "o8")], "SCENARIO"),
        "sweep-workers-negative": (["sweep", str(good), "--out", str(tmp / "s1"),
                                    "--workers", "-1"], "--workers"),
        "sweep-workers-zero": (["sweep", str(good), "--out", str(tmp / "s2"), "--workers",
                                "0"], "--workers"),
        "specimen-non-utf8": (["specimen", str(latin), "--out", str(tmp / "p1")], "UTF-8"),
        "specimen-missing": (["specimen", str(tmp / "none.toml"), "--out", str(tmp / "p2")],
                             "file not found"),
        "calibrate-non-utf8": (["calibrate", str(latin), "--out", str(tmp / "c1")], "UTF-8"),
        "analyse-missing-dir": (["analyse", str(tmp / "no-run")], "no-run"),
        "verify-unknown": (["verify", "nonsense"], "nonsense"),
        "labtest-unknown": (["labtest", "shear-box", "--out", str(tmp / "l1")], "shear-box"),
    }


CLI_CASES = [
    "non-utf8-file", "missing-file", "directory-as-file", "out-is-a-file", "out-under-a-file",
    "resume-nothing", "resume-and-overwrite", "seed-negative", "seed-text", "no-scenario",
    "sweep-workers-negative", "sweep-workers-zero", "specimen-non-utf8", "specimen-missing",
    "calibrate-non-utf8", "analyse-missing-dir", "verify-unknown", "labtest-unknown"]


def test_every_command_line_case_is_run(tmp_path):
    assert sorted(_cli_cases(tmp_path)) == sorted(CLI_CASES)


@pytest.mark.parametrize("case", CLI_CASES)
def test_bad_command_lines_are_one_clear_refusal(tmp_path, monkeypatch, case):
    monkeypatch.setattr(simulation, "Run", _stub)
    args, words = _cli_cases(tmp_path)[case]
    result = _invoke(args)
    assert not isinstance(result.exception, _WouldCompute), f"accepted: {args}"
    _assert_rejected_naming(result, words)


@pytest.mark.parametrize("workers", [0, -1])
def test_a_sweep_of_no_workers_is_refused_before_any_cluster(tmp_path, workers):
    from grainfrac.studies.sweep import SweepError, run_sweeps

    with pytest.raises(SweepError, match="n_workers: must be >= 1"):
        run_sweeps([], n_workers=workers)
