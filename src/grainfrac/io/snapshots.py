"""Time series of ParaView snapshots: grains_NNNN.vtu, contacts_NNNN.vtu, scda_NNNN.vtu
(while an SCDA plug is in the borehole) and series.pvd.

Grains carry point ``displacement_m`` and cell ``stress_compression_positive_Pa``
(xx, yy, zz, xy as a symmetric tensor in ParaView's 6-component order),
``grain_id`` and ``mineral``; contacts carry normal/shear stress, opening,
failure and mode (and pressure and aperture once fluid is present); the plug its
blocks' stress and pressure. Every file carries the code tables and the sign
convention as field data (:func:`grainfrac.physics.codes.metadata_bytes`). The
.pvd index is rewritten atomically after each snapshot, so it only ever lists
complete files.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import meshio
import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.io.files import write_text
from grainfrac.io.vtk import (
    METADATA_FIELD,
    _xyz,
    contact_points_mesh3d,
    contacts_mesh,
    grains_mesh,
    grains_mesh3d,
    write_vtu,
)
from grainfrac.physics.codes import metadata_bytes, to_output_stress
from grainfrac.physics.kinematics import contact_opening


@dataclass(frozen=True)
class PlugState:
    """The SCDA plug at a snapshot: its blocks (triangles in 2D, tetrahedra in 3D, each
    on its own nodes), their displacement and tension-positive stress as the mechanics
    keeps them, and the expansive pressure on the borehole wall (Pa, compression
    positive)."""

    node_xy: np.ndarray  # (k, d)
    element_nodes: np.ndarray  # (e, d + 1)
    u: np.ndarray  # (k, d)
    stress: np.ndarray  # (e, 4) 2D sxx, syy, sxy, szz; (e, 6) 3D xx, yy, zz, yz, xz, xy
    expansive_pressure: float


def plug_mesh(plug: PlugState) -> meshio.Mesh:
    """The plug's blocks with displacement, stress and pressure (compression positive)."""
    stress = to_output_stress(plug.stress)
    n = len(plug.element_nodes)
    three = plug.node_xy.shape[1] == 3
    cells = [("tetra" if three else "triangle", plug.element_nodes.astype(np.int64))]
    mesh = meshio.Mesh(plug.node_xy if three else _xyz(plug.node_xy), cells)
    mesh.point_data["displacement_m"] = plug.u if three else _xyz(plug.u)
    mesh.cell_data["stress_compression_positive_Pa"] = [_stress_tensor(stress)]
    # The blocks' mean stress across the borehole axis (xx, yy are the first two
    # components in both layouts): the pressure the agent exerts on the wall.
    mesh.cell_data["pressure_Pa"] = [0.5 * (stress[:, 0] + stress[:, 1])]
    mesh.cell_data["expansive_pressure_Pa"] = [np.full(n, float(plug.expansive_pressure))]
    return mesh


def plug_file(grains_file: str) -> str:
    """The plug's file of the snapshot whose grains are in ``grains_file``."""
    return grains_file.replace("grains_", "scda_", 1)


def _stress_tensor(stress: np.ndarray) -> np.ndarray:
    # ParaView/VTK symmetric tensor order: xx, yy, zz, xy, yz, xz; ours are 2D (xx, yy,
    # xy, zz) and 3D (xx, yy, zz, yz, xz, xy).
    if stress.shape[1] == 6:
        return stress[:, [0, 1, 2, 5, 3, 4]]
    out = np.zeros((len(stress), 6))
    out[:, :4] = stress[:, [0, 1, 3, 2]]
    return out


