"""``CudaMechanics``: a :class:`~grainfrac.physics.solver.MechanicsSolver` stepped on a GPU.

The solver keeps owning the state, loads and crack record; this wrapper copies the
model and state to the device once (:meth:`CudaMechanics.push`), advances them
there with :func:`~grainfrac.physics.cuda.stepper.run_steps_cuda`, and after each
:meth:`~CudaMechanics.cycle` brings back what the steps changed (nodes, element
stresses, contact states, energy books, new cracks, platens), so that the host's
coupling, histories and checkpoints read the solver's arrays as on the CPU. Before a
cycle the solver sends what the host changes (:meth:`~CudaMechanics.push_inputs`),
and the whole state again only after a host edit of it (a rejected fluid step's
restore, a checkpoint's load: :meth:`MechanicsSolver.note_state_edit`).
"""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import numpy as np

from grainfrac.errors import GrainfracError
from grainfrac.physics.cuda import stepper
from grainfrac.physics.records import CrackLog, NodeLoads, StepControl

if TYPE_CHECKING:
    from grainfrac.physics.solver import MechanicsSolver


# What a step changes, per record: the arrays copied back after each cycle. The
# rest of the state is input that only the host changes: the contacts' fluid
# pressures and opening offsets and the elements' expansion rates go to the device
# every cycle (a coupling sets the pressures, SCDA charging the rates), the initial
# strains (six values per element, set when a plug goes in) with the whole state
# after a host edit.
CHANGED_NODE_ARRAYS = ("u", "v", "force")
CHANGED_ELEMENT_ARRAYS = ("stress", "eigenstrain")
CHANGED_CONTACT_ARRAYS = ("bonded", "status", "sigma_n", "tau", "damage", "plastic_opening",
                          "released")
INPUT_ELEMENT_ARRAYS = ("eigenstrain_rate",)
INPUT_CONTACT_ARRAYS = ("pressure", "opening_offset")


# Environment variable choosing how the GPU sums nodal forces (see CudaMechanics).
SUMS_VARIABLE = "GRAINFRAC_CUDA_SUMS"


def ordered_sums() -> bool:
    """Whether ``$GRAINFRAC_CUDA_SUMS`` asks for ordered sums (the default) or atomics."""
    value = os.environ.get(SUMS_VARIABLE, "ordered")
    if value not in ("ordered", "atomic"):
        raise GrainfracError(f"{SUMS_VARIABLE} must be 'ordered' or 'atomic', got {value!r}")
    return value == "ordered"


