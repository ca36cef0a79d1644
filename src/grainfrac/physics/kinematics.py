"""Contact kinematics: how far the two faces of every sub-contact have separated.

The one place the relative displacement of a sub-contact's nodes is turned into
an opening; the coupling (apertures), the snapshots and the KGD verification
all read it from here.
"""

from __future__ import annotations

import numpy as np

from grainfrac.assembly import GrainAssembly
from grainfrac.physics.coupling_kernels import contact_openings


def contact_opening(assembly: GrainAssembly, u: np.ndarray) -> np.ndarray:
    """Normal opening (m, positive when the faces separate) of every sub-contact."""
    mesh = assembly.mesh
    return contact_openings(np.asarray(u, dtype=float), mesh.contact_nodes,
                            mesh.contact_normal)
