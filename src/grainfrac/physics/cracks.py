"""The crack catalogue: every failed sub-contact, when, where, how and what it released."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.physics.codes import MODE_NAMES
from grainfrac.physics.kernels import SHEAR, TENSILE

__all__ = ["MODE_NAMES", "CrackCatalogue", "crack_catalogue"]


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
    normal: np.ndarray | None = None  # (n, d) unit normal, from the first grain to the second
    length: np.ndarray | None = None  # m, tributary length of the sub-contact (2D)
    grains: np.ndarray | None = None  # (n, 2) the two grains (blocks) it joined
    z: np.ndarray | None = None  # m, along the borehole axis (3D)
    area: np.ndarray | None = None  # m2, tributary area of the sub-contact (3D)

    def __len__(self) -> int:
        return len(self.contact)

    @property
    def n_tensile(self) -> int:
        return int(np.count_nonzero(self.mode == TENSILE))

    @property
    def n_shear(self) -> int:
        return int(np.count_nonzero(self.mode == SHEAR))

    def stage_of(self, stage_starts: list[tuple[str, float]]) -> tuple[list[str], np.ndarray]:
        """The stage each crack formed in and its start (s), from the stages' kinds and
        absolute start times in order: the last stage that started strictly before the
        crack (a crack is timed at the end of its step, so after its stage's start)."""
        if not stage_starts:
            return [""] * len(self), np.zeros(len(self))
        starts = np.array([t for _, t in stage_starts], dtype=float)
        index = np.maximum(np.searchsorted(starts, self.time, side="left") - 1, 0)
        return [stage_starts[i][0] for i in index], starts[index]

    def rows(self, pair_names: tuple[str, ...],
             stage_starts: list[tuple[str, float]] | None = None) -> list[dict]:
        """Rows for cracks.csv (docs/outputs.md: mm and J at the edge); ``stage_starts``
        (kind, absolute start time in s) of the stages run, in order."""
        stage, start = self.stage_of(stage_starts or [])
        if self.z is not None:
            rows = self._rows2d(pair_names, stage, start)
            for row, z, n, area in zip(rows, self.z, self.normal, self.area, strict=True):
                row.update({"z_mm": float(z * 1e3), "normal_z": float(n[2]),
                            "area_mm2": float(area * 1e6)})
            return rows
        return self._rows2d(pair_names, stage, start)

    def _rows2d(self, pair_names, stage, start) -> list[dict]:
        normal = self.normal if self.normal is not None else np.full((len(self), 2), np.nan)
        length = self.length if self.length is not None else np.full(len(self), np.nan)
        grains = self.grains if self.grains is not None else np.full((len(self), 2), -1)
        # The normal's direction as an angle from +x in [0, 180): a crack's two faces
        # are one plane whichever way its normal points.
        angle = np.degrees(np.arctan2(normal[:, 1], normal[:, 0])) % 180.0
        return [
            {"time_s": float(t), "x_mm": float(x * 1e3), "y_mm": float(y * 1e3),
             "mode": MODE_NAMES[int(m)], "contact_type": pair_names[int(p)],
             "energy_J": float(e), "contact": int(c), "stage": k,
             "time_from_stage_start_s": float(t - t0),
             "normal_x": float(n[0]), "normal_y": float(n[1]), "normal_angle_deg": float(a),
             "length_mm": float(ln * 1e3), "grain_a": int(g[0]), "grain_b": int(g[1])}
            for t, x, y, m, p, e, c, k, t0, n, a, ln, g in zip(
                self.time, self.x, self.y, self.mode, self.pair, self.energy, self.contact,
                stage, start, normal, angle, length, grains, strict=True)
        ]


def crack_catalogue(assembly: GrainAssembly, contact: list[int] | np.ndarray,
                    time: list[float] | np.ndarray, mode: list[int] | np.ndarray,
                    energy: list[float] | np.ndarray) -> CrackCatalogue:
    """Attach positions and mineral-pair types to the solver's crack record."""
    contact = np.asarray(contact, dtype=np.int64)
    mesh = assembly.mesh
    d = mesh.dimension
    x = mesh.contact_x[contact].reshape(-1, d)
    return CrackCatalogue(
        contact=contact,
        time=np.asarray(time, dtype=float),
        x=x[:, 0],
        y=x[:, 1],
        mode=np.asarray(mode, dtype=np.int64),
        pair=assembly.contact_view("pair")[contact],
        energy=np.asarray(energy, dtype=float),
        normal=mesh.contact_normal[contact].reshape(-1, d),
        length=(mesh.contact_area / mesh.thickness)[contact] if d == 2
        else np.full(len(contact), np.nan),
        grains=mesh.interface_grains[mesh.contact_interface[contact]].reshape(-1, 2),
        z=x[:, 2] if d == 3 else None,
        area=mesh.contact_area[contact] if d == 3 else None,
    )
