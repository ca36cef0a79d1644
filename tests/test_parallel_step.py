"""The parallel explicit step gives the serial step's motion bit for bit.

Cells and contacts compute their forces on all threads and every node gathers them
in the serial kernels' order, so displacements, stresses, contact states and cracks
do not depend on the number of threads; only the energy books' sums over nodes are
reduced in another order (round-off, 1e-12 relative asserted).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest

from grainfrac import materials
from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.loading.boundary import Loads
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.records import ENERGY_KEYS
from grainfrac.physics.solver import MechanicsSolver

PULL_SPEED = 0.05  # m/s, each side


def _pull(threads: int) -> MechanicsSolver:
    """A breakable quartz rectangle pulled apart until bonds break, on ``threads``."""
    recipe = materials.homogeneous_recipe("quartz", stiffness_factor=1.0, unbreakable=False)
    cfg = validate(SpecimenConfig, {"seed": 0, "specimen": {"shape": "rectangle"}})
    assembly = build_assembly(cfg, recipe)
    model = build_mechanical_model(assembly)
    loads = Loads.free(model.n_nodes)
    top, bottom = assembly.mesh.node_sets["top"], assembly.mesh.node_sets["bottom"]
    loads.fixed[top, 1] = loads.fixed[bottom, 1] = True
    loads.prescribed_velocity[top, 1] = PULL_SPEED
    loads.prescribed_velocity[bottom, 1] = -PULL_SPEED
    solver = MechanicsSolver(model, loads, threads=threads)
    for _ in range(40):
        solver.cycle(200)
        if len(solver.cracks.contact) > 20:
            break
    return solver


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_parallel_step_is_the_serial_step_bit_for_bit():
    serial = _pull(1)
    parallel = _pull(2)
    assert len(serial.cracks.contact) > 0
    assert serial.cracks.contact == parallel.cracks.contact
    assert serial.cracks.time == parallel.cracks.time
    assert serial.cracks.mode == parallel.cracks.mode
    for name, a in serial.state_arrays().items():
        if name == "energies":
            continue
        b = parallel.state_arrays()[name]
        assert np.array_equal(a, b), name
    worst = 0.0
    for key in ENERGY_KEYS:
        a, b = float(serial.energies[key][0]), float(parallel.energies[key][0])
        worst = max(worst, abs(a - b) / max(abs(a), 1e-300) if a != b else 0.0)
    print(f"\n{len(serial.cracks.contact)} cracks, identical; energy books differ by at most "
          f"{worst:.1e} relative (tol 1e-12)")
    assert worst < 1e-12


def _pull_block(threads: int, cycles: int = 40) -> MechanicsSolver:
    """A 3D block of four bonded slab grains pulled apart across its contact planes (up
    to ``cycles`` cycles of 100 steps)."""
    from grainfrac.physics.cuda.synthetic import grain_block, pull_loads

    block = grain_block(8, size=8e-3, cuts=3, softening=True)
    solver = MechanicsSolver(block.model, pull_loads(block, (2.0, 0.0, 0.0)),
                             threads=threads)
    for _ in range(cycles):
        solver.cycle(100)
        if len(solver.cracks.contact) > 20:
            break
    return solver


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_parallel_3d_step_is_the_serial_step_bit_for_bit():
    serial, parallel = _pull_block(1), _pull_block(2)
    assert len(serial.cracks.contact) > 0
    assert serial.cracks.contact == parallel.cracks.contact
    for name, a in serial.state_arrays().items():
        if name != "energies":
            assert np.array_equal(a, parallel.state_arrays()[name]), name


def solvers_take_turns() -> None:
    """Two solvers on 2 numba threads each, stepped from two Python threads at once,
    end as one does alone (run by the test below in a subprocess)."""
    from concurrent.futures import ThreadPoolExecutor

    def pull(solver: MechanicsSolver) -> MechanicsSolver:
        for _ in range(40):
            solver.cycle(100)
            if len(solver.cracks.contact) > 20:
                break
        return solver

    solvers = [_pull_block(2, cycles=0) for _ in range(3)]  # built one after another
    alone = pull(solvers[0])
    with ThreadPoolExecutor(2) as pool:
        together = list(pool.map(pull, solvers[1:]))
    for solver in together:
        assert solver.cracks.contact == alone.cracks.contact
        for name, a in alone.state_arrays().items():
            if name != "energies":
                assert np.array_equal(a, solver.state_arrays()[name]), name


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs 2 numba threads")
def test_parallel_solvers_in_two_threads_of_one_process_take_turns():
    """The explicit loop lets go of the interpreter, but solvers in two threads of one
    process still step one at a time: under numba's workqueue threading layer (the one
    left where neither OpenMP nor TBB is found) two parallel launches at once abort the
    process, as they did here without the solvers' lock."""
    tests = Path(__file__).resolve().parent
    env = {**os.environ, "NUMBA_THREADING_LAYER": "workqueue",
           "PYTHONPATH": os.pathsep.join([str(tests.parent / "src"),
                                          os.environ.get("PYTHONPATH", "")])}
    code = ("import sys; sys.path.insert(0, sys.argv[1]); "
            "from test_parallel_step import solvers_take_turns; solvers_take_turns()")
    out = subprocess.run([sys.executable, "-c", code, str(tests)], env=env,
                         capture_output=True, text=True, timeout=300, check=False)
    assert out.returncode == 0, out.stderr[-3000:]


