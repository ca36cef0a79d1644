"""A scenario's run: its stages on the driver, with history, snapshots and checkpoints.

The driver (:mod:`grainfrac.stages`) owns the loop; this module supplies what
happens between its chunks. After each chunk: a history row, a snapshot when
due, a checkpoint when due (and at every stage end). Work advances in fixed
chunks, so a run resumed from a checkpoint retraces exactly the path of an
uninterrupted one. The checkpoint is one HDF5 file of records
(:mod:`grainfrac.io.checkpoint`) replaced atomically; a numerical blow-up
keeps the last good checkpoint and raises :class:`RunFailed` naming the stage,
step and time. Summary and figures are not made here (:mod:`grainfrac.simulation`).
"""

from __future__ import annotations

import hashlib
import json
import logging
import shutil
import signal
import threading
import time as wallclock
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

import grainfrac
from grainfrac.assembly import GrainAssembly, build_assembly
from grainfrac.errors import CheckpointError, GrainfracError
from grainfrac.io.checkpoint import read_checkpoint, write_checkpoint
from grainfrac.io.files import DirectoryBusy, directory_lock, write_json
from grainfrac.io.results import append_history, write_history
from grainfrac.io.snapshots import PlugState, SnapshotSeries
from grainfrac.materials import RockRecipe
from grainfrac.physics.coupled import CoupledHistory
from grainfrac.physics.fields import Ring
from grainfrac.physics.flow import FluidState
from grainfrac.physics.model import build_mechanical_model
from grainfrac.physics.solver import MechanicsSolver, NumericalBlowUp, resolve_backend
from grainfrac.scenario import Scenario, resolved_dict
from grainfrac.stages import Driver, DriverState, Hooks, Stage, World, from_scenario
from grainfrac.stages.inject import couple_fluid
from grainfrac.stages.world import SCDA

CHECKPOINT_FILE = Path("checkpoint") / "state.h5"
# Checkpoints of grainfrac before format 1: recognised only to refuse them clearly.
LEGACY_CHECKPOINT_FILE = Path("checkpoint") / "state.npz"


def checkpoint_path(out: str | Path) -> Path:
    """The checkpoint of the run directory ``out``."""
    return Path(out) / CHECKPOINT_FILE


class RunFailed(GrainfracError):
    """A run stopped on a numerical problem; the last good state is checkpointed."""


class RunInterrupted(GrainfracError):
    """A run stopped on SIGINT or SIGTERM after writing a checkpoint to resume from."""


class RunDirectoryError(GrainfracError):
    """A run directory cannot be used as asked: busy, holding another run, or not writable."""


# ----------------------------------------------------------------------- run directories

FINGERPRINT_FILE = "fingerprint.json"
LOCK_FILE = "run.lock"
# What a directory may hold and still count as empty (a lock left by a killed run).
_EMPTY_ANYWAY = {LOCK_FILE}


def fingerprint(scenario: Scenario, recipe: RockRecipe,
                base_dir: Path | None = None) -> dict[str, Any]:
    """What identifies a run: the hash of the resolved scenario (every default, the
    rock and SCDA materials inline, the seed), the seed and the grainfrac version."""
    resolved = resolved_dict(scenario, recipe, base_dir)
    text = json.dumps(resolved, sort_keys=True, separators=(",", ":"))
    return {"scenario_sha256": hashlib.sha256(text.encode()).hexdigest(),
            "scenario": scenario.name, "seed": scenario.seed,
            "grainfrac_version": grainfrac.__version__}


