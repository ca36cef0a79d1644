"""The paper's measures recomputed from a run directory alone (CSV + resolved config).

A researcher can analyse any run, on any machine, with other parameters (a
different circle radius for counting radial fractures, say) without re-running
it: everything here reads only ``history.csv``, ``cracks.csv`` and
``config.toml``.
"""

from __future__ import annotations

import csv
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from grainfrac.analysis.breakdown import breakdown_summary
from grainfrac.analysis.fractures import (
    CONNECT_FACTOR,
    energy_split,
    fracture_summary,
    radial_fractures,
)
from grainfrac.errors import GrainfracError
from grainfrac.units import MM


def read_csv_columns(path: Path) -> dict[str, list[str]]:
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    return {k: [r[k] for r in rows] for k in (rows[0].keys() if rows else [])}


def analyse_run(path: str | Path, *, radius_mm: float | None = None,
                more_radii_mm: Sequence[float] = ()) -> dict[str, Any]:
    """Breakdown, crack and fracture measures of a run directory.

    Parameters
    ----------
    path
        Run directory (config.toml, history.csv, cracks.csv).
    radius_mm
        Circle for counting radial fractures (default 2 x borehole radius).
    more_radii_mm
        Further circles (mm). ``n_radial_fractures_by_radius_mm`` holds the count at
        every circle, keyed like ``"8"`` (the default circle as ``"default"``).
    """
    path = Path(path)
    try:
        config = tomllib.loads((path / "config.toml").read_text())
        history = read_csv_columns(path / "history.csv")
        cracks = read_csv_columns(path / "cracks.csv")
    except FileNotFoundError as exc:
        raise GrainfracError(f"{path} is not a run directory: {exc.filename} missing") from None
    specimen = config.get("specimen", {})
    well_radius = 0.5 * specimen.get("borehole_diameter_mm", 0.0) * MM
    for r in ([] if radius_mm is None else [radius_mm]) + list(more_radii_mm):
        if not r * MM > well_radius:
            raise GrainfracError(
                f"radius_mm: the counting circle must lie outside the borehole, > "
                f"{well_radius / MM:g} mm (got {r:g})")
    zone = config.get("grains", {}).get("zone_size_mm", 2.0) * MM

    out: dict[str, Any] = {"breakdown_pressure_MPa": None, "breakdown_time_s": None,
                           "breakdown_drop_1ms_fraction": None}
    stage = np.array(history.get("stage", []))
    inject = stage == "inject"
    if inject.any():
        times = np.array(history["time_s"], dtype=float)
        first = int(np.argmax(inject))
        # Injection starts where the previous stage ended (rows are written after a step).
        start = times[first - 1] if first > 0 else 0.0
        p = np.array(history["well_pressure_MPa"], dtype=float)[inject] * 1e6
        out.update(breakdown_summary(times[inject] - start, p))
    scda = stage == "scda"
    out["peak_expansive_pressure_MPa"] = (
        float(np.max(np.array(history["expansive_pressure_MPa"], dtype=float)[scda]))
        if scda.any() else None)

    x = np.array(cracks.get("x_mm", []), dtype=float) * MM
    y = np.array(cracks.get("y_mm", []), dtype=float) * MM
    mode = np.array(cracks.get("mode", []), dtype=object)
    energy = np.array(cracks.get("energy_J", []), dtype=float)
    out.update(fracture_summary(
        x, y, mode, energy, center=(0.0, 0.0), well_radius=well_radius,
        connect_distance=CONNECT_FACTOR * zone,
        radius=None if radius_mm is None else radius_mm * MM,
    ))
    out.update(energy_split(mode, energy))
    by_radius = {"default" if radius_mm is None else f"{radius_mm:g}":
                 out["n_radial_fractures"]}
    for r in more_radii_mm:
        by_radius[f"{r:g}"] = radial_fractures(
            x, y, (0.0, 0.0), well_radius=well_radius,
            connect_distance=CONNECT_FACTOR * zone, radius=r * MM).count
    out["n_radial_fractures_by_radius_mm"] = by_radius
    pairs, counts = np.unique(np.array(cracks.get("contact_type", []), dtype=str),
                              return_counts=True)
    total = counts.sum()
    out["contact_fraction_failed"] = {str(k): float(c / total)
                                      for k, c in zip(pairs, counts, strict=True)}
    if "tangential_stress_near_well_MPa" in history:
        hoop = np.array(history["tangential_stress_near_well_MPa"], dtype=float)
        out["tangential_stress_near_well_MPa"] = {
            "first": float(hoop[0]), "last": float(hoop[-1]),
            "min": float(np.nanmin(hoop)), "max": float(np.nanmax(hoop)),
        }
    return out
