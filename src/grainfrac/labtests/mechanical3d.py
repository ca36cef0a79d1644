"""UCS, BTS and NSCB on 3D specimens (paper Table 3 shapes): platens and readings.

The shapes are those of :func:`grainfrac.geometry.solids3d.specimen_solid`: the UCS
cylinder and the Brazilian disc have their axis along z, the NSCB half disc its base
on y = 0 and its thickness along z. The readings are the 2D tests' rules (first
peak, diametral split, tangent E at 50 % UCS) with the real 3D section: no
plane-strain conversion. Rigid-body drift is removed by holding the in-plane
displacement of one node under each loading platen (the friction a real platen has
at one point); the platens themselves are frictionless.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainfrac.analysis.fractures import CONNECT_FACTOR
from grainfrac.assembly import GrainAssembly
from grainfrac.geometry.solids3d import LATERAL
from grainfrac.labtests.config import LabTestConfig
from grainfrac.labtests.formulas import (
    brazilian_tensile_strength,
    nscb_fracture_toughness,
    nscb_geometry_factor,
    slope_between,
)
from grainfrac.labtests.mechanical import TANGENT_WINDOW, diametral_split
from grainfrac.labtests.platens import PlatenTest, closing_platen
from grainfrac.loading.boundary import Loads
from grainfrac.physics.model import MechanicalModel
from grainfrac.stages.platen import LoadingCurve, first_peak
from grainfrac.units import GPA, MM, MPA

Z = 2


def _hold(loads: Loads, x: np.ndarray, nodes: np.ndarray, axes: tuple[int, ...]) -> None:
    """Hold the ``axes`` components of the node of ``nodes`` nearest the load line's middle."""
    centre = x[nodes].mean(axis=0)
    loads.fixed[nodes[np.argmin(np.linalg.norm(x[nodes] - centre, axis=1))], list(axes)] = True


def _solid(assembly: GrainAssembly):
    return assembly.mesh.grains.solid


# --------------------------------------------------------------------------- UCS
def ucs_test3d(assembly: GrainAssembly) -> PlatenTest:
    """The cylinder between platens on its end faces (z); axial strain from the end
    faces, lateral strain from the mean radial displacement of the lateral surface."""
    mesh = assembly.mesh
    ns, x = mesh.node_sets, mesh.node_x
    solid = _solid(assembly)
    length = float(solid.hi[Z] - solid.lo[Z])
    side = ns[LATERAL]
    radial = x[side, :2] / np.linalg.norm(x[side, :2], axis=1)[:, None]
    radius = float(np.mean(np.linalg.norm(x[side, :2], axis=1)))

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        for end in ("z-", "z+"):
            _hold(loads, x, ns[end], (0, 1))
        return [closing_platen(a, model, ns["z+"], +1, 0.0, axis=Z),
                closing_platen(a, model, ns["z-"], -1, 0.0, axis=Z)]

    monitors = {
        "axial_strain": lambda s: -(s.u[ns["z+"], Z].mean() - s.u[ns["z-"], Z].mean()) / length,
        "lateral_strain": lambda s: float(np.mean(np.sum(s.u[side, :2] * radial, axis=1)))
        / radius,
    }
    return PlatenTest.build(assembly, place, length, monitors)


def reduce_ucs3d(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
                 ) -> dict[str, Any]:
    """UCS (first peak), E (tangent at 50 % UCS) and nu on the cylinder's section."""
    area = _solid(assembly).section_area
    stress = curve.array("load") / area
    eps_a, eps_l = curve.array("axial_strain"), curve.array("lateral_strain")
    peak, found = first_peak(stress, config.resolved_loading.peak_drop_fraction)
    ucs = float(stress[peak])
    window = (TANGENT_WINDOW[0] * ucs, TANGENT_WINDOW[1] * ucs)
    youngs = slope_between(eps_a, stress, *window, upto=peak + 1)
    poisson = slope_between(eps_a, eps_l, *window, by=stress, upto=peak + 1)
    return {
        "ucs_MPa": ucs / MPA,
        "youngs_modulus_GPa": youngs / GPA,
        "poisson_ratio": poisson,
        "axial_strain_at_peak": float(eps_a[peak]),
        "loaded_area_m2": area,
        "peak_found": found,
        "peak_index": peak,
    }