def _first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """The dotted path of the first place where ``a`` and ``b`` differ (None if equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(a.keys() | b.keys()):
            found = _first_difference(a.get(key), b.get(key), f"{path}.{key}" if path else key)
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            found = _first_difference(x, y, f"{path}.{i}" if path else str(i))
            if found:
                return found
        return None
    return None if a == b else (path or "<root>")


def _mismatch(out: Path, stored: dict[str, Any], now: dict[str, Any],
              scenario: Scenario, recipe: RockRecipe, base_dir: Path | None) -> str | None:
    """Why the run in ``out`` (``stored``) is not the run asked for (``now``), or None."""
    if stored.get("scenario_sha256") == now["scenario_sha256"] and \
            stored.get("grainfrac_version") == now["grainfrac_version"]:
        return None
    if stored.get("grainfrac_version") != now["grainfrac_version"]:
        return (f"written by grainfrac {stored.get('grainfrac_version')}, this is "
                f"{now['grainfrac_version']}")
    if stored.get("seed") != now["seed"]:
        return f"it has seed {stored.get('seed')}, not {now['seed']}"
    if stored.get("scenario") != now["scenario"]:
        return f"it is scenario {stored.get('scenario')!r}, not {now['scenario']!r}"
    where = None
    config = out / "config.toml"
    if config.is_file():
        from grainfrac.io.config import read_toml

        try:
            where = _first_difference(read_toml(config), resolved_dict(scenario, recipe,
                                                                       base_dir))
        except GrainfracError:
            where = None
    return "its scenario differs" + (f" at {where}" if where else "")


def _clear(out: Path) -> None:
    for entry in out.iterdir():
        if entry.name in _EMPTY_ANYWAY:
            continue
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()


@contextmanager
def run_directory(out: Path, scenario: Scenario, recipe: RockRecipe, *,
                  base_dir: Path | None = None, resume: bool = False,
                  overwrite: bool = False) -> Iterator[dict[str, Any]]:
    """Hold ``out`` for one run of ``scenario``; yield the run's :func:`fingerprint`.

    Takes ``out/run.lock`` (a second process gets :class:`RunDirectoryError`),
    then: to resume, ``out`` must hold ``fingerprint.json`` of this same run; for
    a new run ``out`` must be empty (apart from a lock file), or ``overwrite``
    clears it, but only if it holds nothing but what grainfrac writes
    (:data:`RUN_DIRECTORY_ENTRIES`). A new run's fingerprint is written before
    anything else.
    """
    out = Path(out)
    if resume and not out.is_dir():
        raise RunDirectoryError(f"--resume: {out} holds no run to continue (no such directory)")
    expected = fingerprint(scenario, recipe, base_dir)
    with ExitStack() as stack:
        # Only the setup's OS errors are about --out; the run's own propagate unchanged.
        try:
            stack.enter_context(directory_lock(out, LOCK_FILE))
            if resume:
                _check_resumable(out, expected, scenario, recipe, base_dir)
            else:
                _prepare_new(out, overwrite)
                write_json(out / FINGERPRINT_FILE, expected)
        except DirectoryBusy as exc:
            raise RunDirectoryError(f"{exc}; wait for it to finish or use another --out"
                                    ) from None
        except (FileExistsError, NotADirectoryError) as exc:
            raise RunDirectoryError(f"--out {out}: a file is in the way ({exc.strerror}: "
                                    f"{exc.filename})") from None
        except OSError as exc:
            raise RunDirectoryError(f"--out {out}: cannot be written ({exc.strerror}: "
                                    f"{exc.filename})") from None
        yield expected


def _check_resumable(out: Path, expected: dict[str, Any], scenario: Scenario,
                     recipe: RockRecipe, base_dir: Path | None) -> None:
    path = out / FINGERPRINT_FILE
    if not path.is_file() and (out / LEGACY_CHECKPOINT_FILE).is_file():
        read_checkpoint(out / LEGACY_CHECKPOINT_FILE)  # says which grainfrac wrote it
    if not path.is_file():
        raise RunDirectoryError(
            f"--resume: {out} holds no {FINGERPRINT_FILE}, so it cannot be checked to be "
            "this run's; run the scenario again without --resume (add --overwrite)")
    try:
        stored = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RunDirectoryError(f"--resume: {path} cannot be read ({exc})") from None
    if not isinstance(stored, dict):
        raise RunDirectoryError(f"--resume: {path} is not a run fingerprint")
    why = _mismatch(out, stored, expected, scenario, recipe, base_dir)
    if why:
        raise RunDirectoryError(f"--resume: {out} holds another run ({why}); resume it "
                                "without a scenario or --seed, or use another --out")
    if checkpoint_path(out).is_file():
        # A damaged checkpoint is refused here, before the specimen is built.
        read_checkpoint(checkpoint_path(out))


# What grainfrac writes into a run directory (a sweep adds failed.json, a report
# report.html). --overwrite clears a directory only if it holds nothing else.
RUN_DIRECTORY_ENTRIES = frozenset({
    FINGERPRINT_FILE, LOCK_FILE, "config.toml", "summary.json", "history.csv", "cracks.csv",
    "snapshots", "figures", "checkpoint", "run.log", "legend.json", "report.html",
    "failed.json",
})


def _ours(name: str) -> bool:
    # The atomic writers' temporary files are ".<stem>.<random><suffix>".
    if name.startswith("."):
        return any(name.startswith(f".{Path(e).stem}.") for e in RUN_DIRECTORY_ENTRIES)
    return name in RUN_DIRECTORY_ENTRIES


def _prepare_new(out: Path, overwrite: bool) -> None:
    present = sorted({p.name for p in out.iterdir()} - _EMPTY_ANYWAY)
    if not present:
        return
    if not overwrite:
        raise RunDirectoryError(
            f"--out {out} is not empty ({len(present)} entries, e.g. {present[0]}); continue "
            "its run with --resume, clear it with --overwrite, or use another --out")
    foreign = [name for name in present if not _ours(name)]
    if foreign:
        # --out ~ --overwrite must not empty a home directory.
        raise RunDirectoryError(
            f"--overwrite: {out} holds {foreign[0]!r}, which no grainfrac run writes, so it "
            "is not cleared; give an empty or new --out")
    _clear(out)


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
    # Simulated time since the stage started (s), the stage's planned duration (s; None
    # where a stage has none: equilibrate, drill_out) and the ETA of the stage (wall s,
    # from the wall time per fraction so far; None until the stage has advanced).
    stage_time_s: float = 0.0
    stage_planned_s: float | None = None
    eta_s: float | None = None


@dataclass
class RunRecord:
    """What the run itself keeps besides the driver's, the stages' and the world's
    state: the history rows, the snapshots written and when each stage ran."""

    history: list[dict[str, Any]] = field(default_factory=list)
    snapshots: list[tuple[float, str, str]] = field(default_factory=list)
    next_snapshot_time: float = 0.0
    stage_times: dict[str, list[float]] = field(default_factory=dict)
    wall_time_s: float = 0.0


def planned_duration(stage: Stage) -> float | None:
    """The simulated time (s) a stage is planned to last: an injection's duration (or
    volume / rate), SCDA charging's time limit; None for stages that end on a state
    (equilibrate, drill_out)."""
    spec = getattr(stage, "spec", None)
    if stage.kind == "inject":
        return spec.planned_duration_s
    if stage.kind == "scda":
        return spec.max_duration_ms * 1e-3
    return None


def _arrays(obj: Any) -> dict[str, np.ndarray]:
    """The fields of a dataclass as arrays (lists become arrays)."""
    return {f.name: np.asarray(getattr(obj, f.name)) for f in fields(obj)}


log = logging.getLogger(__name__)
# Seconds between two progress lines in run.log (and on stderr off a terminal).
LOG_EVERY_S = 30.0
LOG_FILE = "run.log"


@contextmanager
def run_log(out: Path) -> Iterator[Path]:
    """Send grainfrac's log records (INFO and up) to ``out/run.log`` (appended: a
    resumed run continues its log) while the block runs."""
    path = Path(out) / LOG_FILE
    handler = logging.FileHandler(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    handler.setLevel(logging.INFO)
    logger = logging.getLogger("grainfrac")
    level = logger.level
    if logger.getEffectiveLevel() > logging.INFO:
        logger.setLevel(logging.INFO)
    logger.addHandler(handler)
    try:
        yield path
    finally:
        logger.removeHandler(handler)
        handler.close()
        logger.setLevel(level)


@contextmanager
def stop_on_signals(request_stop: Callable[[str], None]) -> Iterator[None]:
    """While the block runs, SIGINT and SIGTERM call ``request_stop(name)`` instead of
    killing the process (a second one does: the user insists). Only in the main
    thread, where Python delivers signals; elsewhere (a Dask worker's thread) the
    block runs with the handlers as they are."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous: dict[int, Any] = {}

    def handler(signum: int, frame: Any) -> None:
        for sig, old in previous.items():
            signal.signal(sig, old)  # the next one is not caught
        request_stop(signal.Signals(signum).name)

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


class Run(Hooks):
    """A scenario being run into a directory."""

    def __init__(self, scenario: Scenario, recipe: RockRecipe, out: Path, *,
                 base_dir: Path | None = None,
                 progress: Callable[[Progress], None] | None = None,
                 fingerprint: dict[str, Any] | None = None):
        self.scenario = scenario
        # Written into every checkpoint and checked on restore: a checkpoint copied
        # or left from another run is refused, not continued under this run's name.
        self.fingerprint = fingerprint
        self.recipe = recipe
        self.out = Path(out)
        self.progress = progress
        numerics = scenario.numerics
        self.backend = resolve_backend(numerics.backend)  # before any compute
        self.assembly: GrainAssembly = build_assembly(scenario.specimen_config(), recipe)
        model = build_mechanical_model(self.assembly, mass_scaling=numerics.mass_scaling)
        self.world = World(self.assembly, MechanicsSolver(model, damping=numerics.local_damping,
                                                          backend=self.backend),
                           mass_scaling=numerics.mass_scaling,
                           fixed_stress_iterations=numerics.fixed_stress_iterations)
        self.stages: list[Stage] = from_scenario(scenario, base_dir)
        self.driver = Driver(self.stages, self.world, self)
        self.record = RunRecord()
        # Written by a worker thread while the mechanics goes on; every checkpoint
        # waits for them, so that a checkpoint lists only snapshots on disk.
        self.snapshots = SnapshotSeries(self.out / "snapshots", background=True)
        mesh = self.assembly.mesh
        self._centroids = mesh.node_x[mesh.element_nodes].mean(axis=1)
        self._near_well: Ring | None = None  # found at the first history row
        self._last_checkpoint = wallclock.monotonic()
        self._started = wallclock.monotonic()
        self.log_every_s = LOG_EVERY_S
        self._last_log = wallclock.monotonic()
        self._stage_wall_start = wallclock.monotonic()
        self._stop: str | None = None
        # Rows of record.history already in history.csv, and the step of the last checkpoint.
        self._history_written = 0
        self._checkpoint_step = 0

    def request_stop(self, reason: str) -> None:
        """Stop at the end of the chunk in progress, with a checkpoint (a signal handler
        calls this: it only sets a flag, the loop does the rest)."""
        self._stop = reason

    @property
    def solver(self) -> MechanicsSolver:
        return self.world.solver

    @property
    def checkpoint_path(self) -> Path:
        return checkpoint_path(self.out)

    def stage(self, kind: str) -> Stage | None:
        """The first stage of ``kind`` (None if the scenario has none)."""
        return next((s for s in self.stages if s.kind == kind), None)

    def stage_starts(self) -> list[tuple[str, float]]:
        """Kind and absolute start time (s) of every stage begun so far, in order."""
        st = self.driver.state
        begun = st.stage_index + (1 if st.begun else 0)
        return [(stage.kind, stage.state.start_time) for stage in self.stages[:begun]]

    def wall_time(self) -> float:
        """Seconds this run has computed, over every session that resumed it."""
        return self.record.wall_time_s + wallclock.monotonic() - self._started

    # -- the loop ---------------------------------------------------------------------
    def execute(self) -> None:
        """Run (or continue) every stage to the end."""
        try:
            self.driver.execute()
        except BaseException as exc:
            self.snapshots.wait(raise_errors=False)  # the files begun, whatever stopped us
            if not isinstance(exc, NumericalBlowUp):
                raise
            i = self.driver.state.stage_index
            raise RunFailed(
                f"stage {i + 1} ({self.stages[i].kind}) stopped: {exc}; the last "
                f"good state is in {self.checkpoint_path}"
            ) from None
        self.snapshots.wait()

    def after_chunk(self, stage: Stage) -> None:
        self._record(stage)
        if stage.periodic_snapshots:
            self._maybe_snapshot()
        if wallclock.monotonic() - self._last_log >= self.log_every_s:
            self._log_progress(stage)
            self.flush_history()

    def after_stage(self, stage: Stage) -> None:
        self.record.stage_times.setdefault(stage.kind, [stage.state.start_time,
                                                        self.solver.time])
        self._maybe_snapshot(force=True)
        self.checkpoint()
        i = self.stages.index(stage)
        reason = getattr(stage.state, "stop_reason", None)
        log.info("stage %d/%d %s done at t = %.4f ms (stage %.4f ms, %.0f s wall), "
                 "%d cracks%s", i + 1, len(self.stages), stage.kind, self.solver.time * 1e3,
                 (self.solver.time - stage.state.start_time) * 1e3,
                 wallclock.monotonic() - self._stage_wall_start,
                 int(self.world.rock_cracks().sum()), f"; stopped: {reason}" if reason else "")
        self._stage_wall_start = wallclock.monotonic()
        self._stop_if_asked()

    def between_chunks(self) -> None:
        if self._stop is not None or self.checkpoint_due():
            self.checkpoint()
        self._stop_if_asked()

    def checkpoint_due(self) -> bool:
        """Whether ``output.checkpoint_every_minutes`` of wall clock or
        ``output.checkpoint_every_steps`` mechanical steps passed since the last checkpoint."""
        output = self.scenario.output
        if wallclock.monotonic() - self._last_checkpoint >= output.checkpoint_every_minutes * 60:
            return True
        every = output.checkpoint_every_steps
        return every is not None and self.solver.step_count - self._checkpoint_step >= every

    def flush_history(self) -> None:
        """Append the history rows not yet in history.csv to it."""
        rows = self.record.history[self._history_written:]
        if rows or not (self.out / "history.csv").is_file():
            append_history(self.out / "history.csv", rows)
        self._history_written = len(self.record.history)

    def _stop_if_asked(self) -> None:
        # Called where the last checkpoint is the state now: a resume retraces the
        # uninterrupted run from here.
        if self._stop is None:
            return
        i = min(self.driver.state.stage_index, len(self.stages) - 1)
        message = (f"interrupted by {self._stop} in stage {i + 1} ({self.stages[i].kind}) at "
                   f"t = {self.solver.time * 1e3:.4f} ms; checkpoint written to "
                   f"{self.checkpoint_path}. Continue with: grainfrac run --resume --out "
                   f"{self.out}")
        log.warning(message)
        raise RunInterrupted(message)

    def _log_progress(self, stage: Stage) -> None:
        """One line: stage, simulated time, how far, cracks, pressures, ETA of the stage."""
        self._last_log = now = wallclock.monotonic()
        i = self.stages.index(stage)
        fraction = stage.fraction()
        spent = now - self._stage_wall_start
        eta = f"{spent * (1 - fraction) / fraction:.0f} s" if 0 < fraction < 1 else "-"
        w = self.world
        log.info("stage %d/%d %s: t = %.4f ms, %.1f %% of the stage, %d cracks, well "
                 "%.3f MPa, SCDA %.2f MPa, step %d, ETA of the stage %s", i + 1,
                 len(self.stages), stage.kind, self.solver.time * 1e3, 100 * fraction,
                 int(w.rock_cracks().sum()), w.well_pressure() / 1e6,
                 w.expansive_pressure() / 1e6, self.solver.step_count, eta)

    def at_end(self) -> None:
        self.checkpoint()

    # -- what is recorded ---------------------------------------------------------------
    def tangential_stress_near_well(self) -> float:
        """Mean hoop stress (Pa, compression positive as in paper Fig. 10e) of the rock
        between one and two well radii from the centre; NaN without a borehole."""
        mesh = self.assembly.mesh
        if not mesh.has_borehole:
            return float("nan")
        if self._near_well is None:
            r = mesh.borehole_radius
            self._near_well = Ring(self._centroids, self.world.rock_model.element_area,
                                   mesh.borehole_center, r, 2 * r)
        return -self._near_well.mean_tangential_stress(self.solver.stress)

    def _record(self, stage: Stage) -> None:
        s, w = self.solver, self.world
        rock = w.rock_cracks()
        modes = np.asarray(s.cracks.mode, dtype=np.int64)[rock]
        injected = w.coupled.state.injected if w.coupled is not None else 0.0
        row = {
            "time_s": s.time,
            "stage": stage.kind,
            "well_pressure_MPa": w.well_pressure() / 1e6,
            "expansive_pressure_MPa": w.expansive_pressure() / 1e6,
            "injected_volume_ml": injected * 1e6,
            "n_cracks": int(rock.sum()),
            "n_tensile": int(np.count_nonzero(modes == 1)),
            "n_shear": int(np.count_nonzero(modes == 2)),
            "tangential_stress_near_well_MPa": self.tangential_stress_near_well() / 1e6,
            "step": s.step_count,
            "time_from_stage_start_s": s.time - stage.state.start_time,
        }
        self.record.history.append(row)
        if self.progress is not None:
            fraction = stage.fraction()
            self.progress(Progress(self.driver.state.stage_index, stage.kind, len(self.stages),
                                   s.time, fraction, row["n_cracks"],
                                   w.well_pressure(), w.expansive_pressure(),
                                   stage_time_s=row["time_from_stage_start_s"],
                                   stage_planned_s=planned_duration(stage),
                                   eta_s=self._eta(fraction)))

    def _eta(self, fraction: float) -> float | None:
        # Wall seconds left in the stage at the wall rate so far (None at 0 or 1).
        if not 0 < fraction < 1:
            return None
        return (wallclock.monotonic() - self._stage_wall_start) * (1 - fraction) / fraction

    def _maybe_snapshot(self, force: bool = False) -> None:
        every = self.scenario.output.snapshot_every_ms * 1e-3
        if force or self.solver.time >= self.record.next_snapshot_time:
            self.write_snapshot()
            self.record.next_snapshot_time = self.solver.time + every

    def write_snapshot(self) -> None:
        s, w = self.solver, self.world
        n, c, m = self.assembly.mesh.n_nodes, w.n_rock_contacts, w.n_rock_elements
        pressure = aperture = None
        if w.coupled is not None:
            pressure = s.contact_pressure[:c]
            aperture = w.coupled.aperture()
        plug = None
        if w.model_kind == SCDA:
            fill = w.scda_fill
            plug = PlugState(fill.node_xy, fill.element_nodes, s.u[n:], s.stress[m:],
                             w.expansive_pressure())
        tau = s.tau[:c] if self.assembly.dimension == 3 else s.tau[:c, 0]
        self.snapshots.write(self.assembly, s.time, s.u[:n], s.stress[:m], s.sigma_n[:c],
                             tau, s.status[:c], pressure=pressure, aperture=aperture,
                             plug=plug)
        self.record.snapshots = list(self.snapshots.entries)

    # -- checkpoints --------------------------------------------------------------------
    def checkpoint(self) -> None:
        """Write every record of the run's state, then history.csv (once the snapshots
        it lists are written)."""
        self.snapshots.wait()
        s, w = self.solver, self.world
        self.record.wall_time_s = self.wall_time()
        self._started = wallclock.monotonic()
        records: dict[str, dict[str, Any]] = {
            "run": asdict(self.record),
            "driver": asdict(self.driver.state),
            "world": {"model_kind": w.model_kind,
                      "injection_start_time": w.injection_start_time},
            "solver": {"time": s.time, "step_count": s.step_count,
                       "allow_failure": s.allow_failure, **s.state_arrays()},
            "solver/loads": {f.name: getattr(s.loads, f.name) for f in fields(s.loads)
                             if isinstance(getattr(s.loads, f.name), np.ndarray)},
            "solver/cracks": _arrays(s.cracks),
        }
        if self.fingerprint is not None:
            records["fingerprint"] = dict(self.fingerprint)
        for i, stage in enumerate(self.stages):
            records[f"stages/{i}"] = {"kind": stage.kind, **asdict(stage.state)}
        if w.coupled is not None:
            records["fluid/state"] = asdict(w.coupled.state)
            records["fluid/history"] = _arrays(w.coupled.history)
            records["fluid/coupling"] = {"base_external": w.coupled.base_external}
            if w.coupled.mouths_open is not None:
                records["fluid/coupling"]["mouths_open"] = w.coupled.mouths_open
            void_a0 = w.coupled.void_initial_aperture  # a copy: read it once
            if void_a0 is not None:
                records["fluid/coupling"]["void_initial_aperture"] = void_a0
        write_checkpoint(self.checkpoint_path, records)
        self.write_history()
        self._last_checkpoint = wallclock.monotonic()
        self._checkpoint_step = s.step_count

    def write_history(self) -> None:
        """Rewrite history.csv (atomically) with every row of the run so far."""
        write_history(self.out / "history.csv", self.record.history)
        self._history_written = len(self.record.history)

    def restore(self) -> None:
        """Continue from the run directory's checkpoint."""
        path = self.checkpoint_path
        if not path.is_file() and (self.out / LEGACY_CHECKPOINT_FILE).is_file():
            path = self.out / LEGACY_CHECKPOINT_FILE  # read_checkpoint says why it cannot
        elif not path.is_file():
            raise GrainfracError(f"nothing to resume: {path} does not exist")
        records = read_checkpoint(path)
        saved_print = records.get("fingerprint")
        if self.fingerprint is not None and saved_print is not None and \
                saved_print.get("scenario_sha256") != self.fingerprint["scenario_sha256"]:
            raise CheckpointError(f"{path} is the checkpoint of another run (scenario "
                                  f"{saved_print.get('scenario')!r}, seed "
                                  f"{saved_print.get('seed')}): not this run's")
        rec = records["run"]
        rec["snapshots"] = [tuple(x) for x in rec["snapshots"]]
        self.record = RunRecord(**rec)
        self.driver.state = DriverState(**records["driver"])
        for i, stage in enumerate(self.stages):
            saved = dict(records.get(f"stages/{i}", {"kind": None}))
            kind = saved.pop("kind")
            if kind != stage.kind:
                raise CheckpointError(f"{path}: stage {i + 1} of the checkpoint is {kind}, the "
                                      f"scenario's is {stage.kind}: not this scenario's run")
            stage.state = type(stage.state)(**saved)
        w = self.world
        world = records["world"]
        w.injection_start_time = world["injection_start_time"]
        if world["model_kind"] == SCDA:
            self.stage("scda").build_plug(w)
            w.solver = MechanicsSolver(w.scda_model, damping=self.scenario.numerics.local_damping,
                                       backend=self.backend)
            w.model_kind = SCDA
        s = w.solver
        solver = records["solver"]
        s.load_state_arrays(solver)
        loads = records["solver/loads"]
        for name, value in loads.items():
            getattr(s.loads, name)[...] = value
        s.time = float(solver["time"])
        s.step_count = int(solver["step_count"])
        s.allow_failure = bool(solver["allow_failure"])
        for name, value in records["solver/cracks"].items():
            setattr(s.cracks, name, value.tolist())
        if "fluid/state" in records:
            # Coupling to the restored mechanics applies the fluid's initial pressures;
            # the saved fluid state, loads and contact pressures then replace them.
            w.coupled = couple_fluid(w, self.scenario.fluid)
            w.coupled.state = FluidState(**records["fluid/state"])
            coupling = records["fluid/coupling"]
            w.coupled.base_external = coupling["base_external"].copy()
            if "mouths_open" in coupling:
                w.coupled.mouths_open = coupling["mouths_open"]
            if "void_initial_aperture" in coupling:  # closure_storage's reference state
                w.coupled.void_initial_aperture = coupling["void_initial_aperture"]
            w.coupled.history = CoupledHistory(
                **{k: v.tolist() for k, v in records["fluid/history"].items()})
            s.loads.external[...] = loads["external"]
            s.contact_pressure[...] = solver["contact_pressure"]
        self.snapshots.entries = list(self.record.snapshots)
        self._checkpoint_step = s.step_count
        # Rows flushed after the checkpoint are dropped: the resumed run makes them again.
        self.write_history()
