"""Run one virtual lab test into a run directory.

A lab-test run directory holds ``config.toml`` (resolved), ``curve.csv``
(mechanical tests), ``cracks.csv``, ``figures/`` (load curve, crack pattern)
and ``summary.json`` (written last, atomically) with the keys of
docs/outputs.md: ``ucs_MPa``, ``youngs_modulus_GPa``, ``poisson_ratio``, ``bts_MPa``,
``kic_MPa_sqrt_m`` or ``permeability_m2``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from grainfrac import materials
from grainfrac.assembly import GrainAssembly, build_assembly
from grainfrac.io.files import write_csv, write_json, write_toml
from grainfrac.labtests.config import LabTestConfig
from grainfrac.labtests.mechanical import REDUCERS, build_test
from grainfrac.stages.platen import LoadingCurve
from grainfrac.units import MM, MPA

CURVE_COLUMNS = ["time_s", "platen_closure_mm", "load_kN", "n_cracks"]


def _common_summary(config: LabTestConfig, assembly: GrainAssembly) -> dict[str, Any]:
    import grainfrac

    return {
        "grainfrac_version": grainfrac.__version__,
        "test": config.test,
        "name": config.run_name,
        "rock": assembly.recipe.name,
        "seed": config.seed,
        "dimension": assembly.dimension,
        "n_grains": assembly.n_grains,
        "n_elements": assembly.mesh.n_elements,
        "n_contacts": assembly.mesh.n_contacts,
    }


def measure(config: LabTestConfig, *, recipe: materials.RockRecipe | None = None,
            progress: Callable[[LoadingCurve], None] | None = None) -> dict[str, Any]:
    """Run the test in memory; return ``summary`` plus the ``assembly``, ``curve``
    and ``cracks`` (contact, mode) for writing. Nothing is written."""
    recipe = recipe if recipe is not None else config.recipe()
    start = time.perf_counter()
    assembly = build_assembly(config.specimen_config(), recipe)
    summary = _common_summary(config, assembly)
    out: dict[str, Any] = {"assembly": assembly, "curve": None, "cracks": None}
    if config.test == "permeability":
        summary.update(_permeability(config, assembly))
    else:
        test = build_test(config, assembly)
        curve, reason, discarded = test.run(config.resolved_loading, progress)
        summary.update(REDUCERS[config.test](curve, assembly, config))
        s = test.solver
        mode = np.asarray(s.cracks.mode, dtype=np.int64)
        summary.update({
            "n_cracks": len(mode),
            "n_tensile_cracks": int(np.count_nonzero(mode == 1)),
            "n_shear_cracks": int(np.count_nonzero(mode == 2)),
            "platen_speed_mm_per_s": config.platen_speed_mm_per_s,
            "approach_speed_factor": config.resolved_loading.approach_speed_factor,
            "steps": s.step_count,
            "steps_discarded": discarded,
            "stop_reason": reason,
        })
        out["curve"] = curve
        out["cracks"] = (np.asarray(s.cracks.contact, dtype=np.int64), mode,
                         np.asarray(s.cracks.time), np.asarray(s.cracks.energy))
    summary["wall_time_s"] = time.perf_counter() - start
    out["summary"] = summary
    return out


def _permeability(config: LabTestConfig, assembly: GrainAssembly) -> dict[str, Any]:
    """The constant-head test (paper Eq. 8): inlet on top, outlet at the bottom
    (2D: the section's top and bottom; 3D: the cylinder's ends, z+ and z-)."""
    from dataclasses import replace

    from grainfrac.physics import flow

    spec = config.permeability
    a0 = spec.initial_aperture_m or assembly.recipe.hydraulic.initial_aperture_m
    fluid = replace(flow.FluidProperties(), viscosity=spec.viscosity_Pa_s)
    heads = {"pressure_in": spec.pressure_in_MPa * MPA, "pressure_out": spec.pressure_out_MPa * MPA}
    if assembly.dimension == 3:
        from grainfrac.verification.hydraulic3d import measure_permeability3d

        result = measure_permeability3d(assembly.mesh, a0, fluid=fluid, inlet="z+",
                                        outlet="z-", **heads)
        result["height_m"] = result["length_m"]
        extra = ("linear_field_m2",)
    else:
        from grainfrac.verification.hydraulic import measure_permeability

        result = measure_permeability(assembly.mesh, a0, fluid=fluid,
                                      sealed=assembly.contact_intragranular, **heads)
        extra = ("mean_flow_per_width_m2_s", "steps")
    keys = ("permeability_m2", "initial_aperture_m", "flow_rate_m3_s", "outflow_m3_s",
            "area_m2", "height_m", "pressure_drop_Pa") + extra
    return {k: result[k] for k in keys}


def run_labtest(config: LabTestConfig, out: str | Path, *,
                recipe: materials.RockRecipe | None = None,
                progress: Callable[[LoadingCurve], None] | None = None) -> dict[str, Any]:
    """Run a lab test and write its run directory; return the summary."""
    from grainfrac.io.results import write_cracks
    from grainfrac.physics.cracks import crack_catalogue
    from grainfrac.viz.cracks3d import write_crack_figures3d
    from grainfrac.viz.fractures import plot_fracture_pattern

    out = Path(out)
    recipe = recipe if recipe is not None else config.recipe()
    resolved = config.model_dump(mode="json", exclude_none=True)
    resolved["rock"] = recipe.model_dump(mode="json")
    resolved["specimen"] = config.specimen_config().specimen.model_dump(mode="json")
    resolved["loading"] = config.resolved_loading.model_dump(mode="json")
    write_toml(out / "config.toml", resolved)
    result = measure(config, recipe=recipe, progress=progress)
    summary, assembly, curve = result["summary"], result["assembly"], result["curve"]
    if curve is not None:
        contact, mode, times, energy = result["cracks"]
        cat = crack_catalogue(assembly, contact, times, mode, energy)
        write_cracks(out / "cracks.csv", cat.rows(assembly.pair_names, [(config.test, 0.0)]),
                     assembly.dimension)
        _write_curve(out, config, curve, summary)
        title = f"{config.test.upper()} {config.run_name}: {summary['n_cracks']} cracks at the end"
        if assembly.dimension == 3:
            write_crack_figures3d(assembly, contact, mode, out / "figures", title=title)
        else:
            plot_fracture_pattern(assembly, contact, mode, out / "figures" / "cracks.png",
                                  title=title)
    write_json(out / "summary.json", summary)
    return summary


def _write_curve(out: Path, config: LabTestConfig, curve: LoadingCurve,
                 summary: dict[str, Any]) -> None:
    from grainfrac.viz.labcurves import plot_load_curve

    closure_mm = curve.array("closure") / MM
    load_kn = curve.array("load") / 1e3
    rows = [{"time_s": t, "platen_closure_mm": c, "load_kN": f, "n_cracks": n}
            for t, c, f, n in zip(curve.time, closure_mm, load_kn, curve.n_cracks, strict=True)]
    columns = list(CURVE_COLUMNS)
    for name, values in curve.extra.items():
        columns.append(name)
        for row, v in zip(rows, values, strict=True):
            row[name] = v
    peak = summary["peak_index"]
    figure = out / "figures" / "curve.png"
    if config.test == "ucs":
        eps = curve.array("axial_strain") * 100
        stress = curve.array("load") / summary["loaded_area_m2"] / MPA
        for row, s in zip(rows, stress, strict=True):
            row["axial_stress_MPa"] = s
        columns.append("axial_stress_MPa")
        plot_load_curve(eps, stress, figure, xlabel="axial strain (%)",
                        ylabel="axial stress (MPa)", peak_index=peak,
                        peak_label=f"UCS {summary['ucs_MPa']:.1f} MPa, "
                                   f"E {summary['youngs_modulus_GPa']:.1f} GPa",
                        title=f"UCS {config.run_name}",
                        secondary=(curve.array("n_cracks"), "cracks"))
    else:
        label = (f"BTS {summary['bts_MPa']:.2f} MPa" if config.test == "bts"
                 else f"K_IC {summary['kic_MPa_sqrt_m']:.2f} MPa m$^{{1/2}}$")
        plot_load_curve(closure_mm, load_kn, figure, xlabel="platen displacement (mm)",
                        ylabel="load (kN)", peak_index=peak, peak_label=label,
                        title=f"{config.test.upper()} {config.run_name}",
                        secondary=(curve.array("n_cracks"), "cracks"))
    write_csv(out / "curve.csv", rows, columns)
