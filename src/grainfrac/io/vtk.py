"""ParaView files (.vtu) of grain assemblies, written with meshio.

Grains are triangle cells; sub-contacts are short line cells along their
tributary length, so grain boundaries show as lines coloured by contact type,
strength or fissure flag.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.io.files import write_atomic

#: The field-data array of every .vtu grainfrac writes: the code tables and the sign
#: convention as UTF-8 JSON bytes (``bytes(array).decode()``; docs/outputs.md).
METADATA_FIELD = "grainfrac_metadata_json"


def write_vtu(path: str | Path, mesh: meshio.Mesh,
              field_data: dict[str, np.ndarray] | None = None) -> Path:
    """Write ``mesh`` as .vtu atomically, with ``field_data`` (1D arrays, e.g. the UInt8
    JSON of :func:`grainfrac.physics.codes.metadata_bytes`) in the file's FieldData:
    meshio's writer drops field data, so it is added to the XML here (ascii, which
    meshio and ParaView read)."""

    def write(tmp: Path) -> None:
        meshio.write(tmp, mesh, file_format="vtu")
        if not field_data:
            return
        arrays = []
        for name, values in field_data.items():
            values = np.asarray(values).ravel()
            kind = {np.dtype(np.uint8): "UInt8", np.dtype(np.int32): "Int32",
                    np.dtype(np.int64): "Int64", np.dtype(np.float64): "Float64"}[values.dtype]
            arrays.append(f'<DataArray type="{kind}" Name="{name}" NumberOfTuples='
                          f'"{len(values)}" format="ascii">\n'
                          + " ".join(str(v) for v in values.tolist()) + "\n</DataArray>")
        block = "<FieldData>\n" + "\n".join(arrays) + "\n</FieldData>\n"
        text = tmp.read_text(encoding="utf-8")
        text = text.replace("<UnstructuredGrid>\n", "<UnstructuredGrid>\n" + block, 1)
        tmp.write_text(text, encoding="utf-8")

    return write_atomic(path, write)


def _xyz(xy: np.ndarray) -> np.ndarray:
    return np.column_stack((xy, np.zeros(len(xy))))


def grains_mesh(assembly: GrainAssembly) -> meshio.Mesh:
    """Triangle mesh with cell data ``grain_id``, ``mineral``, ``youngs_modulus_Pa``, ..."""
    mesh = assembly.mesh
    cell_data = {
        "grain_id": mesh.element_grain.astype(np.int32),
        "mineral": assembly.element_mineral.astype(np.int32),
        "youngs_modulus_Pa": assembly.element_youngs_modulus,
        "poisson_ratio": assembly.element_poisson_ratio,
        "density_kg_m3": assembly.element_density,
    }
    return meshio.Mesh(
        _xyz(mesh.node_xy),
        [("triangle", mesh.element_nodes.astype(np.int64))],
        cell_data={k: [v] for k, v in cell_data.items()},
    )


def contacts_mesh(assembly: GrainAssembly) -> meshio.Mesh:
    """Sub-contacts as line cells with type, strengths, stiffnesses and fissure flag."""
    mesh = assembly.mesh
    half = 0.5 * (mesh.contact_area / mesh.thickness)[:, None] * mesh.contact_tangent
    points = np.vstack((mesh.contact_xy - half, mesh.contact_xy + half))
    n = mesh.n_contacts
    lines = np.column_stack((np.arange(n), np.arange(n, 2 * n)))
    cell_data = {
        "contact_type": assembly.contact_view("pair").astype(np.int32),
        "interface_id": mesh.contact_interface.astype(np.int32),
        "fissure": assembly.contact_view("fissure").astype(np.int32),
        "tensile_strength_Pa": assembly.contact_view("tensile_strength"),
        "cohesion_Pa": assembly.contact_view("cohesion"),
        "friction_angle_deg": np.degrees(assembly.contact_view("friction_angle")),
        "normal_stiffness_Pa_per_m": assembly.contact_view("normal_stiffness"),
        "shear_stiffness_Pa_per_m": assembly.contact_view("shear_stiffness"),
        "area_m2": mesh.contact_area,
        "normal": _xyz(mesh.contact_normal),
    }
    return meshio.Mesh(_xyz(points), [("line", lines)],
                       cell_data={k: [v] for k, v in cell_data.items()})


# -- 3D ---------------------------------------------------------------------------------
def grains_mesh3d(assembly: GrainAssembly) -> meshio.Mesh:
    """Tetrahedra with cell data ``grain_id``, ``mineral``, ``youngs_modulus_Pa``, ..."""
    mesh = assembly.mesh
    cell_data = {
        "grain_id": mesh.element_grain.astype(np.int32),
        "mineral": assembly.element_mineral.astype(np.int32),
        "youngs_modulus_Pa": assembly.element_youngs_modulus,
        "poisson_ratio": assembly.element_poisson_ratio,
        "density_kg_m3": assembly.element_density,
    }
    return meshio.Mesh(mesh.node_x, [("tetra", mesh.element_nodes.astype(np.int64))],
                       cell_data={k: [v] for k, v in cell_data.items()})


def contacts_mesh3d(assembly: GrainAssembly) -> meshio.Mesh:
    """Internal grain faces as triangles (their face triangulation) with contact type,
    strengths, stiffnesses and fissure flag of the face's interface."""
    mesh = assembly.mesh
    faces = np.flatnonzero(mesh.face_interface >= 0)
    tris = [mesh.face_triangles[f] for f in faces]
    iface = np.repeat(mesh.face_interface[faces], [len(t) for t in tris])
    cell_data = {
        "contact_type": assembly.interface_pair[iface].astype(np.int32),
        "interface_id": iface.astype(np.int32),
        "fissure": assembly.interface_fissure[iface].astype(np.int32),
        "tensile_strength_Pa": assembly.interface_tensile_strength[iface],
        "cohesion_Pa": assembly.interface_cohesion[iface],
        "friction_angle_deg": np.degrees(assembly.interface_friction_angle[iface]),
        "normal_stiffness_Pa_per_m": assembly.interface_normal_stiffness[iface],
        "shear_stiffness_Pa_per_m": assembly.interface_shear_stiffness[iface],
    }
    return meshio.Mesh(mesh.points, [("triangle", np.vstack(tris).astype(np.int64))],
                       cell_data={k: [v] for k, v in cell_data.items()})


