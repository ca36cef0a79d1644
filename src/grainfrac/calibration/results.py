"""Writing a calibration: the recipe, the comparison table, the history (read
back by ``--resume``) and the targets file it was run with.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import tomli_w

from grainfrac import materials
from grainfrac.calibration.bench import no_peak_runs
from grainfrac.calibration.config import FACTORS, MEASURED, REPORTED, CalibrationConfig
from grainfrac.errors import GrainfracError
from grainfrac.io.config import read_toml
from grainfrac.io.files import safe_filename, write_csv, write_json, write_text, write_toml

__all__ = [
    "HELD_OUT_HEADINGS",
    "HISTORY_COLUMNS",
    "LABELS",
    "TABLE_HEADINGS",
    "left_out_notes",
    "read_history",
    "resume_history",
    "table_cells",
    "table_headings",
    "table_rows",
    "write_calibration",
    "write_config",
    "write_history",
]


HISTORY_COLUMNS = ("evaluation", *FACTORS, *MEASURED, "no_peak_runs", "max_error", "wall_time_s")
LABELS = {"ucs_MPa": "UCS (MPa)", "bts_MPa": "BTS (MPa)", "kic_MPa_sqrt_m": "K_IC (MPa m^0.5)",
          "youngs_modulus_GPa": "E (GPa)", "poisson_ratio": "nu",
          "permeability_m2": "permeability (m2)"}


def left_out_notes(result: dict[str, Any]) -> list[str]:
    """One sentence per set of realisations (calibration, held-out) naming the tests
    left out of its means because they found no peak."""
    sets = (("", result["per_seed"]),
            ("held-out ", (result.get("held_out") or {}).get("per_seed", [])))
    return [f"Left out of the {label}means (no peak before the strain limit): "
            + ", ".join(no_peak_runs(runs)) + "." for label, runs in sets if no_peak_runs(runs)]


TABLE_HEADINGS = ("quantity", "laboratory", "simulated (mean)", "error %", "mean 95 % CI",
                  "realisations (min-max)")
HELD_OUT_HEADINGS = ("held-out mean", "held-out error %", "held-out 95 % CI")


def table_headings(result: dict[str, Any]) -> tuple[str, ...]:
    """Column headings of :func:`table_cells`: held-out columns only when measured."""
    return TABLE_HEADINGS + (HELD_OUT_HEADINGS if result.get("held_out") else ())


def table_rows(result: dict[str, Any]) -> list[dict[str, Any]]:
    """Target vs achieved per reported quantity (like paper Table 3), with the
    95 % interval of the mean and the range over the realisations, and the
    mean on the held-out realisations when the config names them."""
    held_out = result.get("held_out")
    rows = []
    for key in REPORTED:
        target = result["targets"][key]
        spread = result.get("spread", {}).get(key, {})
        row = {"quantity": LABELS[key], "laboratory": target,
               "simulated": result["achieved"].get(key),
               "error_percent": _percent(result["errors"].get(key)),
               "mean_ci95_low": spread.get("ci_low"), "mean_ci95_high": spread.get("ci_high"),
               "seed_min": spread.get("min"), "seed_max": spread.get("max")}
        if held_out:
            spread = held_out["spread"].get(key, {})
            row.update({"held_out_mean": held_out["achieved"].get(key),
                        "held_out_error_percent": _percent(held_out["errors"].get(key)),
                        "held_out_ci95_low": spread.get("ci_low"),
                        "held_out_ci95_high": spread.get("ci_high")})
        rows.append(row)
    return rows


def _percent(error: float | None) -> float | None:
    return None if error is None else 100.0 * error


def table_cells(row: dict[str, Any]) -> list[str]:
    """One :func:`table_rows` row as the text cells of :func:`table_headings`."""
    def span(low: float | None, high: float | None) -> str:
        return f"{low:.4g} - {high:.4g}" if low is not None and math.isfinite(low) else "-"

    def number(value: float | None, spec: str) -> str:
        return "-" if value is None else format(value, spec)

    cells = [row["quantity"], f"{row['laboratory']:.4g}", number(row["simulated"], ".4g"),
             number(row["error_percent"], "+.2f"),
             span(row["mean_ci95_low"], row["mean_ci95_high"]),
             span(row["seed_min"], row["seed_max"])]
    if "held_out_mean" in row:
        cells += [number(row["held_out_mean"], ".4g"),
                  number(row["held_out_error_percent"], "+.2f"),
                  span(row["held_out_ci95_low"], row["held_out_ci95_high"])]
    return cells


def write_calibration(result: dict[str, Any], config: CalibrationConfig, out: str | Path,
                      wall_time_s: float) -> dict[str, Path]:
    """Write the calibrated recipe, the target-vs-achieved table and the history."""
    out = Path(out)
    recipe: materials.RockRecipe = result["recipe"]
    # a0 is always solved from the permeability; the other targets only if a factor is paired.
    solved = {*config.pairing().values(), "permeability_m2"}
    matched = ", ".join(LABELS[k] for k in REPORTED if k in solved)
    checked = ", ".join(LABELS[k] for k in REPORTED if k not in solved)
    header = (f"# {recipe.name}: calibrated by grainfrac against {matched}"
              + (f"; {checked} measured, not solved for" if checked else "") + "\n"
              f"# over seeds {config.seeds} at grains {config.grains.min_edge_mm:g}-"
              f"{config.grains.max_edge_mm:g} mm (zone {config.grains.zone_size_mm:g} mm).\n"
              f"# Factors on the start recipe: "
              + ", ".join(f"{k} {v:.4f}" for k, v in result["factors"].items()) + "\n"
              + f"# Mean error on these seeds: {_error_text(result['errors'])}\n")
    if result.get("held_out"):
        header += (f"# Mean error on the held-out seeds {config.validation_seeds}: "
                   f"{_error_text(result['held_out']['errors'])}\n")
    # The name comes from the targets file: as a file name it must not lead out of ``out``.
    recipe_path = write_text(out / f"{safe_filename(recipe.name, 'calibrated-rock')}.toml",
                             header + tomli_w.dumps(recipe.model_dump(mode="json")))
    rows = table_rows(result)
    table_csv = write_csv(out / "table.csv", rows, list(rows[0]))
    headings = table_headings(result)
    lines = ["| " + " | ".join(headings) + " |", "|---" * len(headings) + "|"]
    lines += ["| " + " | ".join(table_cells(r)) + " |" for r in rows]
    lines += [line for note in left_out_notes(result) for line in ("", note)]
    table_md = write_text(out / "table.md", "\n".join(lines) + "\n")
    history = write_history(result["history"], out)
    write_config(config, out)
    summary = {
        "name": recipe.name,
        "converged": result["converged"],
        "factors": result["factors"],
        "initial_aperture_m": result["initial_aperture_m"],
        "targets": result["targets"],
        "achieved": result["achieved"],
        "errors": result["errors"],
        "spread": result.get("spread", {}),
        "evaluations": len(result["history"]),
        "seeds": config.seeds,
        "validation_seeds": config.validation_seeds,
        "held_out": result.get("held_out"),
        "wall_time_s": wall_time_s,
        "per_seed": result["per_seed"],
        "no_peak": no_peak_runs(result["per_seed"]),
        "held_out_no_peak": no_peak_runs((result.get("held_out") or {}).get("per_seed", [])),
    }
    write_json(out / "summary.json", summary)
    return {"recipe": recipe_path, "table_csv": table_csv, "table_md": table_md,
            "history": history}


def _error_text(errors: dict[str, float]) -> str:
    return ", ".join(f"{LABELS[k].split(' (')[0]} {100 * e:+.1f} %" for k, e in errors.items())


def write_history(history: list[dict[str, Any]], out: str | Path) -> Path:
    """Write ``out/history.csv`` (one row per evaluation), atomically."""
    return write_csv(Path(out) / "history.csv",
                     [{k: row.get(k) for k in HISTORY_COLUMNS} for row in history],
                     list(HISTORY_COLUMNS))


def read_history(path: str | Path) -> list[dict[str, Any]]:
    """Rows of a ``history.csv`` written by :func:`write_history` (numbers as floats)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    # A factor added since the history was written was 1 throughout it.
    missing = sorted(set(HISTORY_COLUMNS) - set(FACTORS) - set(rows[0])) if rows else []
    if missing:
        raise GrainfracError(f"{path}: not a calibration history (columns {missing} missing)")
    return [{**dict.fromkeys(FACTORS, 1.0),
             **{k: (float(v) if v not in ("", None) else None) for k, v in row.items()}}
            for row in rows]


def write_config(config: CalibrationConfig, out: str | Path) -> Path:
    """Write the resolved calibration config to ``out/config.toml`` (resume checks it)."""
    return write_toml(Path(out) / "config.toml", config.model_dump(mode="json", exclude_none=True))


def resume_history(config: CalibrationConfig, out: str | Path) -> list[dict[str, Any]]:
    """The history of the interrupted calibration in ``out``, checked to be of ``config``."""
    out = Path(out)
    history, written = out / "history.csv", out / "config.toml"
    if not history.exists() or not written.exists():
        raise GrainfracError(f"--resume: {out} holds no calibration to continue "
                             f"(history.csv and config.toml are needed)")
    before = read_toml(written)
    now = config.model_dump(mode="json", exclude_none=True)
    changed = sorted(k for k in before.keys() | now.keys() if before.get(k) != now.get(k))
    if changed:
        raise GrainfracError(f"--resume: {out} was calibrated with a different targets file "
                             f"(differs in {', '.join(changed)}); use another --out")
    return read_history(history)
