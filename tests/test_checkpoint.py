"""Checkpoints as records in HDF5: exact round trip, format version, old .npz refused."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from grainfrac.cli import app
from grainfrac.errors import CheckpointError
from grainfrac.io.checkpoint import FORMAT_VERSION, read_checkpoint, write_checkpoint
from grainfrac.io.config import validate
from grainfrac.scenario import Scenario, write_resolved

SMALL = {
    "name": "small-eq", "seed": 3,
    "specimen": {"shape": "slab", "width_mm": 40.0, "height_mm": 40.0,
                 "borehole_diameter_mm": 10.0},
    "stages": [{"kind": "equilibrate"}],
}


def test_records_round_trip_exactly(tmp_path):
    rng = np.random.default_rng(0)
    records = {
        "solver": {"u": rng.normal(size=(7, 2)), "status": np.arange(5, dtype=np.int64),
                   "bonded": rng.random(5) > 0.5, "time": 0.1 + 0.2, "step_count": 12345,
                   "allow_failure": True},
        "solver/cracks": {"contact": np.zeros(0, dtype=np.int64), "time": np.zeros(0)},
        "run": {"history": [{"time_s": 1 / 3, "stage": "inject", "x": float("nan")}],
                "stage_times": {"inject": [0.0, 2 / 3]}, "reason": None},
    }
    path = write_checkpoint(tmp_path / "state.h5", records)
    back = read_checkpoint(path)
    for group, record in records.items():
        assert set(back[group]) == set(record), group
        for name, value in record.items():
            got = back[group][name]
            if isinstance(value, np.ndarray):
                assert got.dtype == value.dtype and got.shape == value.shape, name
                assert np.array_equal(got, value), name
            elif name == "history":
                assert got[0]["time_s"] == value[0]["time_s"] and np.isnan(got[0]["x"])
            else:
                assert got == value and type(got) is type(value), name


def test_another_format_version_is_refused(tmp_path):
    path = write_checkpoint(tmp_path / "state.h5", {"run": {"x": 1}})
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = FORMAT_VERSION + 1
    with pytest.raises(CheckpointError, match="format version 2; this grainfrac reads version 1"):
        read_checkpoint(path)


def test_an_old_npz_checkpoint_fails_with_one_line(tmp_path):
    """A run directory from before format 1 (checkpoint/state.npz): resume says why not."""
    out = tmp_path / "old"
    sc = validate(Scenario, SMALL)
    write_resolved(out / "config.toml", sc, sc.recipe())
    (out / "checkpoint").mkdir()
    np.savez(out / "checkpoint" / "state.npz", u=np.zeros(3))
    result = CliRunner().invoke(app, ["run", "--resume", "--out", str(out)])
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    print(f"\n{result.stderr}")
    assert result.exit_code == 2
    assert len(lines) == 1 and "older grainfrac (.npz)" in lines[0], result.stderr
