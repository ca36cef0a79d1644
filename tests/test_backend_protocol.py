"""The CUDA backend's host side in a whole 3D scenario, on any machine.

A run with ``numerics.backend = "cuda"`` keeps the host arrays as the state's master
copy: before each cycle the solver sends the device what the host changed (loads,
contact pressures, expansion rates, energy books; the whole state after a rejected
fluid step's restore or a checkpoint's load) and after it takes back what the step
changed (:class:`grainfrac.physics.cuda.CudaMechanics`). A missed copy in either
direction changes the run.

numba's CUDA simulator runs a 1080-tetrahedron slab at 16 s a step on this project's
machine (measured), far too slow for a scenario. So here the device is emulated by
host arrays that only the copies reach, and the step on them is the CPU kernels':
the run must then be the CPU backend's run to the last bit. The CUDA kernels
themselves are checked against the CPU kernels under the simulator
(``tests/test_cuda_backend.py``), and whole scenarios on a real GPU
(``benchmarks/gpu.py --runs``).
"""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import numpy as np
import pytest

import grainfrac.physics.cuda as cuda_backend
from grainfrac.errors import GrainfracError
from grainfrac.io.config import validate
from grainfrac.physics import kernels
from grainfrac.physics.cuda import stepper
from grainfrac.physics.cuda.mechanics import CudaMechanics
from grainfrac.physics.cuda.synthetic import grain_block
from grainfrac.physics.records import ENERGY_DTYPE, StepControl
from grainfrac.physics.solver import (
    BACKEND_VARIABLE,
    STATE_ARRAYS,
    MechanicsSolver,
    resolve_backend,
)
from grainfrac.scenario import Scenario
from grainfrac.simulation import run_scenario

HYBRID = tomllib.loads((Path(__file__).parent / "data" / "hybrid3d-small.toml").read_text())


class _DeviceArray(np.ndarray):
    """A host array standing in for a device array: reached only by the copies."""

    def copy_to_host(self, out=None):
        if out is None:
            return np.array(self, copy=True).view(np.ndarray)
        out[...] = self
        return out

    def copy_to_device(self, source) -> None:
        self[...] = source


class _EmulatedCuda:
    @staticmethod
    def to_device(array):
        return np.array(array, copy=True).view(_DeviceArray)

    @staticmethod
    def device_array(shape):
        return np.empty(shape).view(_DeviceArray)

    @staticmethod
    def pinned_array(shape, dtype=np.float64):
        return np.empty(shape, dtype)

    @staticmethod
    def synchronize() -> None:
        pass


def _host(record):
    return type(record)(*(np.asarray(a) if isinstance(a, np.ndarray) else a for a in record))


def _advance_with_cpu_kernels(self, n_steps, *, timings=None):
    s = self.solver
    return kernels.run_steps(
        StepControl(int(n_steps), s.model.dt, s.damping, bool(s.allow_failure),
                    float(s.velocity_limit), 1),
        _host(self._nodes), _host(self._loads), _host(self._elements),
        _host(self._element_state), _host(self._contacts), _host(self._contact_state),
        s.model.adjacency, _host(self._platens), s.pore_springs.record(),
        np.asarray(self._energies).view(ENERGY_DTYPE), _host(self._cracks))


def _run(tmp_path, backend: str):
    scenario = validate(Scenario, {**HYBRID, "numerics": {"backend": backend}})
    out = tmp_path / backend
    return out, run_scenario(scenario, scenario.recipe(), out)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("protocol")
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv(BACKEND_VARIABLE, raising=False)
        cpu = _run(tmp, "cpu")
        mp.setattr(stepper, "cuda", _EmulatedCuda)
        mp.setattr(CudaMechanics, "advance", _advance_with_cpu_kernels)
        mp.setattr(cuda_backend, "cuda_available", lambda: True)
        pushes = []
        whole_state = CudaMechanics.push
        mp.setattr(CudaMechanics, "push", lambda self: (pushes.append(1), whole_state(self)))
        device = _run(tmp, "cuda")
    return cpu, device, len(pushes)


