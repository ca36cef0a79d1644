"""The ``grainfrac`` command line. Library code raises; only this module exits."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

import grainfrac
from grainfrac.errors import GrainfracError

app = typer.Typer(
    help="Grain-scale hydro-mechanical fracturing of crystalline rock.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)


def _fail(exc: Exception) -> None:
    if isinstance(exc, OSError) and exc.strerror:
        # An OS error that no layer below turned into a GrainfracError: one line
        # (what, where), never a traceback.
        where = f": {exc.filename}" if exc.filename else ""
        text = f"{exc.strerror}{where}"
    else:
        text = str(exc)
    # The text may hold user input ("[/]" in a key): never read as markup.
    err_console.print(f"[bold red]error:[/] {escape(text)}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


@app.callback()
def _options(
    threads: Annotated[str | None, typer.Option(
        "--threads", help="CPU threads of the explicit step: a number or 'all' (default 1, "
        "or $GRAINFRAC_THREADS). Results are the same on any number; more threads help a "
        "large model on a machine of its own, not runs that share the cores.")] = None,
    backend: Annotated[str | None, typer.Option(
        "--backend", help="Where the explicit step runs: 'cpu' (numba) or 'cuda' (an NVIDIA "
        "GPU; same results to round-off). Overrides a scenario's numerics.backend "
        "(default: the scenario's, else cpu; or $GRAINFRAC_BACKEND).")] = None,
) -> None:
    """Grain-scale hydro-mechanical fracturing of crystalline rock."""
    if threads is None and backend is None:
        return  # numba is not imported for commands that do not step
    import os

    from grainfrac.physics.solver import BACKEND_VARIABLE, resolve_backend
    from grainfrac.threads import THREADS_VARIABLE, default_threads

    if threads is not None:
        os.environ[THREADS_VARIABLE] = threads
        try:
            default_threads()  # checks the value before any compute
        except ValueError as exc:
            _fail(ValueError(f"--threads: {exc}".replace(f"{THREADS_VARIABLE} ", "")))
    if backend is not None:
        os.environ[BACKEND_VARIABLE] = backend
        try:
            resolve_backend()  # checks the value (and the GPU) before any compute
        except GrainfracError as exc:
            _fail(GrainfracError(f"--backend: {exc}"))


@app.command()
def version() -> None:
    """Print the grainfrac version."""
    console.print(grainfrac.__version__)


@app.command()
def presets() -> None:
    """List the rock and SCDA presets."""
    from grainfrac import materials

    console.print("rock:", ", ".join(materials.preset_names("rock")))
    console.print("scda:", ", ".join(materials.preset_names("scda")))


@app.command()
def specimen(
    spec: Annotated[Path, typer.Argument(help="Specimen TOML (shape, grains, rock, fissures).")],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")],
    seed: Annotated[int | None, typer.Option(help="Override the seed in the file.")] = None,
    mesh: Annotated[bool, typer.Option(help="Draw element edges in the PNG.")] = True,
) -> None:
    """Build a grain assembly; write .vtu files, a PNG and a summary."""
    from grainfrac.assembly import build_assembly, load_specimen_config
    from grainfrac.io.files import write_json, write_toml
    from grainfrac.io.vtk import write_assembly
    from grainfrac.specimen_report import specimen_summary
    from grainfrac.viz.specimen import plot_assembly

    try:
        from grainfrac.scenario import check_size

        config, recipe = load_specimen_config(spec)
        if seed is not None:
            config = config.model_copy(update={"seed": seed})
        check_size(config)
        start = time.perf_counter()
        with console.status("tessellating and meshing..."):
            assembly = build_assembly(config, recipe)
        wall = time.perf_counter() - start
        resolved = config.model_dump(mode="json")
        resolved["rock"] = recipe.model_dump(mode="json")
        if assembly.dimension == 3:
            from grainfrac.specimen_report import specimen_summary3d
            from grainfrac.viz.specimen import plot_assembly3d

            summary = specimen_summary3d(assembly, wall_time_s=wall)
            write_toml(out / "specimen.toml", resolved)
            write_assembly(assembly, out)
            plot_assembly3d(assembly, out / "specimen.png",
                            title=f"3D {summary['specimen']} - {recipe.name} - seed {config.seed}")
        else:
            summary = specimen_summary(assembly, wall_time_s=wall)
            write_toml(out / "specimen.toml", resolved)
            write_assembly(assembly, out)
            plot_assembly(assembly, out / "specimen.png", show_mesh=mesh,
                          title=f"{summary['specimen']} - {recipe.name} - seed {config.seed}")
        write_json(out / "summary.json", summary)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    _print_specimen_summary(summary, out)


def _print_specimen_summary(summary: dict, out: Path) -> None:
    counts = Table(title=f"{summary['specimen']} assembly ({summary['rock']}, "
                         f"seed {summary['seed']}, built in {summary['wall_time_s']:.2f} s)")
    counts.add_column("quantity")
    counts.add_column("value", justify="right")
    for key in ("n_grains", "n_elements", "n_nodes", "n_contacts", "n_interfaces",
                "n_fissures", "n_fluid_nodes", "n_pipes"):
        counts.add_row(key.removeprefix("n_").replace("_", " "), str(summary[key]))
    if summary.get("dimension") == 3:
        from grainfrac.specimen_report import quality_rows3d

        for label, value in quality_rows3d(summary):
            counts.add_row(label, value)
    else:
        counts.add_row("min element angle (deg)", f"{summary['min_element_angle_deg']:.1f}")
    console.print(counts)

    minerals = Table(title="mineral volume fractions")
    for col in ("mineral", "target %", "achieved %", "difference (pp)"):
        minerals.add_column(col, justify="right" if col != "mineral" else "left")
    for name, v in summary["volume_percent"].items():
        minerals.add_row(name, f"{v['target']:.2f}", f"{v['achieved']:.2f}",
                         f"{v['achieved'] - v['target']:+.2f}")
    console.print(minerals)

    sizes = Table(title="grain size distribution (mm)")
    sizes.add_column("measure")
    for col in ("count", "p0", "p10", "p50", "p90", "p100", "mean"):
        sizes.add_column(col, justify="right")
    for name, d in summary["size_distribution"].items():
        if d.get("count", 0) == 0:
            continue
        sizes.add_row(name.replace("_", " "), str(d["count"]),
                      *(f"{d[k]:.2f}" for k in ("p0", "p10", "p50", "p90", "p100", "mean")))
    console.print(sizes)
    console.print(f"wrote {out}/grains.vtu, contacts.vtu, specimen.png, specimen.toml, "
                  "summary.json")


@app.command()
def verify(
    name: Annotated[str, typer.Argument(help="Verification case (kirsch, lame, lame3d, ...).")],
    json_rows: Annotated[bool, typer.Option(
        "--json", help="One JSON object per compared quantity instead of a table.")] = False,
    seed: Annotated[int, typer.Option(help="Seed of the grain structure.")] = 0,
    zone_size: Annotated[float | None, typer.Option(
        "--zone-size", min=0.5, max=10.0,
        help="Zone size of the case's mesh (mm), for the cases built on one zone size "
             "(kirsch, lame, patch3d, lame3d, kirsch3d, kirsch3d-plane-strain, penny); "
             "default: the case's own.")] = None,
    wall_zone_size: Annotated[float | None, typer.Option(
        "--wall-zone-size", min=0.2, max=10.0,
        help="Zone size on the borehole wall (mm), refined over 5 mm beside it "
             "(kirsch3d, kirsch3d-plane-strain); default: kirsch3d 1 mm (or the zone "
             "size if finer), kirsch3d-plane-strain the zone size.")] = None,
    equilibrium: Annotated[str | None, typer.Option(
        "--equilibrium",
        help="How the elastic cases (kirsch, lame, patch3d, lame3d, kirsch3d, "
             "kirsch3d-plane-strain) reach equilibrium: 'static' (a sparse solve, then "
             "explicit steps while the unbalanced-force ratio is above its target; the "
             "default) or 'explicit' (dynamic relaxation alone).")] = None,
) -> None:
    """Compare a simulation with its analytical solution; exit 1 if any quantity fails."""
    import inspect
    import json

    from grainfrac.verification import CASES, all_passed, comparison_table

    if name not in CASES:
        _fail(ValueError(f"unknown verification case {name!r}; known: {', '.join(CASES)}"))
    options: dict[str, float] = {"seed": seed}
    if zone_size is not None:
        if "zone_size_mm" not in inspect.signature(CASES[name]).parameters:
            _fail(ValueError(f"--zone-size: the case {name!r} does not take a zone size"))
        options["zone_size_mm"] = zone_size
    if wall_zone_size is not None:
        if "wall_zone_size_mm" not in inspect.signature(CASES[name]).parameters:
            _fail(ValueError(f"--wall-zone-size: the case {name!r} does not refine its wall"))
        options["wall_zone_size_mm"] = wall_zone_size
    if equilibrium is not None:
        if equilibrium not in ("static", "explicit"):
            _fail(ValueError(f"--equilibrium must be 'static' or 'explicit', got "
                             f"{equilibrium!r}"))
        if "equilibrium" not in inspect.signature(CASES[name]).parameters:
            _fail(ValueError(f"--equilibrium: the case {name!r} has no elastic equilibrium "
                             "to choose"))
        options["equilibrium"] = equilibrium
    start = time.perf_counter()
    try:
        if json_rows:
            comparisons = CASES[name](**options)
        else:
            with console.status(f"running verification case {name}..."):
                comparisons = CASES[name](**options)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    wall = time.perf_counter() - start
    if json_rows:
        for c in comparisons:
            typer.echo(json.dumps(c.as_row()))
    else:
        zones = "" if zone_size is None else f", {zone_size:g} mm zones"
        if wall_zone_size is not None:
            zones += f", {wall_zone_size:g} mm at the wall"
        console.print(comparison_table(
            comparisons, title=f"verification: {name} (seed {seed}{zones}, {wall:.1f} s)"))
    raise typer.Exit(code=0 if all_passed(comparisons) else 1)


@app.command()
def run(
    scenario: Annotated[Path | None, typer.Argument(help="Scenario TOML (stages, stress, rock).")
                        ] = None,
    out: Annotated[Path, typer.Option("--out", help="Run directory.")] = Path("run"),
    seed: Annotated[int | None, typer.Option(help="Override the scenario's seed.")] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue the run in --out from its "
                                         "last checkpoint (a SCENARIO or --seed given with it "
                                         "must be the run's).")] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Clear --out first if it "
                                            "holds an earlier run.")] = False,
) -> None:
    """Run a scenario's stages into a run directory (config, history, cracks, snapshots).

    --out must be new or empty (or --overwrite); one process at a time writes it."""
    from grainfrac.runner import run_with_progress

    if scenario is None and not resume:
        _fail(ValueError("give a SCENARIO file, or --resume with --out DIR"))
    if resume and overwrite:
        _fail(ValueError("--resume continues the run in --out, --overwrite clears it: "
                         "give one of them"))
    from grainfrac.run import RunInterrupted

    try:
        summary = run_with_progress(scenario, out, seed=seed, resume=resume,
                                    overwrite=overwrite, console=console)
    except RunInterrupted as exc:
        err_console.print(f"[bold yellow]stopped:[/] {escape(str(exc))}", highlight=False,
                          soft_wrap=True)
        raise typer.Exit(code=130) from None  # the shell's code for an interrupted command
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    _print_run_summary({out.name: summary})
    console.print(f"wrote {out}/ (summary.json, history.csv, cracks.csv, snapshots/, figures/)")


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", help="Directory for the two runs.")] = Path("demo"),
    seed: Annotated[int, typer.Option(help="Grain structure seed (same for both runs).")] = 0,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Clear the two run "
                                            "directories first if they hold earlier runs.")
                         ] = False,
) -> None:
    """HS-only vs hybrid SCDA-HS on the default slab, stress Case 2, 90 ml/min (paper Fig. 17)."""
    from grainfrac.runner import run_demo

    try:
        results = run_demo(out, seed=seed, console=console, overwrite=overwrite)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    _print_run_summary(results)
    hs, hy = results["hs-only"], results["hybrid"]
    if hs["breakdown_pressure_MPa"] and hy["breakdown_pressure_MPa"]:
        console.print(
            f"breakdown pressure: HS-only {hs['breakdown_pressure_MPa']:.2f} MPa, hybrid "
            f"{hy['breakdown_pressure_MPa']:.2f} MPa; radial fractures: HS-only "
            f"{hs['n_radial_fractures']}, hybrid {hy['n_radial_fractures']}")
    from grainfrac.viz.report import build_report

    report_path = build_report([out / "hs-only", out / "hybrid"], out / "report.html")
    console.print(f"wrote {out}/hs-only, {out}/hybrid (figures/ in each) and {report_path}")


def _fmt(value, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def _print_run_summary(results: dict[str, dict]) -> None:
    table = Table(title="run summary")
    table.add_column("quantity")
    for name in results:
        table.add_column(name, justify="right")
    rows = [
        ("breakdown pressure (MPa)", "breakdown_pressure_MPa", ".2f"),
        ("peak expansive pressure (MPa)", "peak_expansive_pressure_MPa", ".1f"),
        ("SCDA stopped by", "scda_stop_reason", "s"),
        ("radial fractures", "n_radial_fractures", "d"),
        ("fracture extent (mm)", "fracture_extent_mm", ".1f"),
        ("cracks (tensile / shear)", None, None),
        ("tortuosity", "tortuosity", ".3f"),
        ("injected volume (ml)", "injected_volume_ml", ".4f"),
        ("wall time (s)", "wall_time_s", ".1f"),
    ]
    for label, key, spec in rows:
        if key is None:
            cells = [f"{r['n_cracks']} ({r['n_tensile_cracks']} / {r['n_shear_cracks']})"
                     for r in results.values()]
        else:
            cells = [_fmt(r.get(key), spec) for r in results.values()]
        table.add_row(label, *cells)
    console.print(table)
    for name, r in results.items():
        for warning in r.get("warnings", []):
            console.print(f"[yellow]warning ({name}): {warning}[/yellow]")


@app.command()
def labtest(
    test: Annotated[str, typer.Argument(help="ucs, bts, nscb or permeability.")],
    out: Annotated[Path, typer.Option("--out", help="Run directory.")],
    rock: Annotated[str | None, typer.Option(
        "--rock", help="Rock preset name or recipe TOML (default strathbogie-granite).")] = None,
    config: Annotated[Path | None, typer.Option(
        "--config", help="Lab-test TOML (specimen, grains, loading); flags override it.")] = None,
    seed: Annotated[int | None, typer.Option(help="Seed of the grain structure.")] = None,
    dim: Annotated[int | None, typer.Option(
        "--dim", help="2 (plane-strain section, default) or 3 (the specimen as a solid).")
                   ] = None,
) -> None:
    """A virtual laboratory test (paper Table 3): curve, crack pattern, summary.json."""
    from grainfrac.labtests import TEST_KINDS, load_lab_test_config
    from grainfrac.labtests.config import lab_test_config

    if test not in TEST_KINDS:
        _fail(ValueError(f"unknown lab test {test!r}; known: {', '.join(TEST_KINDS)}"))
    try:
        overrides = {"test": test, "rock": rock, "seed": seed, "dimension": dim}
        if config is not None:
            cfg = load_lab_test_config(config, **overrides)
        else:
            cfg = lab_test_config(**{k: v for k, v in overrides.items() if v is not None})
        recipe = cfg.recipe(config.parent if config is not None else Path.cwd())
        summary = _run_labtest_with_progress(cfg, recipe, out)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    table = Table(title=f"{test.upper()} {cfg.run_name} ({recipe.name})")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for key in ("ucs_MPa", "youngs_modulus_GPa", "poisson_ratio", "bts_MPa", "kic_MPa_sqrt_m",
                "permeability_m2", "n_grains", "n_cracks", "stop_reason", "wall_time_s"):
        if key in summary:
            value = summary[key]
            table.add_row(key, f"{value:.4g}" if isinstance(value, float) else str(value))
    console.print(table)
    if summary.get("peak_found") is False:
        err_console.print(f"[bold yellow]no peak:[/] the load never fell "
                          f"{100 * cfg.resolved_loading.peak_drop_fraction:g} % below its "
                          "maximum, so the values above are read at the largest load, not at "
                          "failure (the calibration leaves such a test out of its means)",
                          highlight=False, soft_wrap=True)
    console.print(f"wrote {out}/ (summary.json, config.toml"
                  + (", curve.csv, cracks.csv, figures/)" if test != "permeability" else ")"))


def _run_labtest_with_progress(cfg, recipe, out: Path) -> dict:
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from grainfrac.labtests import run_labtest

    if cfg.test == "permeability":
        with console.status("constant-head test..."):
            return run_labtest(cfg, out, recipe=recipe)
    columns = (TextColumn("[bold]{task.description}"), BarColumn(),
               TextColumn("{task.fields[load]}"), TimeElapsedColumn())
    with Progress(*columns, console=console, transient=True) as bar:
        task = bar.add_task(cfg.test.upper(), total=None, load="")

        def show(curve) -> None:
            if len(curve.load) % 10 == 0:
                bar.update(task, load=f"load {curve.load[-1] / 1e3:.2f} kN (peak "
                           f"{max(curve.load) / 1e3:.2f}), {curve.n_cracks[-1]} cracks")

        return run_labtest(cfg, out, recipe=recipe, progress=show)


@app.command()
def calibrate(
    targets: Annotated[Path, typer.Argument(help="TARGETS.toml: start rock, lab targets, seeds.")],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("calibration"),
    resume: Annotated[bool, typer.Option(
        "--resume", help="Continue the interrupted calibration in --out from its history.csv.",
    )] = False,
) -> None:
    """Fit micro-parameters to lab targets with the virtual UCS/BTS/NSCB/permeability tests.

    Every evaluation is appended to OUT/history.csv as it finishes; an
    interrupted calibration continues with --resume (the evaluations done are
    read back, not run again)."""
    from grainfrac import calibration

    start = time.perf_counter()
    saved: list[int] = []

    def checkpoint(rows: list[dict]) -> None:
        calibration.write_history(rows, out)
        saved.append(len(rows))

    try:
        config, recipe = calibration.load_calibration_config(targets)
        replay = calibration.resume_history(config, out) if resume else []
        calibration.write_config(config, out)
        with console.status("calibrating...") as status:
            result = calibration.calibrate(
                config, recipe, log=lambda msg: (console.print(msg), status.update(msg)),
                on_evaluation=checkpoint, replay=replay)
        paths = calibration.write_calibration(result, config, out, time.perf_counter() - start)
    except (GrainfracError, OSError, KeyboardInterrupt) as exc:
        if saved:
            err_console.print(f"stopped after evaluation {saved[-1]}; the evaluations are in "
                              f"{out / 'history.csv'}. Continue with: grainfrac calibrate "
                              f"{targets} --out {out} --resume", highlight=False, soft_wrap=True)
        _fail(GrainfracError("interrupted") if isinstance(exc, KeyboardInterrupt) else exc)
    table = Table(title=f"{config.name}: laboratory vs simulated (mean of seeds {config.seeds})")
    for col in calibration.table_headings(result):
        table.add_column(col, justify="right" if col != "quantity" else "left")
    for row in calibration.table_rows(result):
        table.add_row(*calibration.table_cells(row))
    console.print(table)
    for note in calibration.left_out_notes(result):
        console.print(note)
    console.print(f"{'converged' if result['converged'] else 'NOT converged'} after "
                  f"{len(result['history'])} evaluations in {time.perf_counter() - start:.0f} s; "
                  f"wrote {paths['recipe']} and {paths['table_md']}")


@app.command()
def analyse(
    run_dirs: Annotated[list[Path], typer.Argument(help="One or more run directories.")],
    radius_mm: Annotated[list[float] | None, typer.Option(
        "--radius-mm", help="Circle for counting radial fractures (mm); repeat the option for "
        "several (default: 2 x borehole radius).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of a table.")
                       ] = False,
) -> None:
    """Recompute a finished run's measures from its directory alone (other counting circles)."""
    import json

    from grainfrac.analysis import analyse_run

    radii = radius_mm or []
    results: dict[str, dict] = {}
    try:
        for path in run_dirs:
            results[str(path)] = analyse_run(path, radius_mm=radii[0] if radii else None,
                                             more_radii_mm=radii[1:])
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    if as_json:
        console.print_json(json.dumps(results))
        return
    table = Table(title="run analysis")
    table.add_column("run", overflow="fold")
    table.add_column("breakdown MPa", justify="right")
    table.add_column("cracks T/S", justify="right")
    for r in radii or [None]:
        table.add_column("radial" if r is None else f"radial r={r:g}mm", justify="right")
    table.add_column("extent mm", justify="right")
    for name, a in results.items():
        table.add_row(name, _fmt(a["breakdown_pressure_MPa"]),
                      f"{a['n_tensile_cracks']}/{a['n_shear_cracks']}",
                      *(str(n) for n in a["n_radial_fractures_by_radius_mm"].values()),
                      _fmt(a["fracture_extent_mm"], ".1f"))
    console.print(table)


