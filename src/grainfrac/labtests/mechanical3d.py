"""UCS, BTS and NSCB on 3D specimens (paper Table 3 shapes): where the platens go and
what is monitored.

The shapes are those of :func:`grainfrac.geometry.solids3d.specimen_solid`: the UCS
cylinder and the Brazilian disc have their axis along z, the NSCB half disc its base
on y = 0 and its thickness along z. The curves are read by the 2D tests' reducers
(:mod:`grainfrac.labtests.mechanical`: first peak, diametral split, tangent E at
50 % UCS) with the solid's section and thickness and no plane-strain conversion.
Rigid-body drift is removed by holding the in-plane displacement of one node under
each loading platen (the friction a real platen has at one point); the platens
themselves are frictionless.
"""

from __future__ import annotations

import numpy as np

from grainfrac.analysis.fractures import CONNECT_FACTOR
from grainfrac.assembly import GrainAssembly
from grainfrac.geometry.solids3d import LATERAL
from grainfrac.labtests.mechanical import SplitMonitor
from grainfrac.labtests.platens import PlatenTest, closing_platen
from grainfrac.loading.boundary import Loads
from grainfrac.physics.model import MechanicalModel

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


# --------------------------------------------------------------------------- BTS
def bts_test3d(assembly: GrainAssembly, safety: float = 0.5) -> PlatenTest:
    """The disc between flat platens on its lateral surface along the y diameter
    (``safety``: :meth:`PlatenTest.build`).

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
    split = SplitMonitor(mesh.contact_x[:, :2], radius, CONNECT_FACTOR * mesh.zone_size)
    return PlatenTest.build(assembly, place, 2.0 * radius, {"split": split}, safety)


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


TESTS_3D = {"ucs": ucs_test3d, "bts": bts_test3d, "nscb": nscb_test3d}
