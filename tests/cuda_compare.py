"""Run a tiny grain block on the CPU backend and on the CUDA backend, print a JSON report.

Run by ``tests/test_cuda_backend.py`` in a subprocess with ``NUMBA_ENABLE_CUDASIM=1``
(the simulator must be chosen before numba is imported), or directly on a GPU.
Usage: ``python tests/cuda_compare.py N_CELLS STEPS CYCLES VELOCITY [extras]``; with
``extras`` a platen presses on the top face and a pore's fluid pressure follows
the void of the middle contact plane and its rate
(:class:`~grainfrac.physics.solver.PoreSprings`).
``$GRAINFRAC_CUDA_SUMS`` chooses the GPU's ordered or atomic sums.
"""

from __future__ import annotations

import json
import sys
import threading

import numpy as np

from grainfrac.loading.boundary import Platen
from grainfrac.physics.cuda import SIMULATOR, launch
from grainfrac.physics.cuda.mechanics import ordered_sums
from grainfrac.physics.cuda.synthetic import grain_block, pull_loads
from grainfrac.physics.records import ENERGY_KEYS
from grainfrac.physics.solver import MechanicsSolver, NumericalBlowUp, PoreSprings


def quicken_simulator() -> None:
    """Run numba's CUDA simulator about 7 x faster, with the same results.

    The simulator runs each thread of a block as a Python thread while the launching
    thread polls them; at Python's default 5 ms switch interval the poll holds the
    interpreter most of the time (162 tetrahedra, 12 steps: 52 s; at 0.1 ms: 8 s,
    the same report). A short interval also exposes a race in the simulator: a
    block's threads get its shared array from a dictionary filled without a lock,
    so two threads can each make one (at 0.01 ms the energy books of two kernels
    came out wrong); the lock below closes it.
    """
    from numba.cuda.simulator import kernelapi

    lock = threading.Lock()

    def array(self, shape, dtype):
        if shape == 0:  # dynamic shared memory: one buffer made up front, no race
            return unlocked(self, shape, dtype)
        if isinstance(dtype, kernelapi.types.Type):
            dtype = kernelapi.numpy_support.as_dtype(dtype)
        caller = sys._getframe(1)
        key = (caller.f_code.co_filename, caller.f_lineno)  # the simulator's own key
        with lock:
            if key not in self._allocations:
                self._allocations[key] = np.empty(shape, dtype)
            return self._allocations[key]

    unlocked = kernelapi.FakeCUDAShared.array
    kernelapi.FakeCUDAShared.array = array
    sys.setswitchinterval(1e-4)


def relative(a: np.ndarray, b: np.ndarray) -> float:
    scale = max(float(np.max(np.abs(a))), 1e-300)
    return float(np.max(np.abs(a - b)) / scale)


def main() -> None:
    n, steps, cycles = (int(a) for a in sys.argv[1:4])
    velocity = float(sys.argv[4])
    extras = len(sys.argv) > 5 and sys.argv[5] == "extras"
    if SIMULATOR:
        quicken_simulator()
    block = grain_block(n, cuts=2)
    solvers = []
    for backend in ("cpu", "cuda"):
        loads = pull_loads(block, (velocity, 0.3 * velocity, 0.0))
        if extras:
            top = np.flatnonzero(np.isclose(block.model.x[:, 2], block.model.x[:, 2].max()))
            loads.platens.append(Platen(top, 2, 1, float(block.model.x[:, 2].max()), -0.5,
                                        np.full(len(top), 1e9)))
        solver = MechanicsSolver(block.model, loads, backend=backend)
        # Some expansion, at uneven rates: a node whose force cancels by symmetry has
        # a round-off velocity whose sign (local damping) neither backend can be
        # expected to reproduce.
        quarter = len(solver.eigenstrain_rate) // 4
        solver.eigenstrain_rate[:quarter] = np.random.default_rng(1).uniform(1.0, 3.0, quarter)
        if extras:
            half = block.model.n_contacts // 2
            c = np.arange(half, block.model.n_contacts)  # the second contact plane
            area = block.model.contact_area[c]
            # The pore's pipes resist its void's growth (kernels.pore_pressure).
            solver.pore_springs = PoreSprings(
                c, np.zeros(len(c), np.int64), np.full(len(c), 1e-7),
                np.linspace(1e-6, 3e-6, len(c)),  # a0 of each void (closure_storage)
                np.array([2.5e-6 * area.sum()]), np.array([1e-18]), np.array([30e6]),
                resistance=np.array([1e6 / area.sum()]))
        solvers.append(solver)
    cpu, gpu_host = solvers
    for _ in range(cycles):
        cpu.cycle(steps)
        gpu_host.cycle(steps)
    report = {
        "simulator": SIMULATOR,
        "ordered": ordered_sums(),
        "tets": block.model.n_elements, "contacts": block.model.n_contacts,
        "steps": steps * cycles,
        "cpu_cracks": sorted(zip(cpu.cracks.contact, cpu.cracks.mode, strict=True)),
        "gpu_cracks": sorted(zip(gpu_host.cracks.contact, gpu_host.cracks.mode, strict=True)),
        "same_crack_order": cpu.cracks.contact == gpu_host.cracks.contact,
        "crack_time_diff": float(np.max(np.abs(np.subtract(cpu.cracks.time,
                                                           gpu_host.cracks.time))))
        if len(cpu.cracks.time) == len(gpu_host.cracks.time) and cpu.cracks.time else 0.0,
        "u_rel": relative(cpu.u, gpu_host.u),
        "v_rel": relative(cpu.v, gpu_host.v),
        "force_rel": relative(cpu.force, gpu_host.force),
        "stress_rel": relative(cpu.stress, gpu_host.stress),
        "sigma_n_rel": relative(cpu.sigma_n, gpu_host.sigma_n),
        "tau_rel": relative(cpu.tau, gpu_host.tau),
        "damage_rel": relative(cpu.damage, gpu_host.damage),
        "pressure_rel": relative(cpu.contact_pressure, gpu_host.contact_pressure),
        "energy_rel": {k: abs(float(cpu.energies[k][0] - gpu_host.energies[k][0]))
                       / max(abs(float(cpu.energies[k][0])), 1e-300) for k in ENERGY_KEYS},
        "energy_cpu": {k: float(cpu.energies[k][0]) for k in ENERGY_KEYS},
        "platen": [(p.position, p.reaction) for p in cpu.loads.platens],
        "platen_gpu": [(p.position, p.reaction) for p in gpu_host.loads.platens],
        "time": [cpu.time, gpu_host.time],
        "pore_dissipated": [float(s.pore_springs.dissipated[0]) for s in (cpu, gpu_host)],
    }
    # A blow-up: the pull outruns a 5 m/s velocity limit in the first step; both
    # backends stop after it and say so.
    stops = []
    for backend in ("cpu", "cuda"):
        solver = MechanicsSolver(block.model, pull_loads(block, (velocity, 0.0, 0.0)),
                                 velocity_limit=5.0, backend=backend)
        try:
            solver.cycle(3)
            stops.append(None)
        except NumericalBlowUp:
            stops.append(solver.step_count)
    report["blowup_steps"] = stops
    report["launches"] = launch.counts
    print(json.dumps(report))


if __name__ == "__main__":
    main()
