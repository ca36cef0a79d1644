"""The CUDA backend against the CPU backend on a tiny 3D grain block.

Under numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, which must be set before
numba is imported, hence a subprocess) on every machine; on a real GPU when there
is one. The block (162 tets, 3 slab grains, 32 bonded sub-contacts, one plane
softening, one brittle) is pulled apart and sheared, a quarter of its elements
expand, a platen presses on its top and a pore's fluid pressure follows the void
of one contact plane; 2 cycles of 6 steps break the brittle plane.

Tolerances. With ordered sums (the default) every node adds its cells', contacts'
and platen nodes' forces in the CPU's order, so under the simulator the states are
the CPU's to the last bit (checked: 0); only the energy books are block-reduced in
another order (<= 1e-12). On a GPU the compiler also fuses multiplies and adds,
and with atomic sums the order of the adds varies: states agree to round-off,
observed <= 1e-15 relative; the checks allow 1e-12. Round-off is amplified wherever
local damping takes the sign of a velocity that is zero up to round-off (a node
whose forces cancel by symmetry): that step's damping force flips, a difference of
2 alpha |F| dt / m. Uniform expansion of a symmetric block shows it (1e-7 after 2
steps), so the test expands at uneven rates.
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


def _compare(simulator: bool, sums: str = "ordered") -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_ENABLE_CUDASIM")}
    if simulator:
        env["NUMBA_ENABLE_CUDASIM"] = "1"
    env["GRAINFRAC_CUDA_SUMS"] = sums
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    out = subprocess.run(
        [sys.executable, str(ROOT / "tests" / "cuda_compare.py"), "3", "6", "2", "20", "extras"],
        env=env, capture_output=True, text=True, timeout=300, check=False,
    )
    assert out.returncode == 0, out.stderr[-4000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _check(report: dict, states: float = TOLERANCE) -> None:
    """``states``: the relative tolerance of the state arrays (0: bit for bit)."""
    print("\n" + json.dumps({k: v for k, v in report.items() if "rel" in k}, indent=1))
    assert report["cpu_cracks"], "the load must break some contacts"
    assert report["gpu_cracks"] == report["cpu_cracks"]  # same (contact, mode) set
    assert report["same_crack_order"] and report["crack_time_diff"] == 0.0
    for name in ("u_rel", "v_rel", "force_rel", "stress_rel", "sigma_n_rel", "tau_rel",
                 "damage_rel", "pressure_rel"):
        assert report[name] <= states, name
    for book, rel in report["energy_rel"].items():
        assert rel <= TOLERANCE, book
    assert report["energy_cpu"]["expansion_work"] > 0.0
    assert report["energy_cpu"]["platen_work"] != 0.0
    assert report["energy_cpu"]["fluid_work"] != 0.0
    assert report["energy_cpu"]["bond_energy_released"] > 0.0
    (cpu_pos, cpu_reac), = report["platen"]
    (gpu_pos, gpu_reac), = report["platen_gpu"]
    assert gpu_pos == cpu_pos and gpu_reac == pytest.approx(cpu_reac, rel=states, abs=0)
    assert report["time"][0] == report["time"][1]
    cpu_lost, gpu_lost = report["pore_dissipated"]
    if cpu_lost:  # with extras: the pore's flow resistance dissipated as much on both
        assert gpu_lost == pytest.approx(cpu_lost, rel=TOLERANCE)
    assert report["blowup_steps"] == [1, 1]


def test_simulated_cuda_backend_is_the_cpu_bit_for_bit():
    report = _compare(simulator=True)
    assert report["simulator"] and report["ordered"]
    assert report["launches"]["prepared"] == 0 and report["launches"]["plain"] > 0
    _check(report, states=0.0)


def test_simulated_atomic_sums_match_cpu_to_round_off():
    report = _compare(simulator=True, sums="atomic")
    assert report["simulator"] and not report["ordered"]
    _check(report)


@pytest.mark.gpu
@pytest.mark.skipif(not cuda_available(), reason="no CUDA GPU")
@pytest.mark.parametrize("sums", ["ordered", "atomic"])
def test_gpu_backend_matches_cpu(sums):
    report = _compare(simulator=False, sums=sums)
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