@app.command()
def report(
    run_dirs: Annotated[list[Path], typer.Argument(help="One or more run directories.")],
    out: Annotated[Path | None, typer.Option("--out", help="HTML file (default: report.html "
                                             "in the run directory, or beside several)")] = None,
) -> None:
    """Self-contained HTML report of runs; with several, a side-by-side comparison."""
    from grainfrac.viz.report import build_report

    if out is None:
        out = (run_dirs[0] / "report.html" if len(run_dirs) == 1
               else run_dirs[0].parent / "report.html")
    try:
        path = build_report(run_dirs, out)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    console.print(f"wrote {path}")


# --------------------------------------------------------------------------- sweeps, studies


@app.command()
def sweep(
    sweep_file: Annotated[Path, typer.Argument(
        help="Sweep TOML: base scenario, parameters to vary, realisations per point.")],
    out: Annotated[Path, typer.Option("--out", help="Sweep directory (runs/, runs.csv, "
                                      "stats.csv, sweep.json).")],
    scheduler: Annotated[str | None, typer.Option(
        "--scheduler", help="Address of a running Dask scheduler, e.g. tcp://host:8786 "
        "(default: a local cluster).")] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Workers of the local cluster (default: one per core).")
    ] = None,
) -> None:
    """Run a parameter sweep / ensemble on Dask; mean, std and 95 % CI per point.

    Runs already done in --out are skipped; exit code 1 if any run failed.
    """
    from grainfrac.studies.progress import sweep_progress, sweep_table
    from grainfrac.studies.sweep import load_sweep, run_sweep

    try:
        plan = load_sweep(sweep_file)
        with sweep_progress(console) as show:
            result = run_sweep(plan, out, scheduler=scheduler, n_workers=workers,
                               progress=show)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    console.print(sweep_table(result))
    console.print(f"{result.computed} run(s) computed, {result.skipped} already done, "
                  f"{len(result.failures)} failed in {result.wall_time_s:.1f} s; wrote "
                  + ", ".join(str(p) for p in result.files))
    for run_dir, error in result.failures.items():
        err_console.print(f"[bold red]failed:[/] {out / run_dir}: {error}", highlight=False,
                          soft_wrap=True)
    if result.failures:
        raise typer.Exit(code=1)