# --------------------------------------------------------------------------- BTS
def bts_test3d(assembly: GrainAssembly) -> PlatenTest:
    """The disc between flat platens on its lateral surface along the y diameter.

    The ``split`` monitor is 1 from the first sample at which the cracks, seen along
    the disc's axis, cross the central half of the loaded diameter
    (:func:`~grainfrac.labtests.mechanical.diametral_split`).
    """
    mesh = assembly.mesh
    ns, x = mesh.node_sets, mesh.node_x
    top, bottom = ns["load_y+"], ns["load_y-"]

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        _hold(loads, x, top, (0, Z))
        _hold(loads, x, bottom, (0, Z))
        return [closing_platen(a, model, top, +1, 0.0),
                closing_platen(a, model, bottom, -1, 0.0)]

    solid = _solid(assembly)
    radius = 0.5 * float(solid.hi[1] - solid.lo[1])
    connect = CONNECT_FACTOR * mesh.zone_size
    split = [False]  # once split, always split: cracks never heal

    def split_monitor(s) -> float:
        if not split[0]:
            contacts = np.asarray(s.cracks.contact, dtype=np.int64)
            split[0] = diametral_split(mesh.contact_x[contacts, :2], radius, connect)
        return float(split[0])

    return PlatenTest.build(assembly, place, 2.0 * radius, {"split": split_monitor})


def reduce_bts3d(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
                 ) -> dict[str, Any]:
    """Brazilian tensile strength (paper Eq. 5) at the diametral split, as in 2D
    (:func:`~grainfrac.labtests.mechanical.reduce_bts`), with the disc's thickness."""
    load = curve.array("load")
    peak, found = first_peak(load, config.resolved_loading.peak_drop_fraction)
    split = np.flatnonzero(curve.array("split") > 0)
    split_found = len(split) > 0
    if split_found and split[0] < peak:
        peak = int(np.argmax(load[:split[0] + 1]))
        found = True
    solid = _solid(assembly)
    diameter = float(solid.hi[1] - solid.lo[1])
    thickness = float(solid.hi[Z] - solid.lo[Z])
    sigma = brazilian_tensile_strength(float(load[peak]), diameter, thickness)
    return {"bts_MPa": sigma / MPA, "peak_load_kN": float(load[peak]) / 1e3,
            "peak_found": found, "peak_index": peak, "split_found": split_found,
            "split_index": int(split[0]) if split_found else None}


# --------------------------------------------------------------------------- NSCB
def nscb_test3d(assembly: GrainAssembly) -> PlatenTest:
    """Three-point bending: rollers along z under the base at +-S/2, a platen along
    the apex line."""
    ns, x = assembly.mesh.node_sets, assembly.mesh.node_x
    apex = ns["load_y+"]

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        for name in ("support_x-", "support_x+"):
            loads.platens.append(closing_platen(a, model, ns[name], -1, 0.0))
        _hold(loads, x, apex, (0, Z))
        return [closing_platen(a, model, apex, +1, 0.0)]

    solid = _solid(assembly)
    return PlatenTest.build(assembly, place, float(solid.hi[1] - solid.lo[1]))


def reduce_nscb3d(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
                  ) -> dict[str, Any]:
    """Fracture toughness from the peak bending load (paper Eqs. 6-7) and the half
    disc's thickness."""
    spec = config.specimen_config().specimen
    load = curve.array("load")
    peak, found = first_peak(load, config.resolved_loading.peak_drop_fraction)
    radius = spec.diameter_mm * MM / 2
    notch, span = spec.notch_length_mm * MM, spec.support_span_mm * MM
    solid = _solid(assembly)
    thickness = float(solid.hi[Z] - solid.lo[Z])
    kic = nscb_fracture_toughness(float(load[peak]), radius, thickness, notch, span)
    return {"kic_MPa_sqrt_m": kic / MPA, "peak_load_kN": float(load[peak]) / 1e3,
            "geometry_factor": nscb_geometry_factor(span, radius, notch),
            "peak_found": found, "peak_index": peak}


TESTS_3D = {"ucs": ucs_test3d, "bts": bts_test3d, "nscb": nscb_test3d}
REDUCERS_3D = {"ucs": reduce_ucs3d, "bts": reduce_bts3d, "nscb": reduce_nscb3d}
