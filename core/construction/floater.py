"""Floater's construction (paper eq. 14, 21, N-D in docs/MATH.md); completeness (Prop. 10)
is `completeness.py`.

Each ridge R is shared by two facets R+p and R+q. With D_p, D_q their determinants
``det E`` (N! times the signed volumes of {x} + facet), the N+1 vectors
``e_p, e_q, e_R`` satisfy the barycentric identity

    D_q e_p + D_p e_q + sum_{k in R} C_k e_k = 0,

so dividing by D_p D_q and weighting by any scalar c_R gives homogeneous weights

    w_p += N! c_R / D_p,   w_q += N! c_R / D_q,   w_k += N! c_R C_k / (D_p D_q).

They equal the general construction's for ``d_R = N! c_R / |m_R|``, where ``|m_R|`` is
(N-1)! times the (N-1)-volume of {x} + R (2D: d = 2c/l, 3D: d = 6c/|e_j x e_k|): the
general construction's terms grouped by ridge (Proposition 9). Grouped this way a ridge
needs two facet determinants and N-1 minors C_k, all affine in x, so this form is also
the fast evaluator of named coordinates inside convex cages.
"""

from dataclasses import dataclass
from math import factorial

import numpy as np

from .boundary import plane_distances
from .general import facet_determinants, point_frame, sum_rows
from ..base.inputs import checked
from ..base.simplex import generalized_cross
from ..base.topology import gather_table
from .units import to_world
from .validation import DEFAULT_TOLERANCE, validate_cage

__all__ = ["FloaterTerms", "floater_terms", "floater_term_values", "floater_form_weights",
           "convex_cage_and_determinants", "floater_weights", "ridge_scalars_from_floater",
           "floater_from_ridge_scalars"]


@dataclass(frozen=True)
class FloaterTerms:
    """Per-cage data of Floater's construction, grouped by ridge.

    Attributes
    ----------
    facets : (r, 2) int
        The ridge's facets R+p and R+q (orientation sign +1, then -1).
    opposite : (r, 2) int
        p and q.
    minor_normals : (N-1, r, N) float
    minor_offsets : (N-1, r, 1) float
        ``C_k(x) = minor_offset - minor_normal . x`` for the ridge's k-th vertex.
    term_vertices : ((2 + N-1) r,) int
        The vertex each per-ridge term belongs to (rows ``role * r + ridge``; roles p,
        q, then the ridge's vertices).
    vertex_terms : (n, w) int
        Their gather table (:func:`gencoords.base.topology.gather_table`) by vertex.
    """

    facets: np.ndarray
    opposite: np.ndarray
    minor_normals: np.ndarray
    minor_offsets: np.ndarray
    term_vertices: np.ndarray
    vertex_terms: np.ndarray


def floater_terms(cage):
    """Build the :class:`FloaterTerms` of a closed, consistently oriented cage."""
    topology = cage.topology
    facets, opposite = topology.ridge_facets()
    ridge_vertices = topology.ridges
    size = ridge_vertices.shape[1]
    normals, offsets = [], []
    for slot in range(size):
        # C_k = -(-1)^slot det[e_p, e_q, e_R without k]  (Cramer's null vector of the
        # N+1 vectors); det[w_0 - x, ..., w_{N-1} - x] = (w_0 - x) . gcross(w_i - w_0).
        corners = cage.vertices[np.concatenate([opposite, np.delete(ridge_vertices, slot, axis=1)], axis=1)]
        normal = generalized_cross(np.moveaxis(corners[:, 1:] - corners[:, :1], 0, -1)).T  # (r, N)
        sign = -((-1.0) ** slot)
        normals.append(sign * normal)
        offsets.append(sign * np.einsum("rN,rN->r", corners[:, 0], normal)[:, None])
    term_vertices = np.concatenate([opposite[:, 0], opposite[:, 1], ridge_vertices.T.reshape(-1)])
    return FloaterTerms(
        facets=facets,
        opposite=opposite,
        minor_normals=np.stack(normals),
        minor_offsets=np.stack(offsets),
        term_vertices=term_vertices,
        vertex_terms=gather_table(term_vertices, len(cage.vertices)),
    )


def floater_term_values(cage, terms, points, facet_det, scaled_scalars):
    """Each ridge's terms of Floater's construction, before summing them per vertex.

    Parameters
    ----------
    cage : PreparedCage
    terms : FloaterTerms
    points : (k, N) float
    facet_det : (m, k) float
        ``det E_T`` of every facet (see :class:`~gencoords.construction.general.PointFrame`).
    scaled_scalars : (r, k) float
        ``N! c_R`` (equivalently ``d_R |m_R|``) per (ridge, point).

    Returns
    -------
    values : ((2 + N-1) r + 1, k) float
        Row ``role * r + ridge`` (roles: p, q, then the ridge's vertices), then a zero
        row for the gather table's padding.
    """
    ridges = len(terms.facets)
    x = cage.local(points)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse_det = 1.0 / facet_det
    inverse_p = np.take(inverse_det, terms.facets[:, 0], axis=0)
    inverse_q = np.take(inverse_det, terms.facets[:, 1], axis=0)
    size = len(terms.minor_normals)
    values = np.empty(((2 + size) * ridges + 1, len(x)))
    values[-1] = 0.0
    to_p = np.multiply(scaled_scalars, inverse_p, out=values[:ridges])
    np.multiply(scaled_scalars, inverse_q, out=values[ridges:2 * ridges])
    both = to_p * inverse_q
    for slot in range(size):
        rows = values[(2 + slot) * ridges:(3 + slot) * ridges]
        np.matmul(terms.minor_normals[slot], -x.T, out=rows)
        rows += terms.minor_offsets[slot]
        rows *= both
    return values


