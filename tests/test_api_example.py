"""The Python API example (examples/api/run_and_plot.py) runs and writes its plot, and
docs/outputs.md describes every file, column, summary key and snapshot field it produced."""

from __future__ import annotations

import csv
import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "api" / "run_and_plot.py"
OUTPUTS = ROOT / "docs" / "outputs.md"


def _load_example():
    spec = importlib.util.spec_from_file_location("api_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def example_run(tmp_path_factory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("api") / "run"
    png = _load_example().main(out, smoke=True)
    return out, Path(png)


def test_api_example_writes_a_plot(example_run):
    out, png = example_run
    assert png.is_file() and png.stat().st_size > 10_000, png
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((out / "summary.json").read_text())
    # The smoke run is a whole hybrid: SCDA to its peak, drill-out, injection to breakdown.
    assert summary["scda_stop_reason"] == "peak pressure"
    assert summary["breakdown_pressure_MPa"] is not None
    assert summary["n_cracks"] > 0


def test_api_example_loads_history_as_arrays_without_pandas(example_run, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name == "pandas" or name.startswith("pandas."):
            raise ImportError("pandas hidden by the test")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    history, cracks, summary = _load_example().load(example_run[0])
    assert history["time_s"].dtype.kind == "f" and len(history["time_s"]) > 10
    assert set(cracks["mode"]) <= {"tensile", "shear"}
    assert summary["n_cracks"] == len(cracks["x_mm"])


# --------------------------------------------------------------------------- docs/outputs.md


def _documented() -> set[str]:
    """Every `code span` of docs/outputs.md (names of files, columns, keys, fields)."""
    return set(re.findall(r"`([^`\s]+)`", OUTPUTS.read_text()))


def _keys(value, prefix: str = "") -> set[str]:
    out: set[str] = set()
    if isinstance(value, dict):
        for key, inner in value.items():
            out.add(prefix + key)
            if prefix == "" and isinstance(inner, dict) and key not in (
                    "contact_fraction_total", "contact_fraction_failed", "stage_times_s"):
                out |= {f"{key}.{k}" for k in inner}
    return out


def test_outputs_page_lists_every_summary_key(example_run):
    summary = json.loads((example_run[0] / "summary.json").read_text())
    missing = sorted(k for k in _keys(summary) if k.split(".")[-1] not in _documented()
                     and k not in _documented())
    assert not missing, f"summary.json keys not described in docs/outputs.md: {missing}"


def test_outputs_page_lists_every_column(example_run):
    documented = _documented()
    for name in ("history.csv", "cracks.csv"):
        with open(example_run[0] / name, newline="") as fh:
            header = next(csv.reader(fh))
        missing = [c for c in header if c not in documented]
        assert not missing, f"{name} columns not described in docs/outputs.md: {missing}"


def test_outputs_page_lists_every_file(example_run):
    out = example_run[0]
    documented = _documented()
    for path in sorted(out.rglob("*")):
        if path.is_dir():
            continue
        name = re.sub(r"_\d{4}\.vtu$", "_NNNN.vtu", path.name)
        assert name in documented, (
            f"{path.relative_to(out)} is not described in docs/outputs.md")


def test_outputs_page_lists_every_snapshot_field(example_run):
    import meshio

    documented = _documented()
    snapshots = example_run[0] / "snapshots"
    for name in ("grains_0000.vtu", "contacts_0000.vtu"):
        mesh = meshio.read(snapshots / name)
        fields = set(mesh.point_data) | set(mesh.cell_data)
        missing = sorted(f for f in fields if f not in documented)
        assert not missing, f"{name} fields not described in docs/outputs.md: {missing}"


@pytest.mark.parametrize("test", ["bts", "permeability"])
def test_outputs_page_lists_every_lab_test_key_and_column(tmp_path, test):
    import grainfrac as gf

    out = tmp_path / test
    summary = gf.run_labtest(gf.lab_test_config(test), out)
    documented = _documented()
    missing = sorted(k for k in summary if k not in documented)
    assert not missing, f"{test} summary keys not described in docs/outputs.md: {missing}"
    if (out / "curve.csv").is_file():
        with open(out / "curve.csv", newline="") as fh:
            header = next(csv.reader(fh))
        text = OUTPUTS.read_text()
        assert all(c in text for c in header), header
