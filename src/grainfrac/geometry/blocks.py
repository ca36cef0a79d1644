"""Breakable grains: every zone of a meshed grain becomes a block of its own.

This is UDEC's Trigon approach in the deformable-block setting: a grain is cut
into the triangles of its mesh, and the faces between them become contacts
that can crack (transgranular cracks), next to the grain boundaries
(intergranular cracks). The block map is a :class:`GrainMap` like the grains'
one, so it is meshed, given sub-contacts and a flow network by the same code.
"""

from __future__ import annotations

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from grainfrac.geometry.meshing import GrainMesh
from grainfrac.geometry.tessellation import GrainMap

# Coincident-node tolerance (m): grain meshes duplicate boundary nodes exactly.
_MERGE_TOL = 1e-9


def zone_blocks(mesh: GrainMesh) -> tuple[GrainMap, np.ndarray]:
    """The block map whose blocks are ``mesh``'s elements, and each block's grain.

    Parameters
    ----------
    mesh
        The meshed grains; its elements become the blocks.

    Returns
    -------
    blocks : GrainMap
        One counter-clockwise triangle per element, over vertices shared by
        neighbouring blocks (grain meshes agree along grain boundaries).
    block_grain : np.ndarray
        (b,) the grain each block was cut from.
    """
    xy = mesh.node_xy
    pairs = cKDTree(xy).query_pairs(_MERGE_TOL, output_type="ndarray")
    n = len(xy)
    same = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(same, directed=False)
    first = np.zeros(label.max() + 1, dtype=np.int64)
    first[label[::-1]] = np.arange(n)[::-1]
    vertices = xy[first]
    rings = tuple(label[tri].astype(np.int64) for tri in mesh.element_nodes)
    outline = mesh.grains.outline
    on_boundary = shapely.distance(outline.polygon.boundary, shapely.points(vertices)) < 1e-7
    return GrainMap(outline, vertices, rings, on_boundary), mesh.element_grain.copy()
