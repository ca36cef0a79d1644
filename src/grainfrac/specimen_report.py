"""Summary of a built assembly: counts, achieved mineral fractions, size distribution."""

from __future__ import annotations

from typing import Any

import numpy as np

import grainfrac
from grainfrac.assembly import GrainAssembly
from grainfrac.geometry.statistics import grain_size_distribution


def contact_type_fractions(assembly: GrainAssembly, mask: np.ndarray | None = None
                           ) -> dict[str, float]:
    """Fraction of grain boundaries of each mineral pair (among ``mask`` if given)."""
    pair = assembly.interface_pair if mask is None else assembly.interface_pair[mask]
    counts = np.bincount(pair, minlength=len(assembly.pair_names)).astype(float)
    total = counts.sum()
    return {n: (float(c / total) if total else 0.0)
            for n, c in zip(assembly.pair_names, counts, strict=True)}


def specimen_summary(assembly: GrainAssembly, wall_time_s: float | None = None) -> dict[str, Any]:
    """Scalar description of an assembly, with the summary key names of docs/outputs.md."""
    mesh = assembly.mesh
    achieved = assembly.volume_fractions()
    return {
        "grainfrac_version": grainfrac.__version__,
        "seed": assembly.seed,
        "wall_time_s": wall_time_s,
        "specimen": mesh.grains.outline.kind,
        "rock": assembly.recipe.name,
        "n_grains": assembly.n_grains,
        "n_elements": mesh.n_elements,
        "n_nodes": mesh.n_nodes,
        "n_contacts": mesh.n_contacts,
        "n_interfaces": mesh.n_interfaces,
        "n_fissures": int(assembly.interface_fissure.sum()),
        "fissure_fraction": float(assembly.interface_fissure.mean()),
        "n_fluid_nodes": len(mesh.fluid_node_xy),
        "n_pipes": len(mesh.pipe_nodes),
        "min_element_angle_deg": float(mesh.element_min_angles().min()),
        "volume_percent": {
            name: {"target": float(100 * t), "achieved": float(100 * a)}
            for name, t, a in zip(assembly.mineral_table.names,
                                  assembly.mineral_table.volume_fraction, achieved, strict=True)
        },
        "contact_fraction_total": contact_type_fractions(assembly),
        "size_distribution": grain_size_distribution(mesh.grains),
    }
