"""The crack catalogue: every failed sub-contact, when, where, how and what it released."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.physics.kernels import SHEAR, TENSILE

MODE_NAMES = {TENSILE: "tensile", SHEAR: "shear"}


@dataclass(frozen=True)
class CrackCatalogue:
    """Cracks in the order they formed (SI units)."""

    contact: np.ndarray  # sub-contact id
    time: np.ndarray  # s
    x: np.ndarray  # m
    y: np.ndarray  # m
    mode: np.ndarray  # kernels.TENSILE or kernels.SHEAR
    pair: np.ndarray  # mineral-pair id
    energy: np.ndarray  # strain energy released at failure (J)

    def __len__(self) -> int:
        return len(self.contact)

    @property
    def n_tensile(self) -> int:
        return int(np.count_nonzero(self.mode == TENSILE))

    @property
    def n_shear(self) -> int:
        return int(np.count_nonzero(self.mode == SHEAR))

    def rows(self, pair_names: tuple[str, ...]) -> list[dict]:
        """Rows for cracks.csv (docs/outputs.md: mm and J at the edge)."""
        return [
            {"time_s": float(t), "x_mm": float(x * 1e3), "y_mm": float(y * 1e3),
             "mode": MODE_NAMES[int(m)], "contact_type": pair_names[int(p)],
             "energy_J": float(e)}
            for t, x, y, m, p, e in zip(self.time, self.x, self.y, self.mode, self.pair,
                                        self.energy, strict=True)
        ]


def crack_catalogue(assembly: GrainAssembly, contact: list[int] | np.ndarray,
                    time: list[float] | np.ndarray, mode: list[int] | np.ndarray,
                    energy: list[float] | np.ndarray) -> CrackCatalogue:
    """Attach positions and mineral-pair types to the solver's crack record."""
    contact = np.asarray(contact, dtype=np.int64)
    xy = assembly.mesh.contact_xy[contact].reshape(-1, 2)
    return CrackCatalogue(
        contact=contact,
        time=np.asarray(time, dtype=float),
        x=xy[:, 0],
        y=xy[:, 1],
        mode=np.asarray(mode, dtype=np.int64),
        pair=assembly.contact_view("pair")[contact],
        energy=np.asarray(energy, dtype=float),
    )
