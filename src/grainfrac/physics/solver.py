"""Explicit quasi-static driver for the grain-contact mechanics.

One object owns the state arrays and advances them with the compiled
``run_steps`` loop; it records cracks and energies. It neither writes files
nor plots (that is io/ and viz/).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field

import numba
import numpy as np

from grainfrac.errors import GrainfracError
from grainfrac.loading.boundary import Loads, Platen
from grainfrac.physics import kernels
from grainfrac.physics.elements import n_strain_components, n_stress_components
from grainfrac.physics.model import MechanicalModel
from grainfrac.physics.records import (
    ENERGY_KEYS,
    ContactState,
    CrackLog,
    ElementState,
    NodeLoads,
    NodeState,
    PlatenSet,
    PoreSpringSet,
    StepControl,
    new_energies,
)
from grainfrac.threads import default_threads

# The solver's evolving state: what a checkpoint saves and a rejected step restores.
STATE_ARRAYS = ("u", "v", "stress", "bonded", "status", "sigma_n", "tau", "damage",
                "plastic_opening", "contact_pressure", "released", "energies", "eigenstrain",
                "eigenstrain_rate", "initial_strain", "opening_offset")
# State arrays that no step changes and only a stage sets between cycles (SCDA charging
# the expansion rates, a plug's insertion the initial strains).
SET_BY_STAGES = ("eigenstrain_rate", "initial_strain")


def _copy(value: np.ndarray, into: np.ndarray | None) -> np.ndarray:
    """A copy of ``value``: written into ``into`` if that is an array of its shape and type."""
    if into is None or into.shape != value.shape or into.dtype != value.dtype:
        return value.copy()
    np.copyto(into, value)
    return into


# Environment variable naming the backend of the explicit step (see resolve_backend).
BACKEND_VARIABLE = "GRAINFRAC_BACKEND"
BACKENDS = ("cpu", "cuda")


def resolve_backend(requested: str | None = None) -> str:
    """The backend of the explicit step: ``$GRAINFRAC_BACKEND`` (set by ``grainfrac
    --backend``) if set, else ``requested`` (a scenario's ``numerics.backend``), else
    ``"cpu"``; checked before any compute.

    ``"cuda"`` needs an NVIDIA GPU that numba-cuda can use (or numba's CUDA simulator,
    ``NUMBA_ENABLE_CUDASIM=1``, which runs the same kernels slowly on the CPU).
    """
    value = os.environ.get(BACKEND_VARIABLE, "").strip().lower() or requested or "cpu"
    if value not in BACKENDS:
        raise GrainfracError(f"backend must be one of {', '.join(BACKENDS)}, got {value!r}")
    if value == "cuda":
        from grainfrac.physics.cuda import SIMULATOR, cuda_available

        if not (SIMULATOR or cuda_available()):
            raise GrainfracError("backend 'cuda' needs an NVIDIA GPU usable by numba-cuda, "
                                 "and none was found; use backend 'cpu'")
    return value


class NumericalBlowUp(GrainfracError):
    """The explicit scheme diverged (NaN or runaway velocities)."""


# Quasi-static grain motions are far below this (m/s); beyond it the explicit
# scheme is running away, not the rock.
DEFAULT_VELOCITY_LIMIT = 100.0

# The explicit loop lets go of the interpreter (a run's snapshots are written
# meanwhile), but solvers stepping in several threads of one process still take turns,
# as they did while it held it: numba's "workqueue" threading layer (the one left where
# neither OpenMP nor TBB is found) aborts on parallel kernels entered from two threads.
_STEPPING = threading.Lock()


@dataclass
class CrackRecord:
    """Cracks in the order they formed: contact ids, times (s) and modes."""

    contact: list[int]
    time: list[float]
    mode: list[int]
    energy: list[float]


@dataclass
class PoreSprings:
    """Pores whose fluid pressure follows their void during a mechanics cycle.

    ``contact`` lists their sub-contacts, ``pore`` the pore of each (an index
    into the per-pore arrays), ``lower`` each sub-contact's smallest aperture,
    ``initial_aperture`` the a0 of its void (one for all, or one each); per pore,
    ``held_void`` (m3), ``storage`` (m3/Pa) and ``ceiling`` (Pa), the most pressure it
    may reach. See :func:`grainfrac.physics.kernels.pore_spring_pressure`.
    """

    contact: np.ndarray
    pore: np.ndarray
    lower: np.ndarray
    initial_aperture: float | np.ndarray
    held_void: np.ndarray
    storage: np.ndarray
    ceiling: np.ndarray
    resistance: np.ndarray | None = None
    dissipated: np.ndarray = field(default_factory=lambda: np.zeros(1))

    @classmethod
    def none(cls) -> PoreSprings:
        empty = np.zeros(0)
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), empty, 0.0, empty,
                   empty, empty)

    def record(self) -> PoreSpringSet:
        """The kernels' record, with fresh workspaces."""
        n = len(self.held_void)
        resistance = np.zeros(n) if self.resistance is None else self.resistance
        a0 = np.broadcast_to(np.asarray(self.initial_aperture, float), self.contact.shape)
        return PoreSpringSet(self.contact, self.pore, self.lower, np.ascontiguousarray(a0),
                             self.held_void, self.storage, self.ceiling, resistance,
                             np.zeros(n), np.zeros(n), self.dissipated)


class MechanicsSolver:
    """Advance a :class:`MechanicalModel` under :class:`Loads`.

    Parameters
    ----------
    model
        Model arrays.
    loads
        External forces, supports and platens (may be changed between calls).
    damping
        Local non-viscous damping coefficient (Itasca default 0.8).
    threads
        CPU threads of the explicit step (the motion is the same bit for bit on any
        number); default :func:`default_threads`.
    backend
        ``"cpu"`` (numba kernels, the reference) or ``"cuda"`` (the same laws on an
        NVIDIA GPU, :mod:`grainfrac.physics.cuda`; same results to round-off).
    """

    def __init__(self, model: MechanicalModel, loads: Loads | None = None, damping: float = 0.8,
                 velocity_limit: float = DEFAULT_VELOCITY_LIMIT, threads: int | None = None,
                 backend: str = "cpu"):
        if not 0.0 <= damping < 1.0:
            raise ValueError(f"damping must be in [0, 1), got {damping}")
        # Local damping can raise the effective force to (1 + alpha) F, which
        # shrinks the stable step by sqrt(1 + alpha) (measured: 0.74 stable,
        # 0.75 runaway for alpha = 0.8).
        limit = 1.0 / np.sqrt(1.0 + damping)
        if model.safety >= limit:
            raise ValueError(
                f"time-step safety {model.safety:g} must be < 1/sqrt(1 + damping) = {limit:.3f}"
            )
        self.velocity_limit = velocity_limit
        self.threads = default_threads() if threads is None else threads
        if not 1 <= self.threads <= numba.config.NUMBA_NUM_THREADS:
            raise ValueError(f"threads must be in [1, {numba.config.NUMBA_NUM_THREADS}] (the "
                             f"cores numba may use), got {self.threads}")
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
        self.backend = backend
        # The GPU copy of the state (backend "cuda"), made at the first cycle, and the
        # host edits it has seen: restore_state and load_state_arrays count one.
        self._device = None
        self._state_edits = 0
        self.model = model
        self.loads = (loads if loads is not None
                      else Loads.free(model.n_nodes, model.dimension))
        self.damping = damping
        self.allow_failure = True
        n, c, m, d = model.n_nodes, model.n_contacts, model.n_elements, model.dimension
        zeros = np.zeros
        if backend == "cuda":
            # Pinned host memory: the state crosses the bus every cycle (the 100 mm
            # cube's pull is ~70 MB a fluid step).
            from grainfrac.physics.cuda import host_zeros as zeros
        self.u = zeros((n, d))
        self.v = zeros((n, d))
        self.force = zeros((n, d))
        self.stress = zeros((m, n_stress_components(d)))
        self.bonded = zeros(c, dtype=np.bool_)
        self.bonded[:] = model.initially_bonded
        self.status = zeros(c, dtype=np.int64)
        self.sigma_n = zeros(c)
        self.tau = zeros((c, d - 1))
        self.damage = zeros(c)
        self.plastic_opening = zeros(c)
        self.contact_pressure = zeros(c)
        self.released = zeros(c)
        self.eigenstrain = zeros(m)
        self.eigenstrain_rate = zeros(m)
        self.initial_strain = zeros((m, n_strain_components(d)))
        self.opening_offset = zeros(c)
        self.energies = new_energies()
        self.time = 0.0
        self.step_count = 0
        self.cracks = CrackRecord([], [], [], [])
        self._crack_log = CrackLog(np.zeros(c, dtype=np.int64), np.zeros(c, dtype=np.int64))
        # Set by a hydro-mechanical coupling for the next cycle only.
        self.pore_springs = PoreSprings.none()

    # -- stepping -----------------------------------------------------------------
    def _platen_set(self) -> PlatenSet:
        platens: list[Platen] = self.loads.platens
        nodes = [p.nodes for p in platens]
        offsets = np.cumsum([0] + [len(x) for x in nodes]).astype(np.int64)
        cat = np.concatenate(nodes).astype(np.int64) if nodes else np.zeros(0, np.int64)
        stiff = np.concatenate([p.stiffness for p in platens]) if platens else np.zeros(0)
        return PlatenSet(
            self.model.x, cat, offsets,
            np.array([p.axis for p in platens], dtype=np.int64),
            np.array([p.side for p in platens], dtype=np.float64),
            np.array([p.position for p in platens], dtype=np.float64),
            np.array([p.velocity for p in platens], dtype=np.float64),
            stiff, np.zeros(len(platens)), np.zeros(len(cat)),
        )

    def node_state(self) -> NodeState:
        return NodeState(self.u, self.v, self.force)

    def element_state(self) -> ElementState:
        return ElementState(self.stress, self.eigenstrain, self.eigenstrain_rate,
                            self.initial_strain)

    def contact_state(self) -> ContactState:
        return ContactState(self.bonded, self.status, self.sigma_n, self.tau, self.damage,
                            self.plastic_opening, self.contact_pressure, self.released,
                            self.opening_offset)

    def cycle(self, n_steps: int) -> None:
        """Advance ``n_steps`` steps; record new cracks; check for blow-up."""
        if self.backend == "cuda":
            self._cycle_on_device(n_steps)
            return
        m, ld = self.model, self.loads
        platens = self._platen_set()
        if self.threads > 1:
            numba.set_num_threads(self.threads)  # per calling thread; cheap
        control = StepControl(int(n_steps), m.dt, self.damping, bool(self.allow_failure),
                              float(self.velocity_limit), self.threads)
        node_loads = NodeLoads(m.mass, ld.external, ld.fixed, ld.prescribed_velocity)
        run_steps = kernels.run_steps_threaded if self.threads > 1 else kernels.run_steps
        with _STEPPING:
            n_new, done = run_steps(
                control, self.node_state(), node_loads, m.elements, self.element_state(),
                m.contacts, self.contact_state(), m.adjacency, platens,
                self.pore_springs.record(), self.energies, self._crack_log,
            )
        self._book_cycle(self._crack_log.contact[:n_new], self._crack_log.step[:n_new],
                         platens.position, platens.reaction, done, n_steps)

    def _cycle_on_device(self, n_steps: int) -> None:
        """:meth:`cycle` on the GPU: the host arrays stay the state's master copy. The
        device gets what the host may have changed (loads, pressures, expansion rates,
        energy books every cycle; the whole state after a host edit) and gives back
        what the step changed."""
        from grainfrac.physics.cuda import CudaMechanics

        if self._device is None:
            self._device = CudaMechanics(self)
            self._device.state_edits = self._state_edits
        elif self._device.state_edits != self._state_edits:
            self._device.push()
            self._device.state_edits = self._state_edits
        else:
            self._device.push_inputs()
        record = self._device.cycle(n_steps)
        self._book_cycle(*record, n_steps)

    def note_state_edit(self) -> None:
        """Say that the host changed the state arrays between cycles (beyond the loads
        and the inputs sent every cycle: contact fluid pressures and opening offsets,
        expansion rates): the GPU backend copies the whole state to the device before
        the next cycle. :meth:`restore_state` and
        :meth:`load_state_arrays` say it themselves."""
        self._state_edits += 1

    def _book_cycle(self, crack_contact: np.ndarray, crack_step: np.ndarray,
                    platen_position: np.ndarray, platen_reaction: np.ndarray, done: int,
                    n_steps: int) -> None:
        """After a cycle of ``done`` of ``n_steps`` steps: platens, new cracks (contact
        and step within the cycle), time; a cycle cut short ran away."""
        m, ld = self.model, self.loads
        for platen, pos, reac in zip(ld.platens, platen_position, platen_reaction, strict=True):
            platen.position = float(pos)
            platen.reaction = float(-reac)
        for c, k in zip(crack_contact, crack_step, strict=True):
            c = int(c)
            self.cracks.contact.append(c)
            self.cracks.time.append(self.time + (int(k) + 1) * m.dt)
            self.cracks.mode.append(int(self.status[c]))
            self.cracks.energy.append(float(self.released[c]))
        self.time += done * m.dt
        self.step_count += done
        if done < n_steps:
            vmax = float(np.nanmax(np.abs(self.v))) if np.isfinite(self.v).any() else np.inf
            raise NumericalBlowUp(
                f"velocities ran away at step {self.step_count} (t = {self.time:.6g} s): "
                f"max |v| = {vmax:.3g} m/s > {self.velocity_limit:g} m/s"
            )

    # -- state as named arrays (checkpoints) -----------------------------------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """The evolving state as named arrays (live views), for checkpoints.

        With :meth:`load_state_arrays` this is the whole state a checkpoint needs
        besides ``time``, ``step_count``, ``allow_failure``, the loads and the crack
        record; writers iterate over the names instead of listing them.
        """
        return {name: getattr(self, name) for name in STATE_ARRAYS}

    def load_state_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Copy named arrays (as from :meth:`state_arrays`) into the state, in place.

        Raises ``KeyError`` naming the first missing array and ``ValueError`` on a
        shape mismatch, so a checkpoint of another model fails clearly.
        """
        self.note_state_edit()
        for name, target in self.state_arrays().items():
            value = np.asarray(arrays[name])
            if value.shape != target.shape:
                raise ValueError(f"state array {name!r} has shape {value.shape}, the model "
                                 f"needs {target.shape}")
            target[...] = value

    # -- state in memory (step rejection) ------------------------------------------
    def save_state(self, into: dict | None = None, *, with_stress: bool = True) -> dict:
        """A copy of everything :meth:`cycle` changes, for :meth:`restore_state`.

        Not the element-sized inputs that only stages set (``SET_BY_STAGES``), nor the
        eigenstrains while nothing expands (no step changes them then): a coupled
        step saves the state before each fluid step, and on the 100 mm cube those
        arrays were three quarters of the 23 ms a save took.

        ``into``: an earlier save that is no longer needed, whose arrays are written
        over where they are the same ones (fresh arrays of the cube's tens of
        megabytes cost the page faults of new memory on every fluid step).

        ``with_stress`` False leaves out the element stresses, which every step writes
        before it reads them: for a caller that steps after each restore before
        anything reads them (the coupled step; two thirds of a save on the 100 mm cube).
        """
        fixed = SET_BY_STAGES if self.eigenstrain_rate.any() else (*SET_BY_STAGES,
                                                                   "eigenstrain")
        if not with_stress:
            fixed = (*fixed, "stress")
        spare = {} if into is None else into["arrays"]
        return {
            "arrays": {name: _copy(getattr(self, name), spare.get(name))
                       for name in STATE_ARRAYS if name not in fixed},
            "external": _copy(self.loads.external, None if into is None else into["external"]),
            "platens": [(p.position, p.reaction) for p in self.loads.platens],
            "time": self.time,
            "step_count": self.step_count,
            "n_cracks": len(self.cracks.contact),
        }

    def restore_state(self, saved: dict) -> None:
        """Go back to a state taken by :meth:`save_state` (cracks formed since are dropped;
        the arrays it did not save stay as they are)."""
        self.note_state_edit()
        for name, value in saved["arrays"].items():
            getattr(self, name)[...] = value
        self.loads.external[...] = saved["external"]
        for p, (position, reaction) in zip(self.loads.platens, saved["platens"], strict=True):
            p.position, p.reaction = position, reaction
        self.time = saved["time"]
        self.step_count = saved["step_count"]
        n = saved["n_cracks"]
        for record in (self.cracks.contact, self.cracks.time, self.cracks.mode,
                       self.cracks.energy):
            del record[n:]

    # -- diagnostics --------------------------------------------------------------
    def unbalanced_force_ratio(self) -> float:
        """Mean unbalanced force over free components / mean applied force magnitude.

        Applied force: the larger of the external forces and the internal forces
        (Itasca's ratio uses gridpoint force sums); 0 when nothing is loaded.
        """
        free = ~self.loads.fixed
        total = self.force + self.loads.external
        unbalanced = np.abs(total[free]).mean() if free.any() else 0.0
        scale = max(np.abs(self.loads.external).sum(), np.abs(self.force).sum() / 2.0)
        scale /= max(np.count_nonzero(np.any(self.loads.external != 0, axis=1)
                                      | np.any(self.force != 0, axis=1)), 1)
        return float(unbalanced / scale) if scale > 0 else 0.0

    def equilibrate(self, ratio: float = 1e-5, max_steps: int = 200_000,
                    check_every: int = 200) -> float:
        """Step until the unbalanced-force ratio falls below ``ratio``; return it."""
        steps = 0
        current = np.inf
        while steps < max_steps:
            self.cycle(check_every)
            steps += check_every
            current = self.unbalanced_force_ratio()
            if current < ratio:
                break
        return current

    def kinetic_energy(self) -> float:
        return float(0.5 * np.sum(self.model.mass[:, None] * self.v**2))

    def grain_strain_energy(self) -> float:
        return float(kernels.element_strain_energy(self.u, self.model.elements,
                                                   self.element_state()))

    def contact_strain_energy(self) -> float:
        m = self.model
        return kernels.contact_strain_energy(self.sigma_n, self.tau, m.normal_stiffness,
                                             m.shear_stiffness, m.contact_area)

    def energy_balance(self) -> dict[str, float]:
        """Energies (J): work in, stored, dissipated, and the residual of the balance."""
        out = {name: float(self.energies[name][0]) for name in ENERGY_KEYS}
        out["grain_strain_energy"] = self.grain_strain_energy()
        out["contact_strain_energy"] = self.contact_strain_energy()
        out["kinetic_energy"] = self.kinetic_energy()
        work_in = (out["boundary_work"] + out["platen_work"] + out["expansion_work"]
                   + out["fluid_work"])
        stored = out["grain_strain_energy"] + out["contact_strain_energy"] + out["kinetic_energy"]
        # energy_removed: stored energy that left with a removed body (a drilled-out plug).
        dissipated = (out["damping_work"] + out["friction_work"]
                      + out["bond_energy_released"] + out["energy_removed"])
        out["work_in"] = work_in
        out["residual"] = work_in - stored - dissipated
        return out