def contact_points_mesh3d(assembly: GrainAssembly) -> meshio.Mesh:
    """Sub-contacts of a 3D assembly as vertex cells at their points, with type, interface,
    fissure flag, area and normal: what a snapshot's per-sub-contact fields attach to."""
    mesh = assembly.mesh
    n = mesh.n_contacts
    cell_data = {
        "contact_type": assembly.contact_view("pair").astype(np.int32),
        "interface_id": mesh.contact_interface.astype(np.int32),
        "fissure": assembly.contact_view("fissure").astype(np.int32),
        "area_m2": mesh.contact_area,
        "normal": mesh.contact_normal,
    }
    return meshio.Mesh(mesh.contact_x, [("vertex", np.arange(n, dtype=np.int64)[:, None])],
                       cell_data={k: [v] for k, v in cell_data.items()})


def write_assembly(assembly: GrainAssembly, directory: str | Path) -> list[Path]:
    """Write ``grains.vtu`` and ``contacts.vtu`` into ``directory`` (atomically).

    2D: triangles and sub-contacts as short lines; 3D: tetrahedra and grain faces.
    """
    from grainfrac.physics.codes import metadata_bytes

    directory = Path(directory)
    builders = ((grains_mesh, contacts_mesh) if assembly.dimension == 2
                else (grains_mesh3d, contacts_mesh3d))
    meta = {METADATA_FIELD: metadata_bytes(assembly)}
    return [write_vtu(directory / name, build(assembly), meta)
            for name, build in zip(("grains.vtu", "contacts.vtu"), builders, strict=True)]
