"""Run-directory tables: history.csv and cracks.csv (docs/outputs.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grainfrac.io.files import write_csv

HISTORY_COLUMNS = ["time_s", "stage", "well_pressure_MPa", "expansive_pressure_MPa",
                   "injected_volume_ml", "n_cracks", "n_tensile", "n_shear",
                   "tangential_stress_near_well_MPa", "step"]
CRACK_COLUMNS = ["time_s", "x_mm", "y_mm", "mode", "contact_type", "energy_J"]


def write_history(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    return write_csv(path, rows, HISTORY_COLUMNS)


def write_cracks(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    return write_csv(path, rows, CRACK_COLUMNS)
