"""UCS, BTS and NSCB: where the platens go, what is monitored, how the curve is read.

Each test is a pair of functions: ``place_*`` puts platens and supports on the
specimen, ``reduce_*`` turns the loading curve into the lab's numbers
(paper Table 3). Rigid-body drift is removed by holding the x displacement of
one node per loading platen (the friction a real platen has at one point);
the platens themselves are frictionless.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grainfrac.analysis.fractures import CONNECT_FACTOR, connected_clusters
from grainfrac.assembly import GrainAssembly
from grainfrac.labtests.config import LabTestConfig
from grainfrac.labtests.formulas import (
    brazilian_tensile_strength,
    nscb_fracture_toughness,
    nscb_geometry_factor,
    plane_strain_to_isotropic,
    slope_between,
)
from grainfrac.labtests.platens import PlatenTest, closing_platen
from grainfrac.loading.boundary import Loads
from grainfrac.physics.model import MechanicalModel
from grainfrac.stages.platen import LoadingCurve, first_peak
from grainfrac.units import GPA, MM, MPA

# UCS: E (tangent) and nu are fitted between these fractions of the UCS (paper: at 50 %).
TANGENT_WINDOW = (0.4, 0.6)


def _hold_x(loads: Loads, xy: np.ndarray, nodes: np.ndarray, x: float = 0.0) -> None:
    loads.fixed[nodes[np.argmin(np.abs(xy[nodes, 0] - x))], 0] = True


def _extent(assembly: GrainAssembly) -> tuple[np.ndarray, np.ndarray]:
    if assembly.dimension == 3:
        solid = assembly.mesh.grains.solid
        return solid.lo, solid.hi
    v = assembly.mesh.grains.vertices
    return v.min(axis=0), v.max(axis=0)


def _thickness(assembly: GrainAssembly) -> float:
    """The specimen's thickness: the section's unit thickness in 2D, the solid's
    length along z in 3D (the Brazilian disc's and the NSCB half disc's B)."""
    lo, hi = _extent(assembly)
    return float(hi[2] - lo[2]) if assembly.dimension == 3 else assembly.mesh.thickness


# --------------------------------------------------------------------------- UCS
def ucs_test(assembly: GrainAssembly) -> PlatenTest:
    """Rectangle between a top and a bottom platen; axial and lateral strain monitors."""
    mesh = assembly.mesh
    ns, xy = mesh.node_sets, mesh.node_xy
    lo, hi = _extent(assembly)
    width, height = float(hi[0] - lo[0]), float(hi[1] - lo[1])

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        _hold_x(loads, xy, ns["bottom"])
        return [closing_platen(a, model, ns["top"], +1, 0.0),
                closing_platen(a, model, ns["bottom"], -1, 0.0)]

    monitors = {
        # Strains from the specimen's own faces: the platen penalty is not in them.
        "axial_strain": lambda s: -(s.u[ns["top"], 1].mean() - s.u[ns["bottom"], 1].mean())
        / height,
        "lateral_strain": lambda s: (s.u[ns["right"], 0].mean() - s.u[ns["left"], 0].mean())
        / width,
    }
    return PlatenTest.build(assembly, place, height, monitors)


def reduce_ucs(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
               ) -> dict[str, Any]:
    """UCS (first peak), E (tangent at 50 % UCS) and nu, as a cylinder test reports them
    (in 2D converted from the plane-strain section's)."""
    three = assembly.dimension == 3
    lo, hi = _extent(assembly)
    area = (assembly.mesh.grains.solid.section_area if three
            else float(hi[0] - lo[0]) * assembly.mesh.thickness)
    stress = curve.array("load") / area
    eps_a, eps_l = curve.array("axial_strain"), curve.array("lateral_strain")
    peak, found = first_peak(stress, config.resolved_loading.peak_drop_fraction)
    ucs = float(stress[peak])
    window = (TANGENT_WINDOW[0] * ucs, TANGENT_WINDOW[1] * ucs)
    modulus = slope_between(eps_a, stress, *window, upto=peak + 1)
    # nu = d eps_lateral / d eps_axial over the same window (both positive here).
    ratio = slope_between(eps_a, eps_l, *window, by=stress, upto=peak + 1)
    if three:
        return {"ucs_MPa": ucs / MPA, "youngs_modulus_GPa": modulus / GPA,
                "poisson_ratio": ratio, "axial_strain_at_peak": float(eps_a[peak]),
                "loaded_area_m2": area, "peak_found": found, "peak_index": peak}
    youngs, poisson = plane_strain_to_isotropic(modulus, ratio)
    return {
        "ucs_MPa": ucs / MPA,
        "youngs_modulus_GPa": youngs / GPA,
        "poisson_ratio": poisson,
        "plane_strain_modulus_GPa": modulus / GPA,
        "plane_strain_poisson_ratio": ratio,
        "axial_strain_at_peak": float(eps_a[peak]),
        "loaded_area_m2": area,
        "peak_found": found,
        "peak_index": peak,
    }


# --------------------------------------------------------------------------- BTS
def diametral_split(crack_xy: np.ndarray, radius: float, connect_distance: float) -> bool:
    """Whether a connected crack crosses the central half of the loaded (y) diameter.

    A cluster of cracks (neighbours closer than ``connect_distance``) splits
    the disk when its cracks inside the band ``|x| < R/2`` reach both
    ``y > R/2`` and ``y < -R/2``: one fracture through the disk centre along
    the load, what a Brazilian test's failure load marks.
    """
    if len(crack_xy) < 2:
        return False
    label = connected_clusters(crack_xy[:, 0], crack_xy[:, 1],
                               connect_distance=connect_distance)
    band = np.abs(crack_xy[:, 0]) < 0.5 * radius
    for k in np.unique(label[band]):
        y = crack_xy[band & (label == k), 1]
        if y.max() > 0.5 * radius and y.min() < -0.5 * radius:
            return True
    return False


def bts_test(assembly: GrainAssembly) -> PlatenTest:
    """Disk between flat platens touching its top and bottom (diametral compression).

    The ``split`` monitor is 1 from the first sample at which the disk has
    split along the loaded diameter (:func:`diametral_split`).
    """
    mesh = assembly.mesh
    per, xy = mesh.node_sets["perimeter"], mesh.node_xy
    top, bottom = per[xy[per, 1] > 0.0], per[xy[per, 1] < 0.0]

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        _hold_x(loads, xy, top)
        _hold_x(loads, xy, bottom)
        return [closing_platen(a, model, top, +1, 0.0),
                closing_platen(a, model, bottom, -1, 0.0)]

    lo, hi = _extent(assembly)
    radius = 0.5 * float(hi[1] - lo[1])
    split = SplitMonitor(mesh.contact_xy, radius, CONNECT_FACTOR * mesh.zone_size)
    return PlatenTest.build(assembly, place, 2.0 * radius, {"split": split})


class SplitMonitor:
    """1.0 once the cracks, at ``contact_xy`` in the disc's section, split it along the
    loaded diameter (:func:`diametral_split`), else 0.0.

    Cracks never heal, so the split stands while the solver has at least the cracks
    it had when the split was first seen; a platen loading that goes back in time
    (its fast approach) has fewer, and the split is looked for again.
    """

    def __init__(self, contact_xy: np.ndarray, radius: float, connect_distance: float):
        self.contact_xy, self.radius, self.connect = contact_xy, radius, connect_distance
        self.split_at: int | None = None  # cracks when the split was first seen

    def __call__(self, s) -> float:
        n = len(s.cracks.contact)
        if self.split_at is not None and n < self.split_at:
            self.split_at = None
        if self.split_at is None:
            contacts = np.asarray(s.cracks.contact, dtype=np.int64)
            if diametral_split(self.contact_xy[contacts], self.radius, self.connect):
                self.split_at = n
        return float(self.split_at is not None)


def reduce_bts(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
               ) -> dict[str, Any]:
    """Brazilian tensile strength (paper Eq. 5) from the load at the diametral split.

    The failure load is the largest load up to the sample at which the disk
    has split along its loaded diameter, or the first peak if that comes
    first. After the split, the halves of a 2D small-strain disk lock up
    between flat platens and carry more load (measured, seed 0, 0.4 x sigma_T
    and 2 x c of Table 2: 7.8 kN at the split, 20 kN at the later peak);
    that load is crushing of the fragments, not tensile strength.
    """
    load = curve.array("load")
    peak, found = first_peak(load, config.resolved_loading.peak_drop_fraction)
    split = np.flatnonzero(curve.array("split") > 0)
    split_found = len(split) > 0
    if split_found and split[0] < peak:
        peak = int(np.argmax(load[:split[0] + 1]))
        found = True
    lo, hi = _extent(assembly)
    diameter = float(hi[1] - lo[1])
    sigma = brazilian_tensile_strength(float(load[peak]), diameter, _thickness(assembly))
    return {"bts_MPa": sigma / MPA, "peak_load_kN": float(load[peak]) / 1e3,
            "peak_found": found, "peak_index": peak, "split_found": split_found,
            "split_index": int(split[0]) if split_found else None}


# --------------------------------------------------------------------------- NSCB
def nscb_test(assembly: GrainAssembly, support_span: float) -> PlatenTest:
    """Three-point bending: rollers under the base at +-S/2, a platen on the apex."""
    mesh = assembly.mesh
    xy, ns = mesh.node_xy, mesh.node_sets
    base, arc = ns["base"], ns["arc"]
    reach = 0.75 * mesh.zone_size  # a roller touches the nodes within this of its line

    def place(a: GrainAssembly, model: MechanicalModel, loads: Loads):
        for x in (-0.5 * support_span, 0.5 * support_span):
            nodes = base[np.abs(xy[base, 0] - x) <= reach]
            if len(nodes) == 0:
                nodes = base[[np.argmin(np.abs(xy[base, 0] - x))]]
            loads.platens.append(closing_platen(a, model, nodes, -1, 0.0))
        apex = arc[np.abs(xy[arc, 0]) <= reach]
        if len(apex) == 0:
            apex = arc[[np.argmin(np.abs(xy[arc, 0]))]]
        _hold_x(loads, xy, apex)
        return [closing_platen(a, model, apex, +1, 0.0)]

    lo, hi = _extent(assembly)
    return PlatenTest.build(assembly, place, float(hi[1] - lo[1]))


def reduce_nscb(curve: LoadingCurve, assembly: GrainAssembly, config: LabTestConfig,
                ) -> dict[str, Any]:
    """Fracture toughness from the peak bending load (paper Eqs. 6-7, Kuruppu et al. 2014)."""
    spec = config.specimen_config().specimen
    load = curve.array("load")
    peak, found = first_peak(load, config.resolved_loading.peak_drop_fraction)
    radius = spec.diameter_mm * MM / 2
    notch, span = spec.notch_length_mm * MM, spec.support_span_mm * MM
    kic = nscb_fracture_toughness(float(load[peak]), radius, _thickness(assembly), notch, span)
    return {"kic_MPa_sqrt_m": kic / MPA, "peak_load_kN": float(load[peak]) / 1e3,
            "geometry_factor": nscb_geometry_factor(span, radius, notch),
            "peak_found": found, "peak_index": peak}


def build_test(config: LabTestConfig, assembly: GrainAssembly) -> PlatenTest:
    """The platen test of ``config.test`` on ``assembly`` (2D or 3D)."""
    if assembly.dimension == 3:
        from grainfrac.labtests.mechanical3d import TESTS_3D

        return TESTS_3D[config.test](assembly)
    if config.test == "ucs":
        return ucs_test(assembly)
    if config.test == "bts":
        return bts_test(assembly)
    if config.test == "nscb":
        span = config.specimen_config().specimen.support_span_mm * MM
        return nscb_test(assembly, span)
    raise ValueError(f"{config.test} is not a platen test")


REDUCERS = {"ucs": reduce_ucs, "bts": reduce_bts, "nscb": reduce_nscb}
