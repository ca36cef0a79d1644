"""Element layer: the linear triangle (plane strain) and the linear tetrahedron.

Everything that depends on the element shape lives here: shape-function
gradients, cell measures, lumped masses, the strain-displacement matrices whose
row sums bound the stable time step, and the layout of the stress and strain
components. The mechanics kernels (:mod:`grainfrac.physics.kernels`) loop over
the dimension ``d`` and the ``d + 1`` nodes of a cell and need nothing else.

Component layout (Voigt order, shear strains in engineering form):

- 2D: strain ``(xx, yy, xy)``; stress ``(xx, yy, xy, zz)``: the out-of-plane
  stress of plane strain comes last, so the in-plane components keep their places.
- 3D: strain and stress ``(xx, yy, zz, yz, xz, xy)``.
"""

from __future__ import annotations

from grainfrac.physics.elements import tetrahedron, triangle
from grainfrac.physics.elements.common import (
    element_for_dimension,
    element_row_sums,
    lame_parameters,
    n_strain_components,
    n_stress_components,
)

__all__ = ["element_for_dimension", "element_row_sums", "lame_parameters",
           "n_strain_components", "n_stress_components", "tetrahedron", "triangle"]
