"""One driver runs a scenario's stages: equilibrate, scda, drill_out, inject.

The driver owns the loop (pyro2 style); the physics lives in ``physics/``,
files in ``io/``, figures in ``viz/``. Work advances in fixed chunks (a few
hundred mechanical steps, or one fluid step), so a run resumed from a
checkpoint retraces exactly the path of an uninterrupted one. After each
chunk: a history row, a snapshot when due, a checkpoint when due (and at every
stage end). Checkpoints are single ``.npz`` files replaced atomically; a
numerical blow-up keeps the last good checkpoint and raises :class:`RunFailed`
naming the stage, step and time.
"""

from __future__ import annotations

import json
import time as wallclock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grainfrac.assembly import GrainAssembly, build_assembly
from grainfrac.errors import GrainfracError
from grainfrac.io.files import write_atomic
from grainfrac.io.snapshots import SnapshotSeries
from grainfrac.loading.insitu import initialise_in_situ
from grainfrac.materials import RockRecipe
from grainfrac.physics import flow, scda
from grainfrac.physics.coupled import HydroMechanicalSolver
from grainfrac.physics.model import MechanicalModel, build_mechanical_model
from grainfrac.physics.solver import STATE_ARRAYS, MechanicsSolver, NumericalBlowUp
from grainfrac.scenario import (
    DrillOutStage,
    EquilibrateStage,
    InjectStage,
    ScdaStage,
    Scenario,
)

EQUILIBRATE_CHUNK = 200
SCDA_CHUNK = 500
RELAX_CHUNK = 500
# A crack this close to an outer side (in zone sizes) means a fracture reached it.
BOUNDARY_REACH_ZONES = 1.5


class RunFailed(GrainfracError):
    """A run stopped on a numerical problem; the last good state is checkpointed."""


@dataclass
class Progress:
    """What a progress display needs after each chunk."""

    stage_index: int
    stage_kind: str
    n_stages: int
    time_s: float
    stage_fraction: float
    n_cracks: int
    well_pressure_Pa: float
    expansive_pressure_Pa: float


@dataclass
class RunState:
    """Everything a checkpoint must restore beyond the deterministic rebuild."""

    stage_index: int = 0
    stage_start_time: float = 0.0
    stage_chunks: int = 0
    model_kind: str = "rock"
    history: list[dict[str, Any]] = field(default_factory=list)
    snapshots: list[tuple[float, str, str]] = field(default_factory=list)
    next_snapshot_time: float = 0.0
    peak_expansive_pressure: float = 0.0
    scda_stop_reason: str | None = None
    injection_start_time: float | None = None
    stage_times: dict[str, list[float]] = field(default_factory=dict)
    in_situ_unbalanced_force_ratio: float | None = None
    drill_out_unbalanced_force_ratio: float | None = None
    done: bool = False


