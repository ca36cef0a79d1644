# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       format_name: percent
# ---

# %% [markdown]
# # grainfrac from Python: run a scenario, load its results, plot them
#
# A notebook in text form (jupytext "percent" format: open it in Jupyter with
# jupytext installed, or in VS Code / Spyder, or run it as a script):
#
#     python examples/api/run_and_plot.py --out runs/api            # the paper's hybrid case
#     python examples/api/run_and_plot.py --out runs/api --smoke    # a small, fast version
#
# It runs the hybrid SCDA-then-HS scenario of `examples/hybrid-case2-90mlmin.toml`
# through the Python API, reads the run directory back (history as a pandas
# DataFrame when pandas is installed, numpy arrays otherwise; the crack catalogue;
# summary.json), recounts the radial fractures at another circle and writes a
# figure. Every file it reads is described in docs/outputs.md.

# %%
from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import grainfrac as gf  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1]

# %% [markdown]
# ## 1. The scenario
#
# `gf.load_scenario` validates a TOML file and resolves its rock recipe; every
# problem is reported before any compute. A scenario is a frozen pydantic model:
# change it with `model_copy(update=...)` or build one from a dict with
# `Scenario.model_validate`. The smoke size cuts the slab to 60 mm and shortens
# every stage so the whole script runs in well under a minute.


# %%
def make_scenario(smoke: bool = False):
    """The hybrid example scenario, or a small version of it (``smoke``)."""
    from grainfrac.scenario import Scenario

    scenario, rock = gf.load_scenario(EXAMPLES / "hybrid-case2-90mlmin.toml")
    if not smoke:
        return scenario, rock
    data = scenario.model_dump()
    data["name"] = "hybrid-smoke"
    data["specimen"].update(width_mm=60.0, height_mm=60.0)
    data["stages"] = [
        {"kind": "equilibrate"},
        {"kind": "scda", "peak_pressure_MPa": 45.0, "max_duration_ms": 10.0},
        {"kind": "drill_out", "relax_steps": 2000, "max_steps": 40000},
        {"kind": "inject", "rate_ml_per_min": 90.0, "duration_ms": 10.0, "time_step_ms": 0.05},
    ]
    data["output"] = {"snapshot_every_ms": 2.0, "checkpoint_every_minutes": 60.0}
    return Scenario.model_validate(data), rock


# %% [markdown]
# ## 2. Run it
#
# `gf.run_scenario` writes the run directory (config.toml, history.csv,
# cracks.csv, snapshots/, figures/, summary.json) and returns the summary.


# %%
def run(out: Path, smoke: bool = False) -> dict:
    scenario, rock = make_scenario(smoke)
    return gf.run_scenario(scenario, rock, out, base_dir=EXAMPLES)


# %% [markdown]
# ## 3. Load the results
#
# history.csv and cracks.csv are plain CSV with units in the column names.


# %%
def read_table(path: Path):
    """A CSV file as a pandas DataFrame if pandas is installed, else a dict of numpy arrays."""
    try:
        import pandas as pd
    except ImportError:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        names = rows[0].keys() if rows else []
        table = {}
        for name in names:
            values = [r[name] for r in rows]
            try:
                table[name] = np.array(values, dtype=float)
            except ValueError:  # text columns: stage, mode, contact_type
                table[name] = np.array(values)
        return table
    return pd.read_csv(path)


def load(out: Path) -> tuple:
    """(history, cracks, summary) of a run directory."""
    history = read_table(out / "history.csv")
    cracks = read_table(out / "cracks.csv")
    summary = json.loads((out / "summary.json").read_text())
    return history, cracks, summary


# %% [markdown]
# ## 4. Plot
#
# Expansive and well pressure against time, and where the cracks are, by mode.


# %%
def plot(out: Path, history, cracks, summary: dict, path: Path) -> Path:
    t_ms = np.asarray(history["time_s"], dtype=float) * 1e3
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax1.plot(t_ms, np.asarray(history["expansive_pressure_MPa"], dtype=float),
             label="SCDA expansive pressure")
    ax1.plot(t_ms, np.asarray(history["well_pressure_MPa"], dtype=float),
             label="well pressure")
    if summary["breakdown_pressure_MPa"] is not None:
        ax1.axhline(summary["breakdown_pressure_MPa"], color="k", ls=":",
                    label=f"breakdown {summary['breakdown_pressure_MPa']:.2f} MPa")
    ax1.set_xlabel("time (ms)")
    ax1.set_ylabel("pressure (MPa)")
    ax1.legend()
    x = np.asarray(cracks["x_mm"], dtype=float)
    y = np.asarray(cracks["y_mm"], dtype=float)
    mode = np.asarray(cracks["mode"]).astype(str)
    for name, colour in (("tensile", "tab:blue"), ("shear", "tab:red")):
        sel = mode == name
        ax2.plot(x[sel], y[sel], ".", color=colour, ms=4, label=f"{name} ({sel.sum()})")
    ax2.set_aspect("equal")
    ax2.set_xlabel("x (mm)")
    ax2.set_ylabel("y (mm)")
    ax2.set_title(f"{summary['n_radial_fractures']} radial fractures at 2 well radii")
    ax2.legend()
    fig.suptitle(f"{summary['scenario']} (seed {summary['seed']})")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


# %% [markdown]
# ## 5. Everything together
#
# `gf.analyse_run` recomputes the measures from the run directory alone, here
# with the radial fractures also counted at 1.6 well radii.


# %%
def main(out: str | Path = "runs/api", smoke: bool = False) -> Path:
    out = Path(out)
    summary = run(out, smoke)
    history, cracks, summary = load(out)
    radius_mm = 1.6 * 0.5 * summary_borehole_mm(out)
    recount = gf.analyse_run(out, more_radii_mm=[radius_mm])
    breakdown = summary["breakdown_pressure_MPa"]
    print(f"{summary['scenario']}: breakdown "
          f"{'none' if breakdown is None else f'{breakdown:.2f} MPa'}, "
          f"{summary['n_cracks']} cracks; radial fractures by counting circle (mm): "
          f"{recount['n_radial_fractures_by_radius_mm']}")
    return plot(out, history, cracks, summary, out / "figures" / "api-example.png")


def summary_borehole_mm(out: Path) -> float:
    """Borehole diameter (mm) from the run's resolved config.toml."""
    import tomllib

    return tomllib.loads((out / "config.toml").read_text())["specimen"]["borehole_diameter_mm"]


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="runs/api", help="run directory")
    parser.add_argument("--smoke", action="store_true", help="small and fast")
    args = parser.parse_args()
    print(f"wrote {main(args.out, args.smoke)}")