def _rows(path):
    return list(csv.DictReader(open(path)))


def test_a_cuda_run_is_the_cpu_run_through_the_host_device_copies(runs):
    (cpu_dir, cpu), (dev_dir, dev), _ = runs
    assert cpu["stages"] == ["equilibrate", "scda", "drill_out", "inject"]
    assert cpu["breakdown_pressure_MPa"] is not None and cpu["n_cracks"] > 0
    for key in set(cpu) - {"wall_time_s"}:
        assert dev[key] == cpu[key], key
    assert (dev_dir / "cracks.csv").read_text() == (cpu_dir / "cracks.csv").read_text()
    cpu_rows, dev_rows = _rows(cpu_dir / "history.csv"), _rows(dev_dir / "history.csv")
    assert dev_rows == cpu_rows


def test_the_run_restored_rejected_fluid_steps_on_the_device(runs):
    """Three solvers (rock, rock with the plug, rock again) each copy the state once;
    every further whole-state copy follows a rejected fluid step's restore."""
    *_, pushes = runs
    print(f"whole-state copies to the device: {pushes}")
    assert pushes > 3


def test_a_gpu_solver_keeps_its_state_in_pinned_host_memory(monkeypatch):
    """Every state array of a solver on the GPU backend (copied each cycle; not the
    64-byte energy books) is made by ``cuda.pinned_array``, and starts as the CPU
    solver's."""
    made = []

    def pinned_array(shape, dtype=np.float64):
        made.append(np.empty(shape, dtype))
        return made[-1]

    monkeypatch.setattr(_EmulatedCuda, "pinned_array", staticmethod(pinned_array))
    monkeypatch.setattr(stepper, "cuda", _EmulatedCuda)
    model = grain_block(2, cuts=2).model
    gpu, cpu = MechanicsSolver(model, backend="cuda"), MechanicsSolver(model)
    for name in (set(STATE_ARRAYS) - {"energies"}) | {"force"}:
        array, reference = getattr(gpu, name), getattr(cpu, name)
        assert any(array is a for a in made), name
        assert array.dtype == reference.dtype, name
        np.testing.assert_array_equal(array, reference, err_msg=name)


def test_backend_cuda_without_a_gpu_is_refused_before_any_compute(monkeypatch):
    monkeypatch.delenv(BACKEND_VARIABLE, raising=False)
    monkeypatch.setattr(cuda_backend, "cuda_available", lambda: False)
    if cuda_backend.SIMULATOR:
        pytest.skip("the simulator stands in for a GPU")
    with pytest.raises(GrainfracError, match="backend 'cuda' needs an NVIDIA GPU"):
        resolve_backend("cuda")
    monkeypatch.setenv(BACKEND_VARIABLE, "opencl")
    with pytest.raises(GrainfracError, match="backend must be one of cpu, cuda"):
        resolve_backend("cpu")
    monkeypatch.setenv(BACKEND_VARIABLE, "cpu")
    assert resolve_backend("cuda") == "cpu"  # the command line's choice wins
    with pytest.raises(ValueError, match="backend"):
        validate(Scenario, {**HYBRID, "numerics": {"backend": "gpu"}})


def test_backend_option_is_checked_before_any_compute(monkeypatch):
    from typer.testing import CliRunner

    from grainfrac.cli import app

    monkeypatch.setenv(BACKEND_VARIABLE, "cpu")  # restored after the test
    monkeypatch.setattr(cuda_backend, "cuda_available", lambda: False)
    runner = CliRunner()
    bad = runner.invoke(app, ["--backend", "opencl", "version"])
    assert bad.exit_code == 2 and "--backend" in bad.output and "opencl" in bad.output
    if not cuda_backend.SIMULATOR:
        no_gpu = runner.invoke(app, ["--backend", "cuda", "version"])
        assert no_gpu.exit_code == 2 and "needs an NVIDIA GPU" in no_gpu.output
    assert runner.invoke(app, ["--backend", "cpu", "version"]).exit_code == 0
