"""Time series of ParaView snapshots: grains_NNNN.vtu, contacts_NNNN.vtu and series.pvd.

Grains carry point ``displacement_m`` and cell ``stress_Pa`` (xx, yy, zz, xy as
a symmetric tensor in ParaView's 6-component order), ``grain_id`` and
``mineral``; contacts carry normal/shear stress, opening, failure and mode
(and pressure and aperture once fluid is present). The .pvd index is rewritten
atomically after each snapshot, so it only ever lists complete files.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import meshio
import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.io.files import write_atomic, write_text
from grainfrac.io.vtk import _xyz, contacts_mesh, grains_mesh
from grainfrac.physics.kinematics import contact_opening


def _stress_tensor(stress: np.ndarray) -> np.ndarray:
    # ParaView/VTK symmetric tensor order: xx, yy, zz, xy, yz, xz.
    out = np.zeros((len(stress), 6))
    out[:, :4] = stress[:, [0, 1, 3, 2]]
    return out


@dataclass
class SnapshotSeries:
    """Writes numbered snapshots into ``directory`` and keeps ``series.pvd`` current."""

    directory: Path
    entries: list[tuple[float, str, str]] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.directory = Path(self.directory)

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
    ) -> int:
        """Write one snapshot; return its index."""
        index = len(self.entries)
        grains = grains_mesh(assembly)
        grains.point_data["displacement_m"] = _xyz(u)
        grains.cell_data["stress_Pa"] = [_stress_tensor(stress)]
        contacts = contacts_mesh(assembly)
        extra = {
            "normal_stress_Pa": sigma_n,
            "shear_stress_Pa": tau,
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
        for name, data in zip(names, (grains, contacts), strict=True):
            write_atomic(self.directory / name,
                         lambda p, d=data: meshio.write(p, d, file_format="vtu"))
        self.entries.append((float(time), *names))
        self._write_pvd()
        return index

    def _write_pvd(self) -> None:
        root = ET.Element("VTKFile", type="Collection", version="0.1")
        coll = ET.SubElement(root, "Collection")
        for time, grains, contacts in self.entries:
            ET.SubElement(coll, "DataSet", timestep=repr(time), part="0", file=grains)
            ET.SubElement(coll, "DataSet", timestep=repr(time), part="1", file=contacts)
        ET.indent(root)
        write_text(self.directory / "series.pvd",
                   '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n")