class Run:
    """A scenario being run into a directory."""

    def __init__(self, scenario: Scenario, recipe: RockRecipe, out: Path, *,
                 base_dir: Path | None = None,
                 progress: Callable[[Progress], None] | None = None):
        self.scenario = scenario
        self.recipe = recipe
        self.out = Path(out)
        self.base_dir = base_dir
        self.progress = progress
        self.assembly: GrainAssembly = build_assembly(scenario.specimen_config(), recipe)
        self.rock_model: MechanicalModel = build_mechanical_model(self.assembly)
        self.n_rock_contacts = self.assembly.mesh.n_contacts
        self.n_rock_elements = self.assembly.mesh.n_elements
        self._fill: scda.ScdaFill | None = None
        self._scda_model: MechanicalModel | None = None
        self.solver = MechanicsSolver(self.rock_model)
        self.coupled: HydroMechanicalSolver | None = None
        self.state = RunState()
        self.snapshots = SnapshotSeries(self.out / "snapshots")
        self._last_checkpoint = wallclock.monotonic()
        self.wall_time_before = 0.0

    # -- SCDA models are built only when a stage needs them -------------------------
    def _scda_parts(self, stage: ScdaStage) -> tuple[scda.ScdaFill, MechanicalModel]:
        if self._fill is None:
            self._fill = scda.scda_fill(self.assembly, stage.material(self.base_dir))
            self._scda_model = scda.build_scda_model(self.assembly, self._fill)
        return self._fill, self._scda_model

    # -- bookkeeping ------------------------------------------------------------------
    @property
    def stages(self):
        return self.scenario.stages

    def rock_cracks(self) -> np.ndarray:
        c = np.asarray(self.solver.cracks.contact, dtype=np.int64)
        return c < self.n_rock_contacts

    def expansive_pressure(self) -> float:
        if self.state.model_kind != "scda":
            return 0.0
        return scda.expansive_pressure(self.solver, self.n_rock_contacts, self._fill.n_wall)

    def tangential_stress_near_well(self) -> float:
        """Mean hoop stress (Pa, compression positive as in paper Fig. 10e) of the rock
        between one and two well radii from the centre; NaN without a borehole."""
        outline = self.assembly.mesh.grains.outline
        if outline.borehole_radius <= 0:
            return float("nan")
        from grainfrac.analysis.fields import ring_mean_tangential_stress

        m = self.n_rock_elements
        mesh = self.assembly.mesh
        if not hasattr(self, "_centroids"):
            self._centroids = mesh.node_xy[mesh.element_nodes].mean(axis=1)
            self._areas = self.rock_model.element_area
        r = outline.borehole_radius
        return -ring_mean_tangential_stress(self._centroids, self.solver.stress[:m],
                                            self._areas, outline.borehole_center, r, 2 * r)

    def well_pressure(self) -> float:
        return self.coupled.well_pressure if self.coupled is not None else 0.0

    def _record(self, stage: Any, fraction: float) -> None:
        s = self.solver
        rock = self.rock_cracks()
        modes = np.asarray(s.cracks.mode, dtype=np.int64)[rock]
        injected = self.coupled.state.injected if self.coupled is not None else 0.0
        row = {
            "time_s": s.time,
            "stage": stage.kind,
            "well_pressure_MPa": self.well_pressure() / 1e6,
            "expansive_pressure_MPa": self.expansive_pressure() / 1e6,
            "injected_volume_ml": injected * 1e6,
            "n_cracks": int(rock.sum()),
            "n_tensile": int(np.count_nonzero(modes == 1)),
            "n_shear": int(np.count_nonzero(modes == 2)),
            "tangential_stress_near_well_MPa": self.tangential_stress_near_well() / 1e6,
            "step": s.step_count,
        }
        self.state.history.append(row)
        if self.progress is not None:
            self.progress(Progress(self.state.stage_index, stage.kind, len(self.stages), s.time,
                                   fraction, row["n_cracks"], self.well_pressure(),
                                   self.expansive_pressure()))

    def _maybe_snapshot(self, force: bool = False) -> None:
        every = self.scenario.output.snapshot_every_ms * 1e-3
        if force or self.solver.time >= self.state.next_snapshot_time:
            self.write_snapshot()
            self.state.next_snapshot_time = self.solver.time + every

    def write_snapshot(self) -> None:
        s = self.solver
        n, c, m = self.assembly.mesh.n_nodes, self.n_rock_contacts, self.n_rock_elements
        pressure = aperture = None
        if self.coupled is not None:
            pressure = s.contact_pressure[:c]
            aperture = self.coupled.aperture()
        self.snapshots.write(self.assembly, s.time, s.u[:n], s.stress[:m], s.sigma_n[:c],
                             s.tau[:c], s.status[:c], pressure=pressure, aperture=aperture)
        self.state.snapshots = list(self.snapshots.entries)

    # -- the loop ---------------------------------------------------------------------
    def execute(self) -> None:
        """Run (or continue) every stage to the end."""
        while self.state.stage_index < len(self.stages):
            stage = self.stages[self.state.stage_index]
            try:
                finished = self._advance(stage)
            except NumericalBlowUp as exc:
                raise RunFailed(
                    f"stage {self.state.stage_index + 1} ({stage.kind}) stopped: {exc}; the last "
                    f"good state is in {self.checkpoint_path}"
                ) from None
            if finished:
                self._end_stage(stage)
            elif wallclock.monotonic() - self._last_checkpoint >= (
                    self.scenario.output.checkpoint_every_minutes * 60.0):
                self.checkpoint()
        self.state.done = True
        self.checkpoint()

    def _end_stage(self, stage: Any) -> None:
        self.state.stage_times.setdefault(stage.kind, [self.state.stage_start_time,
                                                        self.solver.time])
        self._maybe_snapshot(force=True)
        self.state.stage_index += 1
        self.state.stage_start_time = self.solver.time
        self.state.stage_chunks = 0
        self.checkpoint()

    def _advance(self, stage: Any) -> bool:
        """One chunk of ``stage``; True when the stage has finished."""
        if isinstance(stage, EquilibrateStage):
            return self._equilibrate(stage)
        if isinstance(stage, ScdaStage):
            return self._scda(stage)
        if isinstance(stage, DrillOutStage):
            return self._drill_out(stage)
        if isinstance(stage, InjectStage):
            return self._inject(stage)
        raise GrainfracError(f"unknown stage {stage!r}")  # pragma: no cover

    def _equilibrate(self, stage: EquilibrateStage) -> bool:
        st = self.state
        if st.stage_chunks == 0:
            sx, sy = self.scenario.stress.resolved_Pa()
            self.solver.loads.external[:] = 0.0
            result = initialise_in_situ(self.solver, self.assembly.mesh, sx, sy,
                                        ratio=stage.unbalanced_ratio, max_steps=stage.max_steps)
            st.in_situ_unbalanced_force_ratio = result.unbalanced_force_ratio
            st.stage_chunks = 1
            self._record(stage, 1.0)
            return True
        return True  # pragma: no cover

    def _scda(self, stage: ScdaStage) -> bool:
        st = self.state
        fill, model = self._scda_parts(stage)
        if st.model_kind != "scda":
            self.solver = scda.insert_scda(self.solver, model, fill)
            st.model_kind = "scda"
        plug = scda.plug_elements(self.solver, self.n_rock_elements)
        elapsed = self.solver.time - st.stage_start_time
        v = stage.velocity(elapsed)
        scda.set_expansion_velocity(self.solver, plug, v, fill.radius)
        self.solver.cycle(SCDA_CHUNK)
        st.stage_chunks += 1
        p = self.expansive_pressure()
        st.peak_expansive_pressure = max(st.peak_expansive_pressure, p)
        elapsed = self.solver.time - st.stage_start_time
        limit = stage.max_duration_ms * 1e-3
        if p >= stage.peak_pressure_MPa * 1e6:
            st.scda_stop_reason = "peak pressure"
        elif stage.velocity(elapsed) < stage.min_velocity_fraction * stage.velocity(0.0):
            st.scda_stop_reason = "expansion decayed"
        elif elapsed >= limit:
            # Neither of the paper's ends: the result depends on the time limit.
            st.scda_stop_reason = "time limit"
        done = st.scda_stop_reason is not None
        self._record(stage, min(1.0, max(p / (stage.peak_pressure_MPa * 1e6), elapsed / limit)))
        self._maybe_snapshot()
        if done:
            self.solver.eigenstrain_rate[:] = 0.0
        return done

    def _drill_out(self, stage: DrillOutStage) -> bool:
        st = self.state
        if st.model_kind == "scda":
            self.solver = scda.drill_out(self.solver, self.rock_model)
            st.model_kind = "rock"
        steps = min(st.stage_chunks * RELAX_CHUNK, stage.max_steps)
        if steps < stage.max_steps:
            self.solver.cycle(min(RELAX_CHUNK, stage.max_steps - steps))
            st.stage_chunks += 1
            steps = min(st.stage_chunks * RELAX_CHUNK, stage.max_steps)
        ratio = self.solver.unbalanced_force_ratio()
        done = steps >= stage.max_steps or (steps >= stage.relax_steps
                                            and ratio < stage.unbalanced_ratio)
        if done:
            st.drill_out_unbalanced_force_ratio = ratio
        self._record(stage, min(1.0, steps / max(stage.relax_steps, 1)))
        return done

    def _make_coupled(self) -> HydroMechanicalSolver:
        fluid = self.scenario.fluid
        network = flow.build_flow_network(
            self.assembly.mesh, permeable_sides=fluid.fixed_pressures(), well=True,
            well_compressibility=fluid.well_compressibility,
            sealed=self.assembly.contact_intragranular,
        )
        a0 = self.assembly.recipe.hydraulic.initial_aperture_m
        return HydroMechanicalSolver(self.assembly, self.solver, network, fluid.properties(a0))

    def _inject(self, stage: InjectStage) -> bool:
        st = self.state
        if self.coupled is None:
            self.coupled = self._make_coupled()
            if st.injection_start_time is None:
                st.injection_start_time = self.solver.time
        self.coupled.advance(stage.time_step, stage.rate)
        st.stage_chunks += 1
        elapsed = self.solver.time - st.stage_start_time
        planned = stage.planned_duration_s
        done = elapsed >= planned - 1e-12
        if stage.stop_at_boundary and self._fracture_at_boundary():
            done = True
        self._record(stage, min(1.0, elapsed / planned))
        self._maybe_snapshot()
        return done

    def _fracture_at_boundary(self) -> bool:
        """Whether a crack made since injection started lies within reach of an outer
        side (not the borehole wall).

        Cracks of earlier stages do not count: after SCDA charging in a weak rock a
        radial crack can already reach the boundary, and the injection that is to
        extend the fractures would otherwise end at its first step.
        """
        since = self.state.injection_start_time
        rock = self.rock_cracks() & (np.asarray(self.solver.cracks.time) >= since)
        if not rock.any():
            return False
        contacts = np.asarray(self.solver.cracks.contact, dtype=np.int64)[rock]
        xy = self.assembly.mesh.contact_xy[contacts]
        outline = self.assembly.mesh.grains.outline
        reach = BOUNDARY_REACH_ZONES * self.assembly.mesh.zone_size
        near = outline.side_of_points(xy, reach)
        return any(mask.any() for side, mask in near.items() if side != "borehole")

    # -- checkpoints --------------------------------------------------------------------
    @property
    def checkpoint_path(self) -> Path:
        return self.out / "checkpoint" / "state.npz"

    def checkpoint(self) -> None:
        s = self.solver
        arrays: dict[str, np.ndarray] = {
            name: getattr(s, name) for name in STATE_ARRAYS
        }
        arrays["loads_external"] = s.loads.external
        arrays["loads_fixed"] = s.loads.fixed
        arrays["loads_prescribed_velocity"] = s.loads.prescribed_velocity
        arrays["cracks"] = np.array([s.cracks.contact, s.cracks.mode], dtype=np.int64).reshape(
            2, -1)
        arrays["crack_values"] = np.array([s.cracks.time, s.cracks.energy]).reshape(2, -1)
        if self.coupled is not None:
            fs = self.coupled.state
            arrays["fluid_pressure"] = fs.pressure
            arrays["fluid_volume"] = fs.volume
            arrays["fluid_content"] = fs.content
            arrays["fluid_totals"] = np.array([fs.injected, fs.outflow, fs.pump_work,
                                               fs.wall_work, fs.viscous_work,
                                               fs.outflow_work])
            arrays["coupled_base_external"] = self.coupled.base_external
            h = self.coupled.history
            arrays["coupled_history"] = np.array([h.time, h.well_pressure, h.injected_volume,
                                                  h.n_cracks]).reshape(4, -1)
        meta = {
            "time": s.time, "step_count": s.step_count, "allow_failure": s.allow_failure,
            "state": self.state.__dict__,
            "wall_time_s": self.wall_time_before + self._wall(),
        }
        arrays["meta"] = np.array(json.dumps(meta))
        write_atomic(self.checkpoint_path, lambda p: np.savez(p, **arrays))
        from grainfrac.io.results import write_history

        write_history(self.out / "history.csv", self.state.history)
        self._last_checkpoint = wallclock.monotonic()

    def _wall(self) -> float:
        return wallclock.monotonic() - self._started

    def start_clock(self) -> None:
        self._started = wallclock.monotonic()

    def restore(self) -> None:
        """Continue from ``checkpoint/state.npz``."""
        with np.load(self.checkpoint_path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta")))
        st = RunState(**meta["state"])
        st.snapshots = [tuple(x) for x in st.snapshots]
        self.state = st
        self.wall_time_before = float(meta["wall_time_s"])
        if st.model_kind == "scda":
            stage = next(x for x in self.stages if isinstance(x, ScdaStage))
            fill, model = self._scda_parts(stage)
            self.solver = MechanicsSolver(model)
        s = self.solver
        for name in STATE_ARRAYS:
            getattr(s, name)[...] = arrays[name]
        s.loads.external[...] = arrays["loads_external"]
        s.loads.fixed[...] = arrays["loads_fixed"]
        s.loads.prescribed_velocity[...] = arrays["loads_prescribed_velocity"]
        s.time = float(meta["time"])
        s.step_count = int(meta["step_count"])
        s.allow_failure = bool(meta["allow_failure"])
        s.cracks.contact = arrays["cracks"][0].tolist()
        s.cracks.mode = arrays["cracks"][1].tolist()
        s.cracks.time = arrays["crack_values"][0].tolist()
        s.cracks.energy = arrays["crack_values"][1].tolist()
        if "fluid_pressure" in arrays:
            self.coupled = self._make_coupled()
            fs = self.coupled.state
            fs.pressure = arrays["fluid_pressure"].copy()
            fs.volume = arrays["fluid_volume"].copy()
            fs.content = arrays["fluid_content"].copy()
            # Checkpoints written before the energy totals hold two or four values.
            totals = np.zeros(6)
            totals[:len(arrays["fluid_totals"])] = arrays["fluid_totals"]
            (fs.injected, fs.outflow, fs.pump_work, fs.wall_work, fs.viscous_work,
             fs.outflow_work) = (float(x) for x in totals)
            self.coupled.base_external = arrays["coupled_base_external"].copy()
            h = arrays["coupled_history"]
            hist = self.coupled.history
            hist.time, hist.well_pressure = h[0].tolist(), h[1].tolist()
            hist.injected_volume, hist.n_cracks = h[2].tolist(), [int(x) for x in h[3]]
            s.loads.external[...] = arrays["loads_external"]
            s.contact_pressure[...] = arrays["contact_pressure"]
        self.snapshots.entries = list(st.snapshots)



# -- entry points ---------------------------------------------------------------------
def summarise(run: Run, wall_time_s: float) -> dict[str, Any]:
    """summary.json of a finished (or stopped) run: the keys of docs/outputs.md."""
    import grainfrac
    from grainfrac.analysis import breakdown_summary, contact_fractions, fracture_summary

    a = run.assembly
    s = run.solver
    rock = run.rock_cracks()
    contact = np.asarray(s.cracks.contact, dtype=np.int64)[rock]
    mode = np.asarray(s.cracks.mode, dtype=np.int64)[rock]
    energy = np.asarray(s.cracks.energy, dtype=float)[rock]
    xy = a.mesh.contact_xy[contact].reshape(-1, 2)
    outline = a.mesh.grains.outline
    out: dict[str, Any] = {
        "grainfrac_version": grainfrac.__version__,
        "scenario": run.scenario.name,
        "seed": run.scenario.seed,
        "wall_time_s": wall_time_s,
        "n_grains": a.n_grains,
        "n_elements": a.mesh.n_elements,
        "n_contacts": a.mesh.n_contacts,
        "stages": list(run.scenario.stage_kinds),
        "stage_times_s": run.state.stage_times,
        "breakdown_pressure_MPa": None,
        "breakdown_time_s": None,
        "breakdown_drop_1ms_fraction": None,
        "peak_well_pressure_MPa": None,
        "peak_expansive_pressure_MPa": None,
        "scda_stop_reason": None,
        "injected_volume_ml": None,
    }
    if run.coupled is not None:
        h = run.coupled.history
        t0 = run.state.injection_start_time or 0.0
        out.update(breakdown_summary(np.asarray(h.time) - t0, np.asarray(h.well_pressure)))
        out["peak_well_pressure_MPa"] = float(np.max(h.well_pressure)) / 1e6
        out["injected_volume_ml"] = run.coupled.state.injected * 1e6
    if "scda" in run.scenario.stage_kinds:
        out["peak_expansive_pressure_MPa"] = run.state.peak_expansive_pressure / 1e6
        out["scda_stop_reason"] = run.state.scda_stop_reason
    out.update(fracture_summary(
        xy[:, 0], xy[:, 1], mode, energy, center=outline.borehole_center,
        well_radius=outline.borehole_radius,
        connect_distance=1.5 * a.mesh.zone_size,
    ))
    out["energy_friction_J"] = float(s.energies[2])
    # The mechanics' own books (J): work in (boundary, expansion, fluid), stored,
    # dissipated (damping, friction, bonds released) and the residual.
    out["energy_balance_J"] = s.energy_balance()
    out["warnings"] = []
    if run.coupled is not None:
        out["hydraulic_energy_J"] = run.coupled.hydraulic_energy()
        out["warnings"] += hydraulic_energy_warnings(out["hydraulic_energy_J"])
    # Grain boundaries only (paper Fig. 14e): a crack through a quartz grain is no Q-Q contact.
    on_boundary = ~a.contact_view("intragranular")
    pair = a.contact_view("pair")
    total, failed = contact_fractions(pair[on_boundary], pair[contact[on_boundary[contact]]],
                                      a.pair_names)
    out["contact_fraction_total"] = total
    out["contact_fraction_failed"] = failed
    out["in_situ_unbalanced_force_ratio"] = run.state.in_situ_unbalanced_force_ratio
    drill_out = next((st for st in run.stages if isinstance(st, DrillOutStage)), None)
    if drill_out is not None:
        ratio = run.state.drill_out_unbalanced_force_ratio
        out["drill_out_unbalanced_force_ratio"] = ratio
        if ratio is not None and ratio >= drill_out.unbalanced_ratio:
            out["warnings"].append(
                f"drill_out: the rock had not settled after max_steps = {drill_out.max_steps} "
                f"(unbalanced-force ratio {ratio:.3g}, target {drill_out.unbalanced_ratio:g}), "
                "so what followed started from a moving rock; raise max_steps")
    return out


# Energy the coupling may make, as a fraction of the pumped energy, before a run is
# flagged. The books close to first order in the fluid step (residual / pumped, see
# HydroMechanicalSolver.hydraulic_energy): default HS-only run (seed 0) -0.84 %, lab
# HS 5 ml/min seed 0 -8.6 %, 140 Table 2 study runs -8.6 to +0.3 %. Runs where the
# coupling visibly made energy (before the fixes in physics/coupled.py) did 2.3-480x
# the pumped energy on the grains alone.
ENERGY_BOOKS_SLACK = 0.10


def hydraulic_energy_warnings(energy: dict[str, float]) -> list[str]:
    """A warning when the fluid's energy books show the coupling made energy: the
    work on the grains, viscous dissipation, stored compression and outflow add up to
    more than the pumped energy (beyond :data:`ENERGY_BOOKS_SLACK` of it)."""
    made = -energy["residual"]
    if made <= ENERGY_BOOKS_SLACK * energy["pumped"]:
        return []
    return [f"the coupling made {made:.3g} J of fluid energy ({made / energy['pumped']:.0%} of "
            f"the {energy['pumped']:.3g} J pumped into the well: {energy['on_grains']:.3g} J "
            f"of work on the grains, {energy['viscous']:.3g} J viscous, "
            f"{energy['stored']:.3g} J stored); compare with a smaller inject time_step_ms"]


def _plot_final_fields(run: Run, figures: Path) -> None:
    """Displacement, minor principal stress and (with fluid) the pressure in contacts."""
    from grainfrac.viz.fields import (
        plot_contact_pressure,
        plot_displacement,
        plot_minor_principal_stress,
    )

    s = run.solver
    n, m = run.assembly.mesh.n_nodes, run.n_rock_elements
    name = run.scenario.name
    plot_displacement(run.assembly, s.u[:n], figures / "displacement.png",
                      title=f"{name}: displacement at the end")
    plot_minor_principal_stress(run.assembly, s.stress[:m], figures / "minor_principal_stress.png",
                                title=f"{name}: minor principal stress at the end")
    if run.coupled is not None:
        plot_contact_pressure(run.assembly, s.contact_pressure[:run.n_rock_contacts],
                              figures / "fluid_pressure.png",
                              title=f"{name}: fluid pressure in grain boundaries (leak-off)")


def run_scenario(scenario: Scenario, recipe: RockRecipe, out: str | Path, *,
                 base_dir: Path | None = None, resume: bool = False,
                 progress: Callable[[Progress], None] | None = None) -> dict[str, Any]:
    """Run (or resume) a scenario into ``out``; return the summary.

    Writes config.toml (resolved), history.csv, cracks.csv, snapshots/,
    figures/, summary.json and checkpoint/state.npz.
    """
    from grainfrac.io.files import write_json
    from grainfrac.io.results import write_cracks
    from grainfrac.physics.cracks import crack_catalogue
    from grainfrac.scenario import write_resolved
    from grainfrac.viz.fractures import plot_fracture_pattern
    from grainfrac.viz.pressure import plot_stage_history, plot_well_pressure

    out = Path(out)
    run = Run(scenario, recipe, out, base_dir=base_dir, progress=progress)
    run.start_clock()
    if resume:
        if not run.checkpoint_path.is_file():
            raise GrainfracError(f"nothing to resume: {run.checkpoint_path} does not exist")
        run.restore()
    else:
        write_resolved(out / "config.toml", scenario, recipe)
    try:
        run.execute()
    finally:
        from grainfrac.io.results import write_history

        write_history(out / "history.csv", run.state.history)
        rock = run.rock_cracks()
        s = run.solver
        cat = crack_catalogue(run.assembly, np.asarray(s.cracks.contact)[rock],
                              np.asarray(s.cracks.time)[rock], np.asarray(s.cracks.mode)[rock],
                              np.asarray(s.cracks.energy)[rock])
        write_cracks(out / "cracks.csv", cat.rows(run.assembly.pair_names))
    wall = run.wall_time_before + run._wall()
    summary = summarise(run, wall)
    figures = out / "figures"
    plot_fracture_pattern(run.assembly, cat.contact, cat.mode, figures / "fractures.png",
                          title=f"{scenario.name} (seed {scenario.seed})")
    if run.coupled is not None:
        h = run.coupled.history
        t0 = run.state.injection_start_time or 0.0
        plot_well_pressure(np.asarray(h.time) - t0, np.asarray(h.well_pressure),
                           np.asarray(h.n_cracks), figures / "well_pressure.png",
                           title=f"{scenario.name}: well pressure")
    plot_stage_history(run.state.history, figures / "pressures.png",
                       title=f"{scenario.name}: pressures and cracks by stage")
    _plot_final_fields(run, figures)
    write_json(out / "summary.json", summary)
    return summary
