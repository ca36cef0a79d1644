"""The CUDA backend against the CPU backend on a tiny 3D grain block.

Under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, which must be set before
numba is imported, hence a subprocess) on every machine; on a real GPU when there
is one. The block (162 tets, 3 slab grains, 32 bonded sub-contacts, one plane
softening, one brittle) is pulled apart and sheared, a quarter of its elements
expand, a platen presses on its top and a pore's fluid pressure follows the void
of one contact plane; 2 cycles of 6 steps break the brittle plane.

Tolerances: the backends add nodal forces and energy sums in different orders
(float64 atomics), so they agree to round-off, observed <= 1e-15 relative; the
checks allow 1e-12. Round-off is amplified wherever local damping takes the sign
of a velocity that is zero up to round-off (a node whose forces cancel by
symmetry): that step's damping force flips, a difference of 2 alpha |F| dt / m.
Uniform expansion of a symmetric block shows it (1e-7 after 2 steps), so the
test expands at uneven rates.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from grainfrac.physics.cuda import cuda_available

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 1e-12


def _compare(simulator: bool) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_ENABLE_CUDASIM")}
    if simulator:
        env["NUMBA_ENABLE_CUDASIM"] = "1"
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, str(ROOT / "tests" / "cuda_compare.py"), "3", "6", "2", "20", "extras"],
        env=env, capture_output=True, text=True, timeout=300, check=False,
    )
    assert out.returncode == 0, out.stderr[-4000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _check(report: dict) -> None:
    print("\n" + json.dumps({k: v for k, v in report.items() if "rel" in k}, indent=1))
    assert report["cpu_cracks"], "the load must break some contacts"
    assert report["gpu_cracks"] == report["cpu_cracks"]  # same (contact, mode) set
    assert report["same_crack_order"] and report["crack_time_diff"] == 0.0
    for name in ("u_rel", "v_rel", "force_rel", "stress_rel", "sigma_n_rel", "tau_rel",
                 "damage_rel"):
        assert report[name] <= TOLERANCE, name
    for book, rel in report["energy_rel"].items():
        assert rel <= TOLERANCE, book
    assert report["energy_cpu"]["expansion_work"] > 0.0
    assert report["energy_cpu"]["platen_work"] != 0.0
    assert report["energy_cpu"]["fluid_work"] != 0.0
    assert report["energy_cpu"]["bond_energy_released"] > 0.0
    (cpu_pos, cpu_reac), = report["platen"]
    (gpu_pos, gpu_reac), = report["platen_gpu"]
    assert gpu_pos == cpu_pos and gpu_reac == pytest.approx(cpu_reac, rel=TOLERANCE)
    assert report["time"][0] == report["time"][1]
    assert report["blowup_steps"] == [1, 1]


def test_simulated_cuda_backend_matches_cpu():
    report = _compare(simulator=True)
    assert report["simulator"]
    assert report["launches"]["prepared"] == 0 and report["launches"]["plain"] > 0
    _check(report)


@pytest.mark.gpu
@pytest.mark.skipif(not cuda_available(), reason="no CUDA GPU")
def test_gpu_backend_matches_cpu():
    report = _compare(simulator=False)
    assert not report["simulator"]
    # On a GPU the kernels go out as prepared launches (physics/cuda/launch.py).
    assert report["launches"]["prepared"] > 0 and report["launches"]["plain"] == 0
    _check(report)


@pytest.mark.slow  # 13 s; keeps the default suite under 10 min
def test_gpu_benchmark_runs_end_to_end_in_the_simulator():
    """``benchmarks/gpu.py --sim-smoke``: every code path of the GPU benchmark, tiny."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_ENABLE_CUDASIM")}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    out = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "gpu.py"), "--sim-smoke"],
                         env=env, capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stderr[-4000:]
    for needle in ("device: numba CUDA simulator", "tet-steps/s", "split (ms/step",
                   "CPU backend", "GPU/CPU at the same size", "total"):
        assert needle in out.stdout, needle
