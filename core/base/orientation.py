"""Orienting the facets of a convex polytope outward (for hulls from other tools)."""

import numpy as np

from .inputs import checked
from .simplex import generalized_cross

__all__ = ["orient_facets_outward"]


@checked
def orient_facets_outward(vertices, facets):
    """Reorder each facet's vertices so that it faces away from the polytope's interior.

    Convex-hull tools (``scipy.spatial.ConvexHull(points).simplices``, for one) list
    facets in no consistent order; the core needs them outward oriented. The centroid
    of a convex polytope's vertices is inside it, so a facet faces outward when
    ``det[v_0 - c, ..., v_{N-1} - c] > 0``; the others get their first two vertices
    swapped.

    Parameters
    ----------
    vertices : (n, N) float
    facets : (m, N) int
        Facets of the convex hull of ``vertices`` (any orientation).

    Returns
    -------
    facets : (m, N) int
        The same facets, outward oriented.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron()
    >>> scrambled = faces[:, ::-1]  # every facet inward
    >>> oriented = gencoords.cages.orient_facets_outward(vertices, scrambled)
    >>> cage = gencoords.advanced.validate_cage(vertices, oriented)  # outward again: no CageError
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    facets = np.array(facets, dtype=np.int64)
    corners = vertices[facets] - vertices.mean(axis=0)  # (m, N, N)
    normals = generalized_cross(np.moveaxis(corners[:, 1:] - corners[:, :1], 0, -1)).T
    inward = np.einsum("mN,mN->m", corners[:, 0], normals) < 0.0
    facets[inward, :2] = facets[inward, 1::-1]
    return facets