@dataclass
class SnapshotSeries:
    """Writes numbered snapshots into ``directory`` and keeps ``series.pvd`` current.

    ``background``: the files are written by one worker thread, in order, while the
    caller goes on (a run's mechanics); :meth:`wait` returns once every snapshot begun
    is on disk and raises the first error of a write. The arrays are copied when the
    snapshot is taken. Compressing a 1e6-tetrahedron snapshot takes seconds; zlib and
    the kernels (numba, or the GPU's) let go of the interpreter meanwhile.
    """

    directory: Path
    entries: list[tuple[float, str, str]] = field(default_factory=list)
    background: bool = False
    _writer: ThreadPoolExecutor | None = field(default=None, init=False, repr=False)
    _pending: list[Future] = field(default_factory=list, init=False, repr=False)

    def __post_init__(self) -> None:
        self.directory = Path(self.directory)

    def wait(self, raise_errors: bool = True) -> None:
        """Return once every snapshot begun is written; raise the first write's error
        (``raise_errors``; else only wait, as while another error is on its way)."""
        pending, self._pending = self._pending, []
        errors = [f.exception() for f in pending]
        first = next((e for e in errors if e is not None), None)
        if first is not None and raise_errors:
            raise first

    def write(
        self,
        assembly: GrainAssembly,
        time: float,
        u: np.ndarray,
        stress: np.ndarray,
        sigma_n: np.ndarray,
        tau: np.ndarray,
        status: np.ndarray,
        pressure: np.ndarray | None = None,
        aperture: np.ndarray | None = None,
        plug: PlugState | None = None,
    ) -> int:
        """Write one snapshot (``stress`` tension positive, as the mechanics keeps it: the
        file has it compression positive); return its index."""
        index = len(self.entries)
        if self.background:  # the caller's arrays change on while the files are written
            u, sigma_n, tau = u.copy(), sigma_n.copy(), tau.copy()
            pressure = None if pressure is None else pressure.copy()
            aperture = None if aperture is None else aperture.copy()
            if plug is not None:
                plug = replace(plug, u=plug.u.copy(), stress=plug.stress.copy())
        three = assembly.dimension == 3
        grains = grains_mesh3d(assembly) if three else grains_mesh(assembly)
        grains.point_data["displacement_m"] = u if three else _xyz(u)
        grains.cell_data["stress_compression_positive_Pa"] = [
            _stress_tensor(to_output_stress(stress))]
        # 3D: one vertex per sub-contact (the faces' triangles are shared by several).
        contacts = contact_points_mesh3d(assembly) if three else contacts_mesh(assembly)
        extra = {
            "normal_stress_Pa": sigma_n,
            # 3D: the magnitude of the shear vector
            "shear_stress_Pa": np.linalg.norm(tau, axis=1) if tau.ndim == 2 else tau,
            "opening_m": contact_opening(assembly, u),
            "failed": (status > 0).astype(np.int32),
            "mode": status.astype(np.int32),
        }
        if pressure is not None:
            extra["pressure_Pa"] = pressure
        if aperture is not None:
            extra["aperture_m"] = aperture
        for key, value in extra.items():
            contacts.cell_data[key] = [np.asarray(value)]
        names = (f"grains_{index:04d}.vtu", f"contacts_{index:04d}.vtu")
        meta = {METADATA_FIELD: metadata_bytes(assembly)}
        plug_path = self.directory / plug_file(names[0])
        self.entries.append((float(time), *names))
        entries = list(self.entries)  # the index as of this snapshot

        def write_files() -> None:
            if plug is not None:
                write_vtu(plug_path, plug_mesh(plug), meta)
            elif plug_path.exists():  # left by a run this one resumes past
                plug_path.unlink()
            for name, data in zip(names, (grains, contacts), strict=True):
                write_vtu(self.directory / name, data, meta)
            self._write_pvd(entries)

        if self.background:
            if self._writer is None:
                self._writer = ThreadPoolExecutor(1, thread_name_prefix="snapshots")
            self._pending.append(self._writer.submit(write_files))
        else:
            write_files()
        return index

    def _write_pvd(self, entries: list[tuple[float, str, str]]) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for time, grains, contacts in entries:
            ET.SubElement(coll, "DataSet", timestep=repr(time), part="0", file=grains)
            ET.SubElement(coll, "DataSet", timestep=repr(time), part="1", file=contacts)
            if (self.directory / plug_file(grains)).is_file():
                ET.SubElement(coll, "DataSet", timestep=repr(time), part="2",
                              file=plug_file(grains))
        ET.indent(root)
        write_text(self.directory / "series.pvd",
                   '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n")
