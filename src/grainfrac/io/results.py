"""Run-directory tables: history.csv and cracks.csv (docs/outputs.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grainfrac.io.files import write_csv

HISTORY_COLUMNS = ["time_s", "stage", "well_pressure_MPa", "expansive_pressure_MPa",
                   "injected_volume_ml", "n_cracks", "n_tensile", "n_shear",
                   "tangential_stress_near_well_MPa", "step", "time_from_stage_start_s"]
CRACK_COLUMNS = ["time_s", "x_mm", "y_mm", "mode", "contact_type", "energy_J",
                 "contact", "stage", "time_from_stage_start_s", "normal_x", "normal_y",
                 "normal_angle_deg", "length_mm", "grain_a", "grain_b"]
# 3D runs add these (length_mm is then empty: a 3D sub-contact has an area).
CRACK_COLUMNS_3D = ["z_mm", "normal_z", "area_mm2"]


def write_history(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    return write_csv(path, rows, HISTORY_COLUMNS)


def append_history(path: str | Path, rows: list[dict[str, Any]]) -> Path:
    """Append ``rows`` to history.csv (with its header if the file is new) and flush
    them to the disk: a run killed later keeps them."""
    import csv
    import os

    path = Path(path)
    new = not path.is_file()
    with open(path, "a", encoding="utf-8", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=HISTORY_COLUMNS, lineterminator="\n")
        if new:
            writer.writeheader()
        writer.writerows(rows)
        f.flush()
        os.fsync(f.fileno())
    return path


def write_cracks(path: str | Path, rows: list[dict[str, Any]], dimension: int = 2) -> Path:
    return write_csv(path, rows, CRACK_COLUMNS + (CRACK_COLUMNS_3D if dimension == 3 else []))
