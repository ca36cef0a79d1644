"""Summary of a built assembly: counts, achieved mineral fractions, size distribution."""

from __future__ import annotations

from typing import Any

import numpy as np

import grainfrac
from grainfrac.assembly import GrainAssembly
from grainfrac.geometry.node_steps import regular_tetrahedron
from grainfrac.geometry.statistics import grain_size_distribution


def contact_type_fractions(assembly: GrainAssembly, mask: np.ndarray | None = None
                           ) -> dict[str, float]:
    """Fraction of grain boundaries of each mineral pair (among ``mask`` if given)."""
    pair = assembly.interface_pair if mask is None else assembly.interface_pair[mask]
    counts = np.bincount(pair, minlength=len(assembly.pair_names)).astype(float)
    total = counts.sum()
    return {n: (float(c / total) if total else 0.0)
            for n, c in zip(assembly.pair_names, counts, strict=True)}


def _counts(assembly: GrainAssembly) -> dict[str, Any]:
    """Grains, elements, nodes, contacts, grain boundaries and fissures (both dimensions)."""
    mesh = assembly.mesh
    return {
        "n_grains": assembly.n_grains,
        "n_elements": mesh.n_elements,
        "n_nodes": mesh.n_nodes,
        "n_contacts": mesh.n_contacts,
        "n_interfaces": mesh.n_interfaces,
        "n_fissures": int(assembly.interface_fissure.sum()),
        "fissure_fraction": float(assembly.interface_fissure.mean()),
    }


def _volume_percent(assembly: GrainAssembly) -> dict[str, dict[str, float]]:
    """Target and achieved mineral fractions (area in 2D, volume in 3D), percent."""
    table = assembly.mineral_table
    return {name: {"target": float(100 * t), "achieved": float(100 * a)}
            for name, t, a in zip(table.names, table.volume_fraction,
                                  assembly.volume_fractions(), strict=True)}


def specimen_summary(assembly: GrainAssembly, wall_time_s: float | None = None) -> dict[str, Any]:
    """Scalar description of an assembly, with the summary key names of docs/outputs.md."""
    mesh = assembly.mesh
    return {
        "grainfrac_version": grainfrac.__version__,
        "seed": assembly.seed,
        "wall_time_s": wall_time_s,
        "specimen": mesh.grains.outline.kind,
        "rock": assembly.recipe.name,
        **_counts(assembly),
        "n_fluid_nodes": len(mesh.fluid_node_xy),
        "n_pipes": len(mesh.pipe_nodes),
        "min_element_angle_deg": float(mesh.element_min_angles().min()),
        "volume_percent": _volume_percent(assembly),
        "contact_fraction_total": contact_type_fractions(assembly),
        "size_distribution": grain_size_distribution(mesh.grains),
    }


# -- 3D ---------------------------------------------------------------------------------
def _describe(values: np.ndarray) -> dict[str, float]:
    if len(values) == 0:
        return {"count": 0}
    out = {"count": int(len(values)), "mean": float(values.mean())}
    for p, v in zip((0, 10, 50, 90, 100), np.percentile(values, (0, 10, 50, 90, 100)),
                    strict=True):
        out[f"p{p}"] = float(v)
    return out


def grain_size_distribution3d(assembly: GrainAssembly) -> dict[str, dict[str, float]]:
    """Percentiles (mm) of grain equivalent diameter (sphere of the grain's volume) and of
    edge lengths: interior grain edges (held to the bounds) and the exempt rest."""
    cx = assembly.mesh.grains
    diameter = np.cbrt(6.0 * cx.grain_volumes() / np.pi) * 1e3
    _, length, interior = cx.edge_classes()
    return {
        "equivalent_diameter_mm": _describe(diameter),
        "edge_length_mm": _describe(length[interior] * 1e3),
        "surface_or_ring_edge_length_mm": _describe(length[~interior] * 1e3),
    }


def regular_tetrahedron_step(edge: float, youngs_modulus: float, poisson_ratio: float,
                             density: float) -> float:
    """Stable step (s) of one free regular tetrahedron, real mass, the solver's safety."""
    from grainfrac.physics.model import model_from_arrays

    return _grains_only_step(regular_tetrahedron(edge), np.array([[0, 1, 2, 3]]),
                             np.array([youngs_modulus]), np.array([poisson_ratio]),
                             np.array([density]), model_from_arrays)


def _grains_only_step(x, cells, e, nu, rho, model_from_arrays) -> float:
    none = np.zeros(0)
    return model_from_arrays(
        x=x, cells=cells, youngs_modulus=e, poisson_ratio=nu, density=rho,
        contact_nodes=np.zeros((0, 2), dtype=np.int64), contact_frame=np.zeros((0, 3, 3)),
        contact_area=none, normal_stiffness=none, shear_stiffness=none, friction_angle=none,
        cohesion=none, tensile_strength=none, bonded=np.zeros(0, dtype=bool),
        mass_scaling=False).dt