@app.command()
def study(
    name: Annotated[str, typer.Argument(help="Study matrix: paper (all studies of the paper).")],
    out: Annotated[Path, typer.Option("--out", help="Study directory (one sweep per study, "
                                      "report.md, report.html, claims.csv).")],
    realisations: Annotated[int, typer.Option(
        "--realisations", min=1, help="Grain realisations per point (seeds 0..N-1).")] = 10,
    only: Annotated[list[str] | None, typer.Option(
        "--only", help="Run only this study (repeatable): scda-confinement, hs-confinement, "
        "grain-size, fissures, injection-rate, hybrid, lab-hs (in 3D: scda-confinement, "
        "hybrid, lab-hs).")] = None,
    dim: Annotated[list[int] | None, typer.Option(
        "--dim", help="2 (plane-strain studies, default) or 3 (the paper's 3D model on "
        "examples/3d); repeat for both: the report puts their verdicts side by side.")
    ] = None,
    examples: Annotated[Path | None, typer.Option(
        "--examples", help="Directory of the example scenarios (default: the checkout's "
        "examples/).")] = None,
    scheduler: Annotated[str | None, typer.Option(
        "--scheduler", help="Address of a running Dask scheduler (default: a local "
        "cluster).")] = None,
    workers: Annotated[int | None, typer.Option(
        "--workers", min=1, help="Workers of the local cluster (default: one per core).")
    ] = None,
) -> None:
    """Run the paper's study matrix as sweeps and write the reproduction report.

    Runs already done in --out are skipped; exit code 1 if any run failed.
    """
    from grainfrac.studies.progress import sweep_progress
    from grainfrac.studies.study import run_paper_study

    if name != "paper":
        _fail(ValueError(f"unknown study {name!r}; known: paper"))
    try:
        with sweep_progress(console) as show:
            done = run_paper_study(out, realisations=realisations, only=only,
                                   dimensions=tuple(dim or (2,)),
                                   examples=examples, scheduler=scheduler, n_workers=workers,
                                   progress=show)
    except (GrainfracError, OSError) as exc:
        _fail(exc)
    table = Table(title=f"paper claims ({realisations} realisation(s) per point)")
    for col in ("study", "claim", "ours", "verdict"):
        table.add_column(col, overflow="fold")
    colour = {"holds": "green", "does not hold": "red", "inconclusive": "yellow"}
    for o in done.outcomes:
        for v in o.verdicts:
            style = colour.get(v.verdict, "dim")
            table.add_row(o.study.name, v.claim.text, v.estimate,
                          f"[{style}]{v.verdict}[/]")
    console.print(table)
    console.print(f"{done.runs_computed} run(s) computed in {done.wall_time_s:.0f} s; wrote "
                  f"{out}/report.html, report.md, claims.csv and one sweep directory per study")
    for run_dir, error in done.failures.items():
        err_console.print(f"[bold red]failed:[/] {run_dir}: {error}", highlight=False,
                          soft_wrap=True)
    if done.failures:
        raise typer.Exit(code=1)


if __name__ == "__main__":  # pragma: no cover
    app()
