"""``CudaMechanics``: a :class:`~grainfrac.physics.solver.MechanicsSolver` stepped on a GPU.

The solver keeps owning the state, loads and crack record; this wrapper copies the
model and state to the device once (:meth:`CudaMechanics.push`), advances them
there with :func:`~grainfrac.physics.cuda.stepper.run_steps_cuda`, and after each
:meth:`~CudaMechanics.cycle` brings back only what is small: the energy books,
the new cracks, the platens' positions and reactions. The full state comes back
on demand (:meth:`~CudaMechanics.pull`), e.g. before a checkpoint, a snapshot or
an energy balance.
"""

from __future__ import annotations

import numpy as np

from grainfrac.physics.cuda import stepper
from grainfrac.physics.records import CrackLog, NodeLoads, StepControl
from grainfrac.physics.solver import MechanicsSolver, NumericalBlowUp


class CudaMechanics:
    """Advance a :class:`MechanicsSolver`'s state on the GPU with the same semantics
    as :meth:`MechanicsSolver.cycle`.

    Parameters
    ----------
    solver
        The CPU solver whose model, loads and state are copied to the device.
    tpb
        Threads per block (a power of two).
    """

    def __init__(self, solver: MechanicsSolver, *, tpb: int = stepper.DEFAULT_TPB):
        self.solver = solver
        self.tpb = tpb
        m = solver.model
        self._elements = stepper.to_device(m.elements)
        self._contacts = stepper.to_device(m.contacts)
        c = m.n_contacts
        self._cracks = stepper.to_device(CrackLog(np.zeros(max(c, 1), np.int64),
                                                  np.zeros(max(c, 1), np.int64)))
        self.push()

    def push(self) -> None:
        """Copy the solver's state and loads to the device (after host-side edits)."""
        s, m = self.solver, self.solver.model
        self._nodes = stepper.to_device(s.node_state())
        self._element_state = stepper.to_device(s.element_state())
        self._contact_state = stepper.to_device(s.contact_state())
        ld = s.loads
        self._loads = stepper.to_device(NodeLoads(m.mass, ld.external, ld.fixed,
                                                  ld.prescribed_velocity))
        self._platens = stepper.to_device(s._platen_set())
        self._energies = stepper.device_energies(s.energies)

    def pull(self) -> None:
        """Copy the device state into the solver's arrays (on demand, not per cycle)."""
        s = self.solver
        stepper.copy_to_host(self._nodes, s.node_state())
        stepper.copy_to_host(self._element_state, s.element_state())
        stepper.copy_to_host(self._contact_state, s.contact_state())

    def _pores_device(self):
        """The solver's pore springs on the device (set per cycle by a coupling)."""
        return stepper.to_device(self.solver.pore_springs.record())

    def cycle(self, n_steps: int, *, timings: dict[str, float] | None = None) -> None:
        """Advance ``n_steps`` on the device; record new cracks; check for blow-up.

        ``timings``, if given, gets the wall time of each stage (see
        :func:`~grainfrac.physics.cuda.stepper.run_steps_cuda`; slower).
        """
        s, m = self.solver, self.solver.model
        n_new, done = stepper.run_steps_cuda(
            StepControl(int(n_steps), m.dt, s.damping, bool(s.allow_failure),
                        float(s.velocity_limit), False),
            self._nodes, self._loads, self._elements, self._element_state, self._contacts,
            self._contact_state, self._platens, self._pores_device(), self._energies,
            self._cracks, tpb=self.tpb, sync_every=max(int(n_steps), 1), timings=timings,
        )
        stepper.add_energies(s.energies, self._energies)
        positions = self._platens.position.copy_to_host()
        reactions = self._platens.reaction.copy_to_host()
        for platen, pos, reac in zip(s.loads.platens, positions, reactions, strict=True):
            platen.position = float(pos)
            platen.reaction = float(-reac)
        contact, step = stepper.fetch_cracks(self._cracks, n_new)
        if n_new:
            status = self._contact_state.status.copy_to_host()
            released = self._contact_state.released.copy_to_host()
            for c, k in zip(contact, step, strict=True):
                s.cracks.contact.append(int(c))
                s.cracks.time.append(s.time + (int(k) + 1) * m.dt)
                s.cracks.mode.append(int(status[c]))
                s.cracks.energy.append(float(released[c]))
        s.time += done * m.dt
        s.step_count += done
        if done < n_steps:
            self.pull()
            v = s.v
            vmax = float(np.nanmax(np.abs(v))) if np.isfinite(v).any() else np.inf
            raise NumericalBlowUp(
                f"velocities ran away at step {s.step_count} (t = {s.time:.6g} s): "
                f"max |v| = {vmax:.3g} m/s > {s.velocity_limit:g} m/s"
            )