def floater_form_weights(cage, terms, points, facet_det, scaled_scalars):
    """Homogeneous weights of Floater's construction: :func:`floater_term_values` summed
    per vertex. Returns (n, k) float."""
    return sum_rows(floater_term_values(cage, terms, points, facet_det, scaled_scalars),
                    terms.vertex_terms)


def convex_cage_and_determinants(points, vertices, faces, tolerance, what):
    """The validated convex cage, and the (m, k) determinants of points off every facet's
    hyperplane (there Floater's terms have a pole: 1 / det E_T)."""
    cage = validate_cage(vertices, faces, convex=True, tolerance=tolerance)
    det = facet_determinants(cage, points)
    near = (np.abs(plane_distances(cage, det)) <= tolerance * cage.size).any(axis=1)
    if near.any():
        first = ", ".join(str(i) for i in np.flatnonzero(near)[:5])
        raise ValueError(f"{what} has a pole on the cage's facet hyperplanes: {np.count_nonzero(near)} "
                         f"points lie within the tolerance ({tolerance:g} of the cage's size) of "
                         f"one (first: {first}); use gencoords.coordinates, which takes the boundary "
                         "limit there, or points strictly inside")
    return cage, det.T


@checked
def floater_weights(points, vertices, faces, c, tolerance=DEFAULT_TOLERANCE):
    """Homogeneous weights of Floater's construction for scalars c.

    Parameters
    ----------
    points : (k, N) float
        Off the facets' hyperplanes by more than the tolerance (ValueError otherwise).
    vertices : (n, N) float
    faces : (m, N) int
        Closed, outward-oriented simplicial facets of a convex cage.
    c : (k, r) float
        One scalar per (point, ridge).
    tolerance : float
        Relative to the cage's size, in (0, 1e-3].

    Returns
    -------
    weights : (k, n) float

    Examples
    --------
    >>> from gencoords.cages.shapes import regular_polygon
    >>> import numpy as np, gencoords
    >>> hexagon, edges = regular_polygon(6)
    >>> w = gencoords.advanced.floater_weights([[0.2, -0.1]], hexagon, edges, np.ones((1, 6)))
    >>> bool(np.allclose(w @ (hexagon - [0.2, -0.1]), 0.0))  # any c gives homogeneous weights
    True
    """
    cage, det = convex_cage_and_determinants(points, vertices, faces, tolerance, "floater_weights")
    scaled = factorial(cage.dimension) * c.T
    weights = floater_form_weights(cage, floater_terms(cage), points, det, scaled).T
    return to_world(weights, cage.scale, -cage.dimension, "Floater weights")


def _ridge_measure(points, vertices, faces, tolerance):
    """|m_R| per (point, ridge) in the frame, N! and the cage."""
    cage, _ = convex_cage_and_determinants(points, vertices, faces, tolerance, "the c <-> d map")
    return point_frame(cage, points).ridge_measure.T, factorial(cage.dimension), cage


@checked
def ridge_scalars_from_floater(points, vertices, faces, c, tolerance=DEFAULT_TOLERANCE):
    """Ridge scalars d giving the same weights as Floater scalars c (Prop. 3, 9).

    Parameters as :func:`floater_weights`.

    Returns
    -------
    d : (k, r) float
        ``N! c / |m_R|``.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> c = np.ones((1, 4))
    >>> d = gencoords.advanced.ridge_scalars_from_floater([[0.5, 0.5]], square, edges, c)
    >>> w = gencoords.advanced.weights_from_ridge_scalars([[0.5, 0.5]], square, edges, d)
    >>> bool(np.allclose(w, gencoords.advanced.floater_weights([[0.5, 0.5]], square, edges, c)))
    True
    """
    measure, scale, cage = _ridge_measure(points, vertices, faces, tolerance)
    return to_world(scale * c / measure, cage.scale, 1 - cage.dimension, "ridge scalars")


@checked
def floater_from_ridge_scalars(points, vertices, faces, d, tolerance=DEFAULT_TOLERANCE):
    """Inverse of :func:`ridge_scalars_from_floater`: c = d |m_R| / N!, (k, r) float.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> c = np.array([[1.0, 2.0, 3.0, 4.0]])
    >>> d = gencoords.advanced.ridge_scalars_from_floater([[0.5, 0.5]], square, edges, c)
    >>> bool(np.allclose(gencoords.advanced.floater_from_ridge_scalars([[0.5, 0.5]], square, edges, d), c))
    True
    """
    measure, scale, cage = _ridge_measure(points, vertices, faces, tolerance)
    return to_world(d * measure / scale, cage.scale, cage.dimension - 1, "Floater scalars")
