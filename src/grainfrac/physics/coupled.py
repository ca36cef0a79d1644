"""Staggered, fully coupled hydro-mechanics.

Each fluid step: apertures from the current contact openings -> implicit
pressure solve over ``dt`` -> pressures applied to both faces of every
sub-contact and to the borehole wall -> the mechanics advances over the same
``dt`` (as many explicit steps as it takes); optionally again, until the pressures
fit the voids the mechanics realised (``fixed_stress_iterations``). The fluid's own
stability limit never restricts ``dt``; accuracy does, so ``dt`` is a parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from grainfrac.assembly import GrainAssembly
from grainfrac.loading.boundary import normal_pressure_forces
from grainfrac.physics import flow
from grainfrac.physics.coupling_kernels import on_loose_grain
from grainfrac.physics.kinematics import contact_opening
from grainfrac.physics.solver import (
    MechanicsSolver,
    NumericalBlowUp,
    PoreSprings,
)

# Open-crack compliance A L / E' times this factor (Sneddon's mean opening of a
# pressurised plane-strain crack is (pi/2) p L / E', see penny_crack_length).
# Measured on the default hybrid run and a small HS run at a 0.1 ms step: 1.5 let
# fluid pile up and spike the well pressure by 3 MPa when a crack closed; 0.5
# started to oscillate (1.7 MPa jumps); 1.0 is smooth in both.
CRACK_COMPLIANCE_FACTOR = 1.0
# An open sub-contact is at least as soft to a pressure rise of its own node as a
# crack this many zones long (HydroMechanicalSolver.crack_compliance).
CRACK_LOCAL_ZONES = 1.0
# A drained pore's spring (HydroMechanicalSolver._pore_springs) is at least this much
# softer than its contact springs. At 1 (as stiff as them, like an undrained pore's)
# a bonded contact at the edge of its fluid chattered: HS 18 ml/min, Case 2, seed 7,
# +-60 nm per mechanical step before breakdown, its pressure switching between 4.68
# and 0 MPa, and 44 % of the pumped energy lost from the books; at 10 the books close
# (-1.4 %). The softer the spring, the more work it does on the grains past the
# pore's fluid (lab HS, 5 ml/min, seed 0: 1 / 3 / 10 / 30 give books -4.5 / -5.8 /
# -8.6 / -31.8 %, breakdown 6.455 MPa in all).
DRAINED_PORE_SOFTENING = 10.0
# A drained pore's flow resistance (HydroMechanicalSolver._pore_springs) is at most this
# fraction of what would stop its faces' relative motion within one mechanical step
# (resistance x sum A^2 (1/m_a + 1/m_b) x dt): the explicit step stays stable (below 2)
# and the motion is still damped within a few steps. Measured on the penny (2 mm zones,
# seed 0, filled disc): 0 / 0.5 give books -15.6 / -11.7 % of the pumped energy at 4 ms;
# the 2D demo's breakdowns moved by 0.01 MPa.
PORE_DAMPING_LIMIT = 0.5
# An iterated fluid step (HydroMechanicalSolver fixed_stress_iterations) has converged
# when solving again from the voids its mechanics realised moves no free node's pressure
# by more than the tolerance or this fraction of the step's own change there.
FIXED_STRESS_FRACTION = 0.05
# Cracks of more fluid nodes than this keep their shared opening mode as a factor
# (flow.SharedCompliance) rather than as a dense block in the pressure matrix: a
# direct factorisation fills such a block at ~N^3 / 3 operations (3 ms at 200 nodes,
# seconds at a few thousand: the 100 mm cube after SCDA charging).
LOW_RANK_MIN_NODES = 200
# Step control (see HydroMechanicalSolver.advance).
MAX_HALVINGS = 5
PRESSURE_JUMP_FRACTION = 0.10
PRESSURE_JUMP_FLOOR = 1.0e6
# A half step whose worst jump is still above this fraction of its parent's is
# accepted. Measured (HS 18 ml/min, Case 1, seed 1): after breakdown a crack-tip
# node flipped between 2 and 6 MPa at every step size down to dt / 32, so each
# step ran all 5 halvings (12381 rejections for 1560 steps, 10x the wall time).
# A jump that time resolution can fix shrinks about in proportion to the step.
UNRESOLVED_JUMP = 0.8


class _OpenCracks(NamedTuple):
    """HydroMechanicalSolver._open_cracks: per sub-contact."""

    is_open: np.ndarray
    length: np.ndarray
    label: np.ndarray


class _Pores(NamedTuple):
    """The pores of one mechanical state, as the fluid solve and the step check see them."""

    aperture: np.ndarray  # conducting (HydroMechanicalSolver.aperture)
    void_aperture: np.ndarray  # holding fluid (HydroMechanicalSolver.void_aperture)
    compliance: np.ndarray  # HydroMechanicalSolver.pore_compliance
    local_compliance: np.ndarray  # HydroMechanicalSolver.crack_compliance
    shared_compliance: flow.SharedCompliance | None
    well_void: float | None


@dataclass
class CoupledHistory:
    """One row per fluid step."""

    time: list[float] = field(default_factory=list)
    well_pressure: list[float] = field(default_factory=list)
    injected_volume: list[float] = field(default_factory=list)
    n_cracks: list[int] = field(default_factory=list)


class HydroMechanicalSolver:
    """Couple a :class:`MechanicsSolver` with the grain-boundary flow network.

    Parameters
    ----------
    assembly
        The assembly both solvers were built from.
    mechanics
        Mechanics solver (its current ``loads.external`` is kept as the base load).
    network
        Flow network (permeable sides, well) with every pipe; the pipes of intact
        sealed faces are left out while they stay bonded (:func:`flow.conducting`).
    fluid
        Fluid and aperture parameters.
    fixed_stress_iterations
        How many times a fluid step may be redone (0: the plain staggered step). After
        the mechanics, the pressures are solved again from the voids it realised in
        place of those the solve's compliance anticipated; while they move by more
        than ``fixed_stress_tolerance`` (Pa) or ``FIXED_STRESS_FRACTION`` of the step's
        change, the mechanics is run again at them (the iterated fixed-stress split of
        Kim, Tchelepi and Juanes 2011). Why: a sudden start (the penny's injection into
        a closed disc) books fluid at one step's pressure as an opening that inertia
        delays into the next steps at three times that pressure, and the plain step
        makes that energy. Measured on the penny (2 mm zones, seed 0): books -4.2 %
        -> -0.1 % of the pumped energy, at about twice the wall time.
    fixed_stress_tolerance
        See ``fixed_stress_iterations``.
    """

    def __init__(self, assembly: GrainAssembly, mechanics: MechanicsSolver,
                 network: flow.FlowNetwork, fluid: flow.FluidProperties, *,
                 fixed_stress_iterations: int = 0, fixed_stress_tolerance: float = 2.0e3):
        self.assembly = assembly
        self.fixed_stress_iterations = int(fixed_stress_iterations)
        self.fixed_stress_tolerance = float(fixed_stress_tolerance)
        self.mechanics = mechanics
        # Every pipe, sealed grain interiors included; self.network conducts.
        self._all_pipes = network
        self.fluid = fluid
        # Per sub-contact a0 of the void (fluid.closure_storage), else None: the fluid's.
        self._void_a0: np.ndarray | None = None
        self._set_closure_reference()
        self.network = self._conducting_network()
        self.base_external = mechanics.loads.external.copy()
        self._wall_loop = (flow.borehole_wall_loop(assembly.mesh)
                           if network.wall_pressurised else None)
        self.well_unit_forces = (
            normal_pressure_forces(assembly.mesh, "borehole", 1.0)
            if network.wall_pressurised else None
        )
        self.state = flow.initial_state(network, self.void_aperture(), fluid,
                                        well_volume=self.well_void())
        # The fluid's work on the grains before this state's books began (saturate).
        self._fluid_work_before = 0.0
        # Plane-strain modulus of the softest grain: a crack opens against it.
        m = mechanics.model
        nu = m.lam / (2.0 * (m.lam + m.mu))
        youngs = m.mu * 2.0 * (1.0 + nu)
        self.crack_modulus = float(np.min(youngs / (1.0 - nu**2)))
        mesh = assembly.mesh
        # Opening compliance of the borehole (m3/Pa): a pressurised hole of radius a in
        # an elastic plane widens by p a / (2 G) (Lame; the same in plane stress, so
        # also for a 3D slab's hole), so its void grows by pi a^2 l / G per Pa over
        # its length l; G is the grains' volume-weighted shear modulus.
        shear_modulus = float(np.average(m.mu, weights=m.element_area))
        self.wall_compliance = (math.pi * mesh.borehole_radius**2
                                * mesh.borehole_length / shear_modulus
                                if network.wall_pressurised else 0.0)
        self._wall_nodes = np.zeros(len(mesh.fluid_node_x), dtype=bool)
        self._wall_nodes[mesh.fluid_node_sets.get("borehole", np.zeros(0, np.int64))] = True
        self._well_diameter = 2.0 * mesh.borehole_radius
        self._contact_grains = mesh.interface_grains[mesh.contact_interface]
        self._n_grains = int(self._contact_grains.max()) + 1
        self.history = CoupledHistory()
        self.rejected_steps = 0
        # The mechanical state saved before the last fluid step, reused by the next one.
        self._spare_save: dict | None = None
        # The pores at the end of the last checked step, keyed by the mechanics' step
        # count: the next step starts from the same mechanical state.
        self._pores: tuple[int, _Pores] | None = None
        self._pore_layout_cache: tuple | None = None
        self._apply_pressure()

    def saturate(self, pressure: float | np.ndarray) -> None:
        """Fill every pore with fluid at ``pressure`` (Pa, scalar or per unknown) at the
        current apertures and apply it to the grains: a fresh fluid state, its books at
        zero. With ``fluid.closure_storage`` the voids follow the faces from here."""
        self._set_closure_reference()
        self.state = flow.initial_state(self.network, self.void_aperture(), self.fluid, pressure,
                                        well_volume=self.well_void())
        self._pores = None
        self._apply_pressure()
        self._fluid_work_before = float(self.mechanics.energies["fluid_work"][0])

    def _conducting_network(self, aperture: np.ndarray | None = None) -> flow.FlowNetwork:
        """The network less the pipes of grain-interior faces still bonded, with the
        mouths of a sealed wall that have opened (they stay open). ``aperture``: the
        current pore apertures, if the caller has them."""
        bonded = self.mechanics.bonded[:self.assembly.mesh.n_contacts]
        if self._all_pipes.mouths is not None:
            aperture = self.aperture() if aperture is None else aperture
            self._all_pipes = flow.open_mouths(self._all_pipes, aperture, bonded, self.fluid)
        return flow.conducting(self._all_pipes, bonded)

    @property
    def mouths_open(self) -> np.ndarray | None:
        """Which of a sealed wall's mouths have opened to the well (None: not sealed)."""
        mouths = self._all_pipes.mouths
        return None if mouths is None else mouths.is_open.copy()

    @mouths_open.setter
    def mouths_open(self, is_open: np.ndarray) -> None:
        mouths = self._all_pipes.mouths
        self._all_pipes = replace(self._all_pipes,
                                  mouths=replace(mouths, is_open=np.asarray(is_open, bool)))
        self.network = self._conducting_network()
        self._pores = None

    def aperture(self) -> np.ndarray:
        """Per sub-contact, the aperture that conducts (m, :func:`flow.pore_aperture`)."""
        return self._apertures()[0]

    def void_aperture(self) -> np.ndarray:
        """Per sub-contact, the width of the void that holds fluid (m): the aperture,
        or with ``fluid.closure_storage`` one that follows the faces through their
        closure from the reference state (:meth:`saturate`, or construction)."""
        return self._apertures()[1]

    def _apertures(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`aperture` and :meth:`void_aperture`, from one reading of the openings."""
        n = self.assembly.mesh.n_contacts
        opening = contact_opening(self.assembly, self.mechanics.u)
        bonded = self.mechanics.bonded[:n]
        aperture = flow.pore_aperture(opening, self.fluid, bonded)
        if self._void_a0 is None:
            return aperture, aperture
        return aperture, flow.pore_aperture(opening, self.fluid, bonded, self._void_a0)

    @property
    def void_initial_aperture(self) -> np.ndarray | None:
        """Per sub-contact a0 of the void under ``fluid.closure_storage`` (m; None
        without it): what a checkpoint keeps of the reference state."""
        return None if self._void_a0 is None else self._void_a0.copy()

    @void_initial_aperture.setter
    def void_initial_aperture(self, a0: np.ndarray) -> None:
        self._void_a0 = np.array(a0, dtype=float)
        self._pores = None

    def _set_closure_reference(self) -> None:
        """With ``fluid.closure_storage``: each void's a0 from the faces' current opening.

        Why: the aperture law holds a pressed contact at its smallest aperture while its
        faces close by up to its load over kn, so the fluid pressure that lifts them does
        work p dV on the grains for a void that holds no more fluid. The penny (1 MPa
        confinement, 2 mm zones: 5 um of closure) made energy in proportion to the
        confinement that way (:func:`flow.closure_initial_aperture`)."""
        if not self.fluid.closure_storage:
            return
        opening = contact_opening(self.assembly, self.mechanics.u)
        self._void_a0 = flow.closure_initial_aperture(opening, self.fluid)

    def well_void(self) -> float | None:
        """Void volume (m3) of the borehole with its wall where the mechanics has moved it
        (None without a well). The fluid fills it, so a wall pushed out by the well
        pressure takes fluid that the pump must supply."""
        if not self.network.wall_pressurised:
            return None if self.network.well_unknown < 0 else 0.0
        return flow.borehole_volume(self.assembly.mesh, self.mechanics.u, self._wall_loop)

    @property
    def well_pressure(self) -> float:
        w = self.network.well_unknown
        return float(self.state.pressure[w]) if w >= 0 else 0.0

    def _apply_pressure(self) -> None:
        self.mechanics.contact_pressure[:] = self.state.pressure[self.network.contact_unknown]
        # In place, without node-sized temporaries; p f + base is base + p f to the bit.
        external = self.mechanics.loads.external
        if self.well_unit_forces is None:
            external[...] = self.base_external
        else:
            np.multiply(self.well_pressure, self.well_unit_forces, out=external)
            external += self.base_external

    def pore_compliance(self, cracks: _OpenCracks | None = None) -> np.ndarray:
        """Opening compliance at fixed total stress per unknown (m3/Pa): sum of A dw/dp.

        A bonded sub-contact, or a broken one held shut by more effective
        compression than a step may add in pressure (:func:`pressure_jump_limit`),
        opens by dp / kn. An open crack, or a broken contact that the next
        pressure rise will open (at a crack tip), opens against the grains: a
        pressurised crack of length L in plane strain opens by
        (pi/2) dp L / E' on average (Sneddon), so its sub-contacts get
        ``CRACK_COMPLIANCE_FACTOR`` A L / E' (in 3D L is :func:`penny_crack_length`
        of the crack's size). L is measured: open sub-contacts
        joined by pipes form a crack, whose length is the sum of its pipes, plus
        the well diameter if it reaches the wall. Understating the compliance
        makes the staggered coupling unstable (a crack tip treated as a spring
        blew the default hybrid run up); overstating it makes pressure lag and
        spike (both measured), hence the measured length.

        This lumps the crack's uniform opening mode onto each node, as if every
        node were as soft to a pressure rise of its own as the whole crack is to
        a uniform one. The step control uses it as the undrained response of one
        pore; the pressure solve uses :meth:`crack_compliance`, which keeps the
        mode whole.

        A grain with no bonded boundary left is not the flank of a crack: pressure
        moves it bodily against its contacts, so the sub-contacts around it keep
        A / kn. With the crack compliance, fluid squeezed by such a grain showed
        as a tiny pressure (measured: 4x the void's volume of fluid in a gap at
        0.4 MPa), the grain kept closing the gap, and when the gap shut the
        pressure there leapt to 150 MPa (hybrid, 15 % fissures, seed 0, the
        lab-calibrated 2D rock).
        """
        m = self.mechanics
        is_open, length, _ = cracks or self._open_cracks()
        compliance = m.model.contact_area / m.model.normal_stiffness
        crack = CRACK_COMPLIANCE_FACTOR * m.model.contact_area * length / self.crack_modulus
        compliance = np.where(is_open, np.maximum(compliance, crack), compliance)
        return self._per_unknown(compliance)

    def crack_compliance(self, cracks: _OpenCracks | None = None
                         ) -> tuple[np.ndarray, sp.csr_matrix | None]:
        """Opening compliance of the pores for the pressure solve (m3/Pa).

        Returns
        -------
        local : ndarray
            Per unknown: the opening under a pressure rise at that node alone. A
            closed sub-contact is a spring, A / kn; an open one opens at least as
            a crack ``CRACK_LOCAL_ZONES`` zones long, ``CRACK_COMPLIANCE_FACTOR``
            A (zone length) / E'. The borehole adds its Lame compliance.
        shared : flow.SharedCompliance or None
            The uniform opening mode of each open crack k, kappa_k a a^T with
            a_i the open area of crack k at node i, A_k = sum a_i and
            kappa_k = ``CRACK_COMPLIANCE_FACTOR`` L_k / (E' A_k): a uniform rise dp
            opens node i by a_i L_k dp / E', the Sneddon opening of
            :meth:`pore_compliance`, but a rise at one node alone opens the whole
            crack, not that node only. ``None`` when nothing is open.

        With the mode lumped per node (:meth:`pore_compliance`), a segment that the
        grains squeeze books its surplus fluid as coming opening instead of
        pushing it along the crack. Measured on the lab-calibrated 2D rock: the
        hybrid run of seed 1 made 29 % of the pumped energy, and the fissured
        hybrid run of seed 3 80 %; with the shared mode they close at +0.54 % and
        +0.69 % (12 ms of injection). With only the contact spring as the local
        term, seed 3 ran away (-328 %).
        """
        m = self.mechanics
        area = m.model.contact_area
        is_open, length, crack = cracks or self._open_cracks()
        spring = area / m.model.normal_stiffness
        mesh = self.assembly.mesh
        zone = CRACK_LOCAL_ZONES * mesh.zone_size
        if mesh.dimension == 3:
            zone = penny_crack_length(zone)
        zone_crack = CRACK_COMPLIANCE_FACTOR * area * zone / self.crack_modulus
        local = self._per_unknown(np.where(is_open, np.maximum(spring, zone_crack), spring))
        if not is_open.any():
            return local, None
        n = self.network.n_unknowns
        idx = np.flatnonzero(is_open)
        # Open area per (crack, node), grouped by crack.
        keys, inv = np.unique(crack[idx] * n + self.network.contact_unknown[idx],
                              return_inverse=True)
        node_area = np.bincount(inv, weights=area[idx])
        crack_of, node = np.divmod(keys, n)
        _, group, size = np.unique(crack_of, return_inverse=True, return_counts=True)
        crack_area = np.bincount(group, weights=node_area)
        crack_length = np.zeros(len(size))
        crack_length[group[inv]] = length[idx]
        kappa = CRACK_COMPLIANCE_FACTOR * crack_length / (self.crack_modulus * crack_area)
        # Small cracks as explicit blocks: every pair (i, j) of entries in the same crack.
        large = size > LOW_RANK_MIN_NODES
        small_entry = ~large[group]
        pairs = np.where(large, 0, size)[group]
        first = np.cumsum(size) - size
        row = np.repeat(np.arange(len(keys)), pairs)
        col = first[group[row]] + np.arange(len(row)) - np.repeat(np.cumsum(pairs) - pairs, pairs)
        near = sp.coo_matrix((kappa[group[row]] * node_area[row] * node_area[col],
                              (node[row], node[col])), shape=(n, n)).tocsr()
        # Large cracks as factors: their open area per node, one column each.
        column = np.cumsum(large) - 1
        entry = ~small_entry
        modes = sp.csc_matrix((node_area[entry], (node[entry], column[group[entry]])),
                              shape=(n, int(large.sum())))
        return local, flow.SharedCompliance(near, modes, kappa[large])

    def _per_unknown(self, contact_compliance: np.ndarray) -> np.ndarray:
        """Sum sub-contact compliances onto the fluid unknowns; the well adds its wall's."""
        total = np.bincount(self.network.contact_unknown, weights=contact_compliance,
                            minlength=self.network.n_unknowns)
        if self.network.well_unknown >= 0:
            total[self.network.well_unknown] += self.wall_compliance
        return total

    def hydraulic_energy(self) -> dict[str, float]:
        """The fluid's energy books (J) since injection started.

        ``pumped``: the pump's work on the well; ``on_grains``: the fluid's work on
        the grains (pressure on grain-boundary faces and on the borehole wall);
        ``viscous``: dissipated by flow; ``stored``: the fluid's compression energy
        now; ``outflow``: carried out through the permeable sides; ``residual``:
        pumped minus the other four. A faithful coupling closes the books up to its
        time discretisation; a negative residual is energy made by the staggered
        scheme. Measured at the 0.01 ms fluid step: default HS-only run (seed 0,
        12 ms) -0.84 % of the pumped energy; lab HS, 5 ml/min, seed 0, -8.6 % (-5.0 %
        at a quarter of the step); 140 Table 2 study runs -8.6 to +0.3 %.
        """
        s = self.state
        books = {
            "pumped": float(s.pump_work),
            "on_grains": float(self.mechanics.energies["fluid_work"][0])
            - self._fluid_work_before + s.wall_work,
            "viscous": s.viscous_work,
            "stored": flow.compression_energy(self.network, s, self.fluid),
            "outflow": s.outflow_work,
        }
        books["residual"] = books["pumped"] - sum(
            books[k] for k in ("on_grains", "viscous", "stored", "outflow"))
        return books

    def _on_loose_grain(self, bonded: np.ndarray) -> np.ndarray:
        """Sub-contacts on the boundary of a grain that has no bonded boundary left."""
        return on_loose_grain(self._contact_grains, np.asarray(bonded, dtype=bool),
                              self._n_grains)

    def _open_cracks(self) -> _OpenCracks:
        """The sub-contacts that open against the grains under the next pressure rise
        (broken, not held shut by more than a step's pressure change, not around a
        loose grain), the length (m) of the open crack each belongs to (0 where
        closed), and each one's crack label (open sub-contacts joined by open pipes)."""
        from scipy.sparse.csgraph import connected_components

        m = self.mechanics
        is_open = ~m.bonded & (m.sigma_n < pressure_jump_limit(m.contact_pressure))
        is_open &= ~self._on_loose_grain(m.bonded)
        mesh = self.assembly.mesh
        n = len(mesh.fluid_node_x)
        open_pipe = is_open[mesh.pipe_contacts[:, 0]] & is_open[mesh.pipe_contacts[:, 1]]
        ends = mesh.pipe_nodes[open_pipe]
        graph = sp.coo_matrix((np.ones(len(ends)), (ends[:, 0], ends[:, 1])), shape=(n, n))
        _, label = connected_components(graph, directed=False)
        contact_label = label[mesh.contact_fluid_node]
        touches = np.zeros(label.max() + 1, dtype=bool)
        touches[label[self._wall_nodes]] = True
        if mesh.dimension == 3:
            # A crack is a surface: its size is that of the disc of its open area.
            area = np.bincount(contact_label[is_open], weights=m.model.contact_area[is_open],
                               minlength=label.max() + 1)
            diameter = 2.0 * np.sqrt(area / math.pi) + np.where(touches, self._well_diameter,
                                                                 0.0)
            crack_length = penny_crack_length(np.maximum(diameter, mesh.zone_size))
        else:
            length = np.bincount(label[ends[:, 0]], weights=mesh.pipe_length[open_pipe],
                                 minlength=label.max() + 1)
            crack_length = length + np.where(touches, self._well_diameter, 0.0)
            crack_length = np.maximum(crack_length, mesh.zone_size)
        return _OpenCracks(is_open, np.where(is_open, crack_length[contact_label], 0.0),
                           contact_label)

    def advance(self, dt: float, injection_rate: float = 0.0, *,
                crack_free_above: float = math.inf) -> None:
        """One coupled step of ``dt`` seconds with ``injection_rate`` (m3/s) into the well.

        ``dt`` is rounded up to a whole number of mechanical steps (at least one):
        the fluid step is the time the mechanics advances, and the well receives
        ``injection_rate`` times it.

        Step control: a step that changes any fluid node's pressure by more than
        :func:`pressure_jump_limit`, leaves a node with negative fluid content, or
        whose mechanics runs away, is undone and done again as two half steps
        (down to ``dt / 2**MAX_HALVINGS``; at that depth a jump is accepted and a
        runaway is reported). A half step whose worst jump is not below
        ``UNRESOLVED_JUMP`` of its parent's is accepted (halving cannot fix it), unless
        the jump is in the well, whose pressure is the result. A step longer than
        ``crack_free_above`` (s) in which a contact breaks is halved too, so that a
        grown fluid step (:func:`grainfrac.stages.inject.next_time_step`) never holds
        the pressures over a crack's onset for longer than that.
        Measured on the default hybrid run (seed 0, 0.01 ms): a crack-tip node
        reached 135 MPa with 10.4 MPa in the well before the mechanics blew up;
        with the compliance rule of
        :meth:`pore_compliance` 71 of 2000 steps were halved and none ran away.
        """
        self._advance_controlled(dt, injection_rate, 0, crack_free_above=crack_free_above)
        h = self.history
        h.time.append(self.mechanics.time)
        h.well_pressure.append(self.well_pressure)
        h.injected_volume.append(self.state.injected)
        h.n_cracks.append(len(self.mechanics.cracks.contact))

    def _advance_controlled(self, dt: float, injection_rate: float, depth: int,
                            parent_jump: float = math.inf, *,
                            crack_free_above: float = math.inf) -> None:
        # The top level's save is written over by the next step's (recursion below
        # it makes saves of its own while this one is still needed). Without the
        # stresses: a restore here is always followed by a cycle, which writes them.
        mech_saved = self.mechanics.save_state(self._spare_save if depth == 0 else None,
                                               with_stress=False)
        if depth == 0:
            self._spare_save = mech_saved
        n_cracks = len(self.mechanics.cracks.contact)
        fluid_saved = _copy_state(self.state)
        jump = math.inf
        try:
            self._step(dt, injection_rate, fluid_saved, mech_saved)
            jump, well_jump, content_ok = self._step_check(fluid_saved.pressure)
            # A jump that halving the step hardly shrinks is not a matter of time
            # resolution (a crack-tip node opening and closing): accept it, but
            # not in the well, whose pressure is the result.
            accepted = content_ok and well_jump <= 1.0 and (
                jump <= 1.0 or jump > UNRESOLVED_JUMP * parent_jump) and not (
                dt > crack_free_above * (1 + 1e-9)
                and len(self.mechanics.cracks.contact) > n_cracks)
        except NumericalBlowUp:
            if depth >= MAX_HALVINGS:
                raise
            accepted = False
        steps = whole_steps(dt, self.mechanics.model.dt)
        # One mechanical step cannot be halved: done again it would be the same step.
        if accepted or depth >= MAX_HALVINGS or steps == 1:
            return
        self.mechanics.restore_state(mech_saved)
        self._pores = None
        self.state = fluid_saved
        self._apply_pressure()
        self.rejected_steps += 1
        # The halves together advance the step's own whole mechanical steps: each half
        # rounded up on its own overshot the stage's end by a step per halving (3
        # steps measured where a run's last step was halved twice).
        start = self.mechanics.step_count
        self._advance_controlled(0.5 * dt, injection_rate, depth + 1, jump,
                                 crack_free_above=crack_free_above)
        left = steps - (self.mechanics.step_count - start)
        if left > 0:
            self._advance_controlled(left * self.mechanics.model.dt, injection_rate,
                                     depth + 1, jump, crack_free_above=crack_free_above)

    def _step_check(self, before: np.ndarray) -> tuple[float, float, bool]:
        """The largest pressure change of the step just taken over its
        :func:`pressure_jump_limit` (<= 1 is acceptable), the same in the well,
        and whether every free fluid node kept a non-negative content.

        The change counts the pressure the fluid would need to fit the voids the
        mechanics left at the end of the step (:func:`flow.undrained_pressure`),
        not only the pressure the fluid solve gave at its start: the mechanics
        runs at that pressure, and a grain that closes a gap with fluid in it
        overshoots otherwise. Measured (hybrid, 15 % fissures, seed 0, the
        lab-calibrated 2D rock): a loose grain closed a half-filled gap from 3 to
        0.2 um within one 0.01 ms step, the next fluid solve put 139 MPa there,
        halving that next step could not shrink it, and the run blew up.
        """
        free = ~self.network.fixed
        pores = self._current_pores()
        undrained = flow.undrained_pressure(self.network, self.state, pores.void_aperture,
                                            self.fluid, pores.compliance, pores.well_void)
        after = np.maximum(self.state.pressure, undrained)
        ratio = np.abs(after - before) / pressure_jump_limit(
            np.maximum(np.abs(before), self.well_pressure))
        well = self.network.well_unknown
        well_ratio = float(ratio[well]) if well >= 0 else 0.0
        worst = float(np.max(ratio[free])) if free.any() else 0.0
        content_ok = bool(np.all(self.state.content[free] >= -1e-6 * self.state.volume[free]))
        return worst, well_ratio, content_ok

    def _current_pores(self) -> _Pores:
        """Apertures, compliances and borehole void of the current mechanical state."""
        count = self.mechanics.step_count
        if self._pores is None or self._pores[0] != count:
            aperture, void = self._apertures()
            self.network = self._conducting_network(aperture)
            cracks = self._open_cracks()
            local, shared = self.crack_compliance(cracks)
            self._pores = (count, _Pores(aperture, void, self.pore_compliance(cracks), local,
                                         shared, self.well_void()))
        return self._pores[1]

    def _step(self, dt: float, injection_rate: float, start: flow.FluidState,
              mech_start: dict) -> None:
        """One fluid step: the pressure solve, then the mechanics at those pressures; with
        ``fixed_stress_iterations``, again from ``mech_start`` while the pressures solved
        from the voids the mechanics realised move by more than :meth:`_split_converged`
        allows. ``start`` and ``mech_start`` are the caller's copies of the fluid and
        mechanical states the step begins from (only read here)."""
        m = self.mechanics
        # The mechanics can only advance whole steps of its own: the fluid step is
        # the time it does advance, so the well gets rate x the simulated time.
        # Injecting for ``dt`` itself fell short: a fluid step below the mechanical
        # one still advanced a whole mechanical step, and the default 0.01 ms is
        # 71.7 steps of the default slab (1.394e-7 s each), run as 72 (issue 42).
        n_steps = whole_steps(dt, m.model.dt)
        dt = n_steps * m.model.dt
        pores = self._current_pores()
        pipe_links = flow.links(self.network, pores.aperture, self.fluid)
        self._solve(self.state, pores, dt, injection_rate, pores.void_aperture,
                    pores.well_void, pipe_links)
        # implicit_step rebinds a state's volume and never writes into it: no copy.
        start_void = self.state.volume
        for iteration in range(self.fixed_stress_iterations + 1):
            self._mechanics_cycle(dt, n_steps, pipe_links)
            if iteration == self.fixed_stress_iterations:
                break
            # The solve again, about this iteration's pressures, with the voids the
            # mechanics realised in place of the ones its compliance anticipated.
            trial = _copy_state(start)
            trial.pressure = self.state.pressure.copy()
            self._solve(trial, pores, dt, injection_rate, self.void_aperture(),
                        self.well_void(), pipe_links)
            if self._split_converged(start.pressure, self.state.pressure, trial.pressure):
                break
            m.restore_state(mech_start)
            trial.volume = start_void  # the sealed pores' springs start from these voids
            self.state = trial

    def _solve(self, state: flow.FluidState, pores: _Pores, dt: float, injection_rate: float,
               void_aperture: np.ndarray, well_void: float | None,
               pipe_links: tuple[np.ndarray, np.ndarray]) -> None:
        """:func:`flow.implicit_step` of ``state`` with the pores' compliances about its
        pressures, from the voids of ``void_aperture`` and ``well_void``."""
        flow.implicit_step(self.network, state, void_aperture, dt, self.fluid,
                           injection_rate, compliance=pores.local_compliance,
                           well_volume=well_void, shared_compliance=pores.shared_compliance,
                           pipe_links=pipe_links)

    def _mechanics_cycle(self, dt: float, n_steps: int,
                         pipe_links: tuple[np.ndarray, np.ndarray]) -> None:
        """The mechanics over the fluid step at the solved pressures (pore springs on)."""
        m = self.mechanics
        self._apply_pressure()
        m.pore_springs = self._pore_springs(dt, pipe_links)
        u_before = m.u.copy()
        try:
            m.cycle(n_steps)
        finally:
            self.state.viscous_work += float(m.pore_springs.dissipated[0])
            m.pore_springs = PoreSprings.none()
        if self.well_unit_forces is not None:
            self.state.wall_work += self.well_pressure * float(
                np.sum(self.well_unit_forces * (m.u - u_before)))

    def _split_converged(self, start: np.ndarray, used: np.ndarray,
                         again: np.ndarray) -> bool:
        """Whether the pressures solved again from the realised voids (``again``) are
        those the mechanics ran at (``used``) at every free node: within
        ``fixed_stress_tolerance`` (Pa) or ``FIXED_STRESS_FRACTION`` of the step's own
        change from ``start``."""
        free = ~self.network.fixed
        change = np.abs(again - used)[free]
        allowed = np.maximum(self.fixed_stress_tolerance,
                             FIXED_STRESS_FRACTION * np.abs(used - start)[free])
        return bool(np.all(change <= allowed))

    def _pore_springs(self, dt: float, pipe_links: tuple[np.ndarray, np.ndarray]
                      ) -> PoreSprings:
        """How each free pore's pressure follows its void during this step's mechanics.

        Undrained pores: those next to a grain with no bonded boundary left, and
        those above the well's pressure (fluid being squeezed, not fed from the
        well) or at zero pressure (not reached by the well's fluid: a squeezed one
        pressurises at once; this moved the default seed-0 HS-only breakdown by
        0.01 MPa). Holding the solve's pressure in them pumps energy: a grain
        squeezes the pore during one step at a low pressure, the next solve puts a
        high one there, which blows the pore open during the next step at that
        pressure. Measured with the pressure held (and the borehole void of the
        undeformed mesh): hybrid, 15 % fissures, seed 0, the lab-calibrated 2D
        rock, a loose grain by the well cycled between 0 and 10-26 MPa and opened
        its gaps by 10-20 um a time, and the fluid did 23 J of work on the grains
        against 0.048 J pumped into the well (local damping took it); HS-only,
        Table 2, seed 8, a crack-tip pore cycled between 3.5 and 21 MPa, then
        reached 219 MPa (0.18 vs 0.08 J).

        Each such pore is a spring that starts the step at the solve's pressure and
        its current void, with the compliance of the fluid (V c) but no less than
        that of the pore's contact springs (sum A / kn): the fluid's own is up to
        100x stiffer in a thin gap, more than the explicit step can carry, while
        contact stiffness is what the mass scaling allows for (a node's stiffness
        at most doubles). Centred instead on the void the solve expects (the
        current void plus the opening its crack compliance anticipates), a crack
        that had collapsed during the last step started at 1045 MPa against the
        solve's 4.06 and blew open (HS 18 ml/min, Case 1, Table 2, seed 2: 0.16 J
        of fluid work for 0.049 J pumped).

        Drained pores (the others) hold the solve's pressure while their void is
        what their fluid fills at it, content - V c p (the current void plus the
        opening the solve's compliance anticipated); wider, the pressure falls as a
        spring of the fluid's compliance plus what the pore's pipes can bring in over
        the step (V c + dt sum C), a tenth as stiff as its contacts at most
        (``DRAINED_PORE_SOFTENING``), and it never rises above the solve's. Held
        without that limit, a bond breaking during a step let the held pressure push
        its faces apart into a void no fluid had reached: lab HS, 5 ml/min, seed 8,
        0.34-0.59 mJ of fluid work in single steps with the well pressure unchanged,
        and 1.16x the pumped energy on the grains over the run. Limited only past
        the larger of the current void and that filled one, a crack left wider than
        its fluid closed against the full pressure, and the grains' work on the
        fluid was lost (HS-only, Table 2, seed 4: 24 % of the pumped energy missing
        from the books). Measured with the fluid energy books
        (:meth:`hydraulic_energy`), residual / pumped at the 0.01 ms step: lab HS
        seed 8 -5.0 % (work on grains / pumped 0.65; 0.56 at a quarter step, 0.99
        with the pressure held); HS-only seed 4 -1.7 % (work on grains 0.066 J; 0.064
        at a quarter step); HS 18 ml/min, Case 2, seed 7 -1.4 %; default HS-only
        seed 0 -1.2 %.

        A drained pore's pressure also drops by ``resistance`` x the rate its void
        grows: the fluid that growth draws must come through the pore's pipes, at
        1 / sum C of pressure per unit rate (squeeze-film damping, which the step's
        one pressure solve does not see within the step), capped by
        ``PORE_DAMPING_LIMIT`` where the explicit step would not damp it stably. The
        drop's work is booked as viscous dissipation. Why: the solve's pressure,
        held for the step, lags the faces' motion, and a delayed spring pumps energy
        into their vibration. Measured on the penny (2 mm zones, seed 0): a plane
        node at the fracture front swung its void by +-10e-12 m3 every 4-5 fluid
        steps with the pressure in phase with the opening (0.94-1.04 MPa), and the
        books showed -15.6 % of the pumped energy; with the drop it opens smoothly,
        -11.7 %.
        """
        net = self.network
        pressure = self.state.pressure
        m = self.mechanics
        pore, contact, pores, local, springs, inertia = self._pore_layout()
        if len(contact) == 0:
            return PoreSprings.none()
        undrained = (pressure > self.well_pressure) | (pressure <= 0.0)
        undrained[pore[self._on_loose_grain(m.bonded[:len(pore)])]] = True
        f = self.fluid
        p = pressure[pores]
        void = self.state.volume[pores]
        fluid_storage = void / f.bulk_modulus
        ends, conductance = pipe_links  # flow.links of the step's network and apertures
        supply = dt * np.bincount(ends.ravel(), weights=np.repeat(conductance, 2),
                                  minlength=net.n_unknowns)[pores]
        sealed = undrained[pores]
        floor = springs * np.where(sealed, 1.0, DRAINED_PORE_SOFTENING)
        storage = np.maximum(np.where(sealed, fluid_storage, fluid_storage + supply), floor)
        filled = self.state.content[pores] - fluid_storage * p
        start = np.where(sealed, void, filled)
        # The pipes' resistance to the flow a moving void draws, capped where the
        # explicit step would no longer damp it stably.
        with np.errstate(divide="ignore"):
            resistance = np.minimum(dt / supply, PORE_DAMPING_LIMIT / (m.model.dt * inertia))
        resistance = np.where(sealed | ~(supply > 0), 0.0, resistance)
        return PoreSprings(
            contact=contact, pore=local,
            lower=flow.smallest_aperture(f, m.bonded[contact]),
            initial_aperture=(f.initial_aperture if self._void_a0 is None
                              else self._void_a0[contact]),
            held_void=start + p * storage, storage=storage,
            ceiling=np.where(sealed, np.inf, p), resistance=resistance)

    def _pore_layout(self) -> tuple[np.ndarray, ...]:
        """Which unknown each sub-contact fills, the sub-contacts of free pores (not the
        well's), those pores, each listed sub-contact's pore among them, each pore's
        contact springs sum A / kn, and how its void's rate answers its pressure,
        sum A^2 (1/m_a + 1/m_b) (m4/kg). Fixed by the network's unknowns: found
        once (on the 100 mm cube they cost as much as the rest of the pore springs)."""
        net = self.network
        cached = self._pore_layout_cache
        if (cached is not None and cached[0][0] is net.unknown_of_node
                and cached[0][1] is net.fixed and cached[0][2] == net.well_unknown):
            return cached[1]
        pore = net.contact_unknown
        listed = ~net.fixed
        if net.well_unknown >= 0:
            listed[net.well_unknown] = False
        contact = np.flatnonzero(listed[pore])
        pores, local = np.unique(pore[contact], return_inverse=True)
        model = self.mechanics.model
        area = model.contact_area[contact]
        springs = np.bincount(local, weights=area / model.normal_stiffness[contact])
        nodes = model.contact_nodes[contact]
        inertia = np.bincount(local, weights=area**2 * (1 / model.mass[nodes[:, 0]]
                                                       + 1 / model.mass[nodes[:, 1]]))
        layout = (pore, contact.astype(np.int64), pores, local.astype(np.int64), springs,
                  inertia)
        self._pore_layout_cache = ((net.unknown_of_node, net.fixed, net.well_unknown), layout)
        return layout


def _copy_state(state: flow.FluidState) -> flow.FluidState:
    """A copy of a fluid state whose arrays the caller may change."""
    return replace(state, pressure=state.pressure.copy(), volume=state.volume.copy(),
                   content=state.content.copy(),
                   dry=None if state.dry is None else state.dry.copy())


def penny_crack_length(diameter):
    """The 2D crack length (m) whose compliance rule gives a penny-shaped crack of
    ``diameter`` (m) the same fraction of its Sneddon opening as a 2D crack gets.

    Sneddon's mean opening under a pressure p is (pi / 2) p L / E' for a plane-strain
    crack of length L, and 16 p R / (3 pi E') = 8 p D / (3 pi E') for a penny of
    diameter D = 2R. The 2D rule A L / E' (``CRACK_COMPLIANCE_FACTOR`` 1) is 2 / pi of
    the former, so the penny's length is (2 / pi) (8 / (3 pi)) D = 16 D / (3 pi^2),
    0.54 D. A crack that is not a disc (a radial crack across a slab) is taken as the
    disc of its area, which overstates the opening of an elongated one.
    """
    return 16.0 / (3.0 * math.pi**2) * np.asarray(diameter)


def whole_steps(dt: float, step: float) -> int:
    """Mechanical steps of ``step`` seconds that a fluid step of ``dt`` advances: ``dt``
    rounded up, at least one; a ``dt`` within 1e-9 of a step of a whole number (a
    remainder computed from step counts) is that number, not one more."""
    return max(1, math.ceil(dt / step - 1e-9))


def pressure_jump_limit(pressure):
    """Largest pressure change (Pa) a coupled step may make at a fluid node before it
    is halved: 10 % of the pressure, at least 1 MPa (scalar or array).

    Constant-rate injection moves the well pressure by ~0.04 MPa per 0.01 ms step
    at 90 ml/min (default slab), and a breakdown drop spreads over several steps;
    the onset of a split instability jumped 3.3 MPa in one step (measured).
    """
    return np.maximum(PRESSURE_JUMP_FRACTION * np.abs(pressure), PRESSURE_JUMP_FLOOR)