class CudaMechanics:
    """Advance a :class:`MechanicsSolver`'s state on the GPU with the same semantics
    as :meth:`MechanicsSolver.cycle` (which calls it for ``backend="cuda"``).

    Parameters
    ----------
    solver
        The CPU solver whose model, loads and state are copied to the device.
    tpb
        Threads per block (a power of two).
    ordered
        Sum nodal forces and pore voids in the CPU's order (the CPU's states to the
        last bit under the simulator, reproducible runs on a GPU) or with float64
        atomics (fewer memory passes; round-off that changes from run to run). See
        :mod:`grainfrac.physics.cuda.device_kernels`. Default: ``$GRAINFRAC_CUDA_SUMS``
        (``ordered`` or ``atomic``), else ordered.
    """

    def __init__(self, solver: MechanicsSolver, *, tpb: int = stepper.DEFAULT_TPB,
                 ordered: bool | None = None):
        self.solver = solver
        self.tpb = tpb
        self.ordered = ordered_sums() if ordered is None else ordered
        # The solver's count of host edits of the state that the device holds.
        self.state_edits = 0
        m = solver.model
        self._elements = stepper.to_device(m.elements)
        self._contacts = stepper.to_device(m.contacts)
        # Made once per model; without it each cycle would rebuild it from device copies.
        self._order = (stepper.GatherOrder.of(m.n_nodes, m.elements.cells, m.contacts.nodes)
                       if self.ordered else None)
        c = m.n_contacts
        self._cracks = stepper.to_device(CrackLog(np.zeros(max(c, 1), np.int64),
                                                  np.zeros(max(c, 1), np.int64)))
        self.push()

    def push(self) -> None:
        """Copy the solver's whole state and its loads to the device."""
        s, m = self.solver, self.solver.model
        ld = s.loads
        self._nodes = stepper.to_device(s.node_state())
        self._element_state = stepper.to_device(s.element_state())
        self._contact_state = stepper.to_device(s.contact_state())
        self._loads = stepper.to_device(NodeLoads(m.mass, ld.external, ld.fixed,
                                                  ld.prescribed_velocity))
        self._platens = stepper.to_device(s._platen_set())
        self._energies = stepper.device_energies(s.energies)
        self._expanding = bool(s.eigenstrain_rate.any())

    def push_inputs(self) -> None:
        """Copy what the host changes between cycles: loads, platens, energy books and
        the input arrays of the element and contact states."""
        s, m = self.solver, self.solver.model
        ld = s.loads
        stepper.copy_fields(NodeLoads(m.mass, ld.external, ld.fixed, ld.prescribed_velocity),
                            self._loads, ("external", "fixed", "prescribed_velocity"))
        # Expansion rates are zero outside SCDA charging: then neither they nor the
        # eigenstrains they drive cross the bus (2 x 48 MB a cycle on 1e6 tetrahedra).
        expanding = bool(s.eigenstrain_rate.any())
        if expanding or self._expanding:
            stepper.copy_fields(s.element_state(), self._element_state, INPUT_ELEMENT_ARRAYS)
        self._expanding = expanding
        stepper.copy_fields(s.contact_state(), self._contact_state, INPUT_CONTACT_ARRAYS)
        self._platens = stepper.to_device(s._platen_set())
        self._energies = stepper.device_energies(s.energies)

    def pull(self) -> None:
        """Copy what a step changes from the device into the solver's arrays."""
        s = self.solver
        stepper.copy_fields(self._nodes, s.node_state(), CHANGED_NODE_ARRAYS)
        changed = CHANGED_ELEMENT_ARRAYS if self._expanding else ("stress",)
        stepper.copy_fields(self._element_state, s.element_state(), changed)
        stepper.copy_fields(self._contact_state, s.contact_state(), CHANGED_CONTACT_ARRAYS)
        stepper.add_energies(s.energies, self._energies)

    def advance(self, n_steps: int, *, timings: dict[str, float] | None = None
                ) -> tuple[int, int]:
        """Advance ``n_steps`` on the device only; return (new cracks, steps done).

        ``timings``, if given, gets the wall time of each stage (see
        :func:`~grainfrac.physics.cuda.stepper.run_steps_cuda`; slower).
        """
        s, m = self.solver, self.solver.model
        pores = s.pore_springs.record()
        on_device = stepper.to_device(pores)
        done = stepper.run_steps_cuda(
            StepControl(int(n_steps), m.dt, s.damping, bool(s.allow_failure),
                        float(s.velocity_limit), 1),
            self._nodes, self._loads, self._elements, self._element_state, self._contacts,
            self._contact_state, self._platens, on_device, self._energies,
            self._cracks, tpb=self.tpb, sync_every=max(int(n_steps), 1), timings=timings,
            ordered=self.ordered, order=self._order,
        )
        on_device.dissipated.copy_to_host(pores.dissipated)  # the pores' books, in place
        return done

    def cycle(self, n_steps: int, *, timings: dict[str, float] | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """:meth:`advance`, then bring the changed state back into the solver.

        Returns what :meth:`MechanicsSolver._book_cycle` records: the new cracks'
        contacts and steps (in the CPU backend's order), the platens' positions and
        reactions, and the steps done. ``timings`` as for :meth:`advance`, with the
        copy back under "to host".
        """
        n_new, done = self.advance(n_steps, timings=timings)
        start = time.perf_counter()
        self.pull()
        contact, step = stepper.fetch_cracks(self._cracks, n_new)
        positions = self._platens.position.copy_to_host()
        reactions = self._platens.reaction.copy_to_host()
        if timings is not None:
            timings["to host"] = timings.get("to host", 0.0) + time.perf_counter() - start
        return contact, step, positions, reactions, done