def stable_steps3d(assembly: GrainAssembly) -> dict[str, float]:
    """Stable time steps (s) of a 3D assembly and their ratio to a regular zone-size
    tetrahedron of quartz (recipe table values; the wall's zone size where the zones
    are refined at the borehole).

    ``grains_table`` is the real-mass step of the tetrahedra alone with each mineral
    at its table values (the mesh's own limit where quartz is the fastest mineral,
    as in Table 2), ``grains`` the same with the grains' Weibull-drawn properties (a grain
    drawn stiffer than the table has a shorter step on any mesh), ``with_contacts``
    adds the contact springs (Table 2 stiffnesses), ``run`` is the mass-scaled step a
    simulation uses: a quantile of the nodes' own steps, so that the few nodes of short
    edges and slivers get mass instead of setting every node's step
    (``run_added_mass_fraction``: the mass added over the real mass).
    """
    from grainfrac.physics.model import build_mechanical_model, model_from_arrays

    mesh = assembly.mesh
    mtab = assembly.mineral_table
    q = list(mtab.names).index("quartz") if "quartz" in mtab.names else 0
    ref = regular_tetrahedron_step(mesh.wall_zone_size, float(mtab.youngs_modulus_Pa[q]),
                                   float(mtab.poisson_ratio[q]), float(mtab.density_kg_m3[q]))
    rec = mesh.record()
    mineral = assembly.element_mineral
    table = _grains_only_step(rec.x, rec.cells, mtab.youngs_modulus_Pa[mineral],
                              mtab.poisson_ratio[mineral], mtab.density_kg_m3[mineral],
                              model_from_arrays)
    grains = _grains_only_step(rec.x, rec.cells, assembly.element_youngs_modulus,
                               assembly.element_poisson_ratio, assembly.element_density,
                               model_from_arrays)
    real = build_mechanical_model(assembly, mass_scaling=False).dt
    run = build_mechanical_model(assembly)
    return {"regular_quartz_tet_s": ref, "grains_table_s": table, "grains_s": grains,
            "with_contacts_s": real, "run_mass_scaled_s": run.dt,
            "grains_table_ratio": table / ref, "grains_ratio": grains / ref,
            "with_contacts_ratio": real / ref, "run_ratio": run.dt / ref,
            "run_added_mass_fraction": float(run.mass.sum() / run.real_mass.sum() - 1.0)}


def specimen_summary3d(assembly: GrainAssembly, wall_time_s: float | None = None
                       ) -> dict[str, Any]:
    """Scalar description of a 3D assembly (same keys as 2D where they mean the same)."""
    from grainfrac.geometry.tessellation3d import short_edge_report

    mesh = assembly.mesh
    cx = mesh.grains
    volumes = mesh.element_volumes()
    steps = stable_steps3d(assembly)
    dihedral = mesh.min_dihedral_angles()
    spec_edges = (float(np.min(cx.edge_classes()[1])) * 1e3)
    return {
        "grainfrac_version": grainfrac.__version__,
        "seed": assembly.seed,
        "wall_time_s": wall_time_s,
        "dimension": 3,
        "specimen": cx.solid.kind,
        "size_mm": [float(v) * 1e3 for v in cx.solid.extent],
        "borehole_facets": cx.solid.borehole_facets,
        "zone_size_mm": mesh.zone_size * 1e3,
        "wall_zone_size_mm": mesh.wall_zone_size * 1e3,
        "rock": assembly.recipe.name,
        **_counts(assembly),
        "n_fluid_nodes": mesh.flow.n_nodes,
        "n_pipes": mesh.flow.n_pipes,
        "volume_relative_error": float(volumes.sum()) / cx.solid.volume - 1.0,
        "min_dihedral_angle_deg": float(dihedral.min()),
        "dihedral_p1_deg": float(np.percentile(dihedral, 1)),
        "shortest_edge_mm": spec_edges,
        "edges_breaking_rule": short_edge_report(
            cx, assembly_min_edge(assembly), assembly_max_edge(assembly),
            mesh.zone_sizes or mesh.zone_size),
        "smallest_element_mm3": float(volumes.min()) * 1e9,
        "stable_step": steps,
        "volume_percent": _volume_percent(assembly),
        "contact_fraction_total": contact_type_fractions(assembly),
        "size_distribution": grain_size_distribution3d(assembly),
    }


def assembly_min_edge(assembly: GrainAssembly) -> float:
    return float(assembly.mesh.grain_bounds[0])


def assembly_max_edge(assembly: GrainAssembly) -> float:
    return float(assembly.mesh.grain_bounds[1])


def quality_rows3d(summary: dict[str, Any]) -> list[tuple[str, str]]:
    """Mesh-quality lines of the printed 3D table."""
    s = summary["stable_step"]
    zones = []
    if summary.get("wall_zone_size_mm", 0) != summary.get("zone_size_mm", 0):
        zones = [("zone size (mm)", f"{summary['zone_size_mm']:g}, "
                                    f"{summary['wall_zone_size_mm']:g} at the borehole wall")]
    return zones + [
        ("min dihedral angle (deg)", f"{summary['min_dihedral_angle_deg']:.2f}"),
        ("shortest grain edge (mm)", f"{summary['shortest_edge_mm']:.3f}"),
        ("tet volume error (relative)", f"{summary['volume_relative_error']:.1e}"),
        ("stable step, tets, table minerals (s)", f"{s['grains_table_s']:.3e} "
                                                  f"({s['grains_table_ratio']:.3f} x "
                                                  "regular quartz tet)"),
        ("stable step, tets, drawn grains (s)", f"{s['grains_s']:.3e} "
                                                f"({s['grains_ratio']:.3f} x)"),
        ("stable step, with contacts (s)", f"{s['with_contacts_s']:.3e} "
                                           f"({s['with_contacts_ratio']:.3f} x)"),
        ("stable step, mass-scaled run (s)", f"{s['run_mass_scaled_s']:.3e} "
                                             f"({s['run_ratio']:.3f} x; mass "
                                             f"+{100 * s['run_added_mass_fraction']:.2f} %)"),
    ]
