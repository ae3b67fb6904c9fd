"""Completeness (Proposition 10): every set of homogeneous weights is Floater's for some c.

At a point x the map from Floater scalars c (one per ridge) to homogeneous weights
(docs/MATH.md, "Floater's construction") is linear and onto the (n - N)-dimensional
space of homogeneous weights, so any coordinates, of any method, come from some c, hence
from some ridge scalars d (``floater.ridge_scalars_from_floater``), hence from some
generating surface (Corollaries 1 and 2).
"""

from math import factorial

import numpy as np

from ..base import tolerances
from .floater import convex_cage_and_determinants, floater_term_values, floater_terms
from ..base.inputs import checked
from .units import to_world
from .validation import DEFAULT_TOLERANCE

__all__ = ["floater_matrix", "floater_scalars"]


def _frame_matrices(cage, points, det):
    """Floater's map at each point, in the cage's frame: (k, n, r) float.

    Column R holds ridge R's terms for c_R = 1, each added at its vertex.
    """
    terms = floater_terms(cage)
    ridges = len(terms.facets)
    unit = np.full((ridges, len(points)), float(factorial(cage.dimension)))
    values = floater_term_values(cage, terms, points, det, unit)[:-1]  # (roles r, k)
    matrix = np.zeros((len(points), len(cage.vertices), ridges))
    roles = len(terms.term_vertices) // ridges
    np.add.at(matrix, (slice(None), terms.term_vertices, np.tile(np.arange(ridges), roles)), values.T)
    return matrix


@checked
def floater_matrix(points, vertices, faces, tolerance=DEFAULT_TOLERANCE):
    """The linear map from Floater scalars c to homogeneous weights, per point.

    Parameters
    ----------
    points : (k, N) float
        Inside the convex cage, off the facets' hyperplanes by more than the tolerance
        (the terms have a pole there: ValueError).
    vertices : (n, N) float
    faces : (m, N) int
        Closed, outward-oriented simplicial facets of a convex cage (CageError otherwise).
    tolerance : float
        Relative to the cage's size, in (0, 1e-3].

    Returns
    -------
    matrix : (k, n, r) float
        ``weights[k] = matrix[k] @ c[k]``; ridges ordered as :func:`gencoords.advanced.ridges`.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> gencoords.advanced.floater_matrix([[0.5, 0.5]], square, edges).shape
    (1, 4, 4)
    """
    cage, det = convex_cage_and_determinants(points, vertices, faces, tolerance, "floater_matrix")
    return to_world(_frame_matrices(cage, points, det), cage.scale, -cage.dimension, "Floater matrices")


@checked
def floater_scalars(point, vertices, faces, w, tolerance=DEFAULT_TOLERANCE):
    """Floater scalars c reproducing given homogeneous weights (Proposition 10).

    Parameters
    ----------
    point : (N,) float
        Inside the convex cage, off the facets' hyperplanes (as :func:`floater_matrix`).
    vertices : (n, N) float
    faces : (m, N) int
    w : (n,) float
        Homogeneous weights at the point (coordinates of any kind qualify).
    tolerance : float
        Relative to the cage's size, in (0, 1e-3].

    Returns
    -------
    c : (r,) float
        The least-norm solution of ``floater_matrix(point) @ c = w``. Ridge scalars
        follow from :func:`gencoords.advanced.ridge_scalars_from_floater`.

    Raises
    ------
    ValueError
        ``w`` is not homogeneous at the point (``sum_i w_i (v_i - x) != 0``): no c gives
        it; the least-squares residual exceeds ``tolerances.HOMOGENEOUS`` times ``|w|``.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> x = np.array([0.5, 0.5])
    >>> target = gencoords.weights(x[None], square, edges, kind="wachspress")[0]
    >>> c = gencoords.advanced.floater_scalars(x, square, edges, target)
    >>> bool(np.allclose(gencoords.advanced.floater_weights(x[None], square, edges, c[None])[0], target))
    True
    """
    cage, det = convex_cage_and_determinants(point[None], vertices, faces, tolerance, "floater_scalars")
    # Solved in the frame (the world matrix is scale^-N times it), c converted after.
    matrix = _frame_matrices(cage, point[None], det)[0]
    c, *_ = np.linalg.lstsq(matrix, w, rcond=None)
    residual = np.linalg.norm(matrix @ c - w)
    if residual > tolerances.HOMOGENEOUS * np.linalg.norm(w):
        raise ValueError(f"w is not homogeneous at the point (sum_i w_i (v_i - x) != 0), so no "
                         f"Floater scalars reproduce it: least-squares residual {residual:.3g}, "
                         f"{residual / max(np.linalg.norm(w), tolerances.TINY):.3g} of |w| (accepted: "
                         f"{tolerances.HOMOGENEOUS:g}); pass weights or coordinates of the point")
    return to_world(c, cage.scale, cage.dimension, "Floater scalars")
