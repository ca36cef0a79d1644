"""Run a scenario into its run directory: the run, then its summary, cracks and figures.

The run itself (stages on the driver, history, snapshots, checkpoints) is
:class:`grainfrac.run.Run`; this layer sits above it and above the analysis, and
turns a finished (or stopped) run into ``cracks.csv``, ``summary.json`` and
``figures/``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import grainfrac
from grainfrac.analysis import breakdown_summary, contact_fractions, fracture_summary
from grainfrac.analysis.fractures import energy_split
from grainfrac.analysis.fractures3d import fracture_summary3d
from grainfrac.io.files import write_json
from grainfrac.io.results import write_cracks
from grainfrac.materials import RockRecipe
from grainfrac.physics.codes import SIGN_CONVENTION, SIGN_CONVENTIONS, code_tables
from grainfrac.physics.cracks import crack_catalogue
from grainfrac.run import Progress, Run, run_directory, run_log, stop_on_signals
from grainfrac.scenario import Scenario, write_resolved
from grainfrac.viz.cracks3d import write_crack_figures3d
from grainfrac.viz.fields import (
    plot_contact_pressure,
    plot_displacement,
    plot_minor_principal_stress,
)
from grainfrac.viz.fractures import plot_fracture_pattern
from grainfrac.viz.pressure import plot_stage_history, plot_well_pressure

log = logging.getLogger(__name__)


def legend(run: Run) -> dict[str, Any]:
    """``legend.json``: the names of the integer codes in the run's files and the sign
    conventions of its quantities (:mod:`grainfrac.physics.codes`, the tables every
    snapshot carries as field data too)."""
    return {
        "codes": code_tables(run.assembly),
        "where": {
            "mineral": "grains*.vtu, grains.vtu (cell data)",
            "contact_type": "contacts.vtu (cell data); cracks.csv and history by name",
            "mode": "contacts*.vtu (cell data); cracks.csv by name",
            "failed": "contacts*.vtu (cell data)",
            "fissure": "contacts.vtu (cell data)",
        },
        "sign_convention": SIGN_CONVENTION,
        "sign_conventions": SIGN_CONVENTIONS,
        "units": "SI in files (m, Pa, s, J) unless the name says otherwise (_MPa, _mm, _ml)",
        "times": "absolute simulated time (s) from the start of the run, except "
                 "breakdown_time_s and breakdown_time_from_injection_s (from the start of "
                 "injection, injection_start_time_s) and the time_from_stage_start_s "
                 "columns (from the start of the row's stage)",
    }


def summarise(run: Run, wall_time_s: float) -> dict[str, Any]:
    """summary.json of a finished (or stopped) run: the keys of docs/outputs.md."""
    a = run.assembly
    s = run.solver
    coupled = run.world.coupled
    rock = run.world.rock_cracks()
    contact = np.asarray(s.cracks.contact, dtype=np.int64)[rock]
    mode = np.asarray(s.cracks.mode, dtype=np.int64)[rock]
    energy = np.asarray(s.cracks.energy, dtype=float)[rock]
    out: dict[str, Any] = {
        "grainfrac_version": grainfrac.__version__,
        "scenario": run.scenario.name,
        "seed": run.scenario.seed,
        "wall_time_s": wall_time_s,
        "sign_convention": SIGN_CONVENTION,
        "dimension": a.dimension,
        "n_grains": a.n_grains,
        "n_elements": a.mesh.n_elements,
        "n_contacts": a.mesh.n_contacts,
        "stages": list(run.scenario.stage_kinds),
        "stage_times_s": run.record.stage_times,
        "breakdown_pressure_MPa": None,
        "breakdown_time_s": None,
        "breakdown_time_from_injection_s": None,
        "breakdown_time_absolute_s": None,
        "injection_start_time_s": None,
        "breakdown_drop_1ms_fraction": None,
        "peak_well_pressure_MPa": None,
        "peak_expansive_pressure_MPa": None,
        "scda_stop_reason": None,
        "injection_stop_reason": None,
        "injected_volume_ml": None,
    }
    if coupled is not None:
        h = coupled.history
        t0 = run.world.injection_start_time or 0.0
        out.update(breakdown_summary(np.asarray(h.time) - t0, np.asarray(h.well_pressure)))
        # breakdown_time_s keeps its meaning (from the start of injection); the two
        # explicit keys say which clock they read.
        out["injection_start_time_s"] = t0
        if out["breakdown_time_s"] is not None:
            out["breakdown_time_from_injection_s"] = out["breakdown_time_s"]
            out["breakdown_time_absolute_s"] = t0 + out["breakdown_time_s"]
        out["peak_well_pressure_MPa"] = float(np.max(h.well_pressure)) / 1e6
        out["injected_volume_ml"] = coupled.state.injected * 1e6
    charge = run.stage("scda")
    if charge is not None:
        out["peak_expansive_pressure_MPa"] = charge.state.peak_pressure / 1e6
        out["scda_stop_reason"] = charge.state.stop_reason
    injections = [st for st in run.stages if st.kind == "inject" and st.state.stop_reason]
    if injections:
        out["injection_stop_reason"] = injections[-1].state.stop_reason
    connect = 1.5 * a.mesh.zone_size
    if a.dimension == 3:
        # The paper counts fractures and measures tortuosity on the top face (Sect. 5.3);
        # the 2D keys read that face, the _top/_mid keys say which plane they read.
        out.update(fracture_summary3d(a, contact, mode, connect_distance=connect))
        out["n_radial_fractures"] = out["n_radial_fractures_top"]
        out["tortuosity"] = out["tortuosity_top"]
        out.update(energy_split(mode, energy))
    else:
        xy = a.mesh.contact_x[contact].reshape(-1, 2)
        out.update(fracture_summary(
            xy[:, 0], xy[:, 1], mode, energy, center=a.mesh.borehole_center,
            well_radius=a.mesh.borehole_radius, connect_distance=connect))
    out["energy_friction_J"] = s.energy_balance()["friction_work"]
    # The mechanics' own books (J): work in (boundary, expansion, fluid), stored,
    # dissipated (damping, friction, bonds released) and the residual.
    out["energy_balance_J"] = s.energy_balance()
    out["warnings"] = []
    if coupled is not None:
        out["hydraulic_energy_J"] = coupled.hydraulic_energy()
        out["warnings"] += hydraulic_energy_warnings(out["hydraulic_energy_J"])
    # Grain boundaries only (paper Fig. 14e): a crack through a quartz grain is no Q-Q contact.
    on_boundary = ~a.contact_view("intragranular")
    pair = a.contact_view("pair")
    total, failed = contact_fractions(pair[on_boundary], pair[contact[on_boundary[contact]]],
                                      a.pair_names)
    out["contact_fraction_total"] = total
    out["contact_fraction_failed"] = failed
    equilibrate = run.stage("equilibrate")
    out["in_situ_unbalanced_force_ratio"] = equilibrate.state.unbalanced_force_ratio
    unsettled = equilibrate.unsettled_warning()
    if unsettled:
        out["warnings"].append(unsettled)
    stage = run.stage("drill_out")
    if stage is not None:
        drill_out = stage.spec
        ratio = stage.state.unbalanced_force_ratio
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
            f"{energy['stored']:.3g} J stored); compare with a smaller inject time_step_ms or "
            "with numerics.fixed_stress_iterations = 8"]


def _plot_final_fields(run: Run, figures: Path) -> None:
    """Displacement, minor principal stress and (with fluid) the pressure in contacts."""
    s = run.solver
    n, m = run.assembly.mesh.n_nodes, run.world.n_rock_elements
    name = run.scenario.name
    plot_displacement(run.assembly, s.u[:n], figures / "displacement.png",
                      title=f"{name}: displacement at the end")
    plot_minor_principal_stress(run.assembly, s.stress[:m], figures / "minor_principal_stress.png",
                                title=f"{name}: minor principal stress at the end")
    if run.world.coupled is not None:
        plot_contact_pressure(run.assembly, s.contact_pressure[:run.world.n_rock_contacts],
                              figures / "fluid_pressure.png",
                              title=f"{name}: fluid pressure in grain boundaries (leak-off)")


def run_scenario(scenario: Scenario, recipe: RockRecipe, out: str | Path, *,
                 base_dir: Path | None = None, resume: bool = False, overwrite: bool = False,
                 progress: Callable[[Progress], None] | None = None,
                 log_every_s: float | None = None) -> dict[str, Any]:
    """Run (or resume) a scenario into ``out``; return the summary.

    Writes fingerprint.json, config.toml (resolved), run.log (a progress line
    every ``log_every_s``, default :data:`grainfrac.run.LOG_EVERY_S`),
    history.csv, cracks.csv, snapshots/, figures/, summary.json and
    checkpoint/state.h5, holding
    ``out/run.lock`` meanwhile (:func:`grainfrac.run.run_directory`: a new run
    needs an empty ``out`` or ``overwrite``; a resumed one, ``out`` of the same
    scenario, seed and version). Raises :class:`~grainfrac.run.RunDirectoryError`
    for a directory it cannot use and :class:`~grainfrac.run.RunFailed` on a
    numerical blow-up (the history, crack catalogue and last good checkpoint stay).
    SIGINT or SIGTERM (in the main thread) stop it at the end of the chunk in
    progress with a checkpoint: :class:`~grainfrac.run.RunInterrupted` says how to
    resume.
    """
    out = Path(out)
    with run_directory(out, scenario, recipe, base_dir=base_dir, resume=resume,
                       overwrite=overwrite) as print_, run_log(out):
        log.info("%s run %r, seed %d, into %s (grainfrac %s, scenario sha256 %s)",
                 "resuming" if resume else "starting", scenario.name, scenario.seed, out,
                 print_["grainfrac_version"], print_["scenario_sha256"][:12])
        if not resume:
            write_resolved(out / "config.toml", scenario, recipe, base_dir)
        run = Run(scenario, recipe, out, base_dir=base_dir, progress=progress,
                  fingerprint=print_)
        if log_every_s is not None:
            run.log_every_s = log_every_s
        write_json(out / "legend.json", legend(run))
        log.info("%d grains, %d elements, %d contacts; stages: %s", run.assembly.n_grains,
                 run.assembly.mesh.n_elements, run.assembly.mesh.n_contacts,
                 ", ".join(scenario.stage_kinds))
        if resume:
            run.restore()
        try:
            with stop_on_signals(run.request_stop):
                run.execute()
        finally:
            run.write_history()
            cat = _rock_crack_catalogue(run)
            write_cracks(out / "cracks.csv", cat.rows(run.assembly.pair_names,
                                                      run.stage_starts()),
                         run.assembly.dimension)
        summary = summarise(run, run.wall_time())
        _plot_run(run, cat, out / "figures")
        write_json(out / "summary.json", summary)
        for warning in summary["warnings"]:
            log.warning("summary: %s", warning)
        log.info("done in %.1f s: %d cracks, breakdown pressure %s MPa; wrote %s",
                 summary["wall_time_s"], summary["n_cracks"],
                 "-" if summary["breakdown_pressure_MPa"] is None
                 else f"{summary['breakdown_pressure_MPa']:.3f}", out / "summary.json")
    return summary


def _rock_crack_catalogue(run: Run):
    rock = run.world.rock_cracks()
    cracks = run.solver.cracks
    return crack_catalogue(run.assembly, np.asarray(cracks.contact)[rock],
                           np.asarray(cracks.time)[rock], np.asarray(cracks.mode)[rock],
                           np.asarray(cracks.energy)[rock])


def _plot_run(run: Run, cat, figures: Path) -> None:
    """Fracture pattern, well pressure (with fluid), pressures by stage, final fields."""
    scenario = run.scenario
    three = run.assembly.dimension == 3
    if not three:
        plot_fracture_pattern(run.assembly, cat.contact, cat.mode, figures / "fractures.png",
                              title=f"{scenario.name} (seed {scenario.seed})")
    coupled = run.world.coupled
    if coupled is not None:
        h = coupled.history
        t0 = run.world.injection_start_time or 0.0
        plot_well_pressure(np.asarray(h.time) - t0, np.asarray(h.well_pressure),
                           np.asarray(h.n_cracks), figures / "well_pressure.png",
                           title=f"{scenario.name}: well pressure")
    plot_stage_history(run.record.history, figures / "pressures.png",
                       title=f"{scenario.name}: pressures and cracks by stage")
    if three:
        write_crack_figures3d(run.assembly, cat.contact, cat.mode, figures,
                              title=f"{scenario.name} (seed {scenario.seed})")
    else:
        _plot_final_fields(run, figures)