def test_cell_blocks_share_no_node_and_cover_every_cell():
    from grainfrac.physics.cuda.synthetic import grain_block
    from grainfrac.physics.records import cell_blocks

    model = grain_block(8, size=8e-3, cuts=3).model
    bounds = cell_blocks(model.n_nodes, model.cells, n_blocks=64)
    assert bounds[0] == 0 and bounds[-1] == model.n_elements
    assert np.all(np.diff(bounds) > 0)
    assert len(bounds) - 1 == 4  # one block per slab grain: nowhere else to cut
    owner = np.full(model.n_nodes, -1)
    for b in range(len(bounds) - 1):
        nodes = np.unique(model.cells[bounds[b]:bounds[b + 1]])
        assert np.all(owner[nodes] == -1), f"block {b} shares a node with an earlier one"
        owner[nodes] = b
    # two blocks asked of four equal grains: cut in the middle
    assert list(cell_blocks(model.n_nodes, model.cells, n_blocks=2)) == [
        0, model.n_elements // 2, model.n_elements]
    # one grain: one block
    grain = model.cells[:bounds[1]]
    assert list(cell_blocks(model.n_nodes, grain)) == [0, len(grain)]


def test_cell_forces_by_any_number_of_tasks_are_the_serial_forces():
    """Each task takes the blocks nearest its share of the cells; with more tasks than
    blocks some get none. The forces and stresses stay the serial kernel's."""
    from grainfrac.physics import kernels
    from grainfrac.physics.cuda.synthetic import grain_block, pull_loads

    block = grain_block(6, size=6e-3, cuts=3)
    solver = MechanicsSolver(block.model, pull_loads(block, (1.0, 0.0, 0.0)))
    solver.cycle(50)
    model = solver.model
    nodes, state = solver.node_state(), solver.element_state()
    serial = np.zeros_like(nodes.force)
    kernels.element_forces(nodes, model.elements, state, serial)
    serial_stress = state.stress.copy()
    for tasks in (1, 2, 3, 5, 9):
        nodes.force[:] = np.nan
        state.stress[:] = np.nan
        kernels.block_element_forces(nodes, model.elements, state, model.adjacency, tasks)
        assert np.array_equal(nodes.force, serial), tasks
        assert np.array_equal(state.stress, serial_stress), tasks


def test_threads_option_is_checked_before_any_compute(monkeypatch):
    from typer.testing import CliRunner

    from grainfrac.cli import app
    from grainfrac.threads import THREADS_VARIABLE, default_threads

    monkeypatch.setenv(THREADS_VARIABLE, "1")  # restored after the test
    runner = CliRunner()
    bad = runner.invoke(app, ["--threads", "0", "version"])
    assert bad.exit_code == 2 and "--threads" in bad.output and "got 0" in bad.output
    assert runner.invoke(app, ["--threads", "lots", "version"]).exit_code == 2
    good = runner.invoke(app, ["--threads", "all", "version"])
    assert good.exit_code == 0
    assert default_threads() == numba.config.NUMBA_NUM_THREADS
