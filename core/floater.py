"""Floater's construction (paper eq. 14, 21, N-D in docs/MATH.md) and completeness (Prop. 10).

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

from .construction import facet_determinants, point_frame, prepare_cage, sum_rows
from .simplex import generalized_cross
from .topology import gather_table

__all__ = ["FloaterTerms", "floater_terms", "floater_term_values", "floater_form_weights", "floater_matrix",
           "floater_weights", "ridge_scalars_from_floater", "floater_from_ridge_scalars",
           "floater_scalars"]


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
        Their gather table (:func:`core.topology.gather_table`) by vertex.
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
    cage : Cage
    terms : FloaterTerms
    points : (k, N) float
    facet_det : (m, k) float
        ``det E_T`` of every facet (see :class:`~core.construction.PointFrame`).
    scaled_scalars : (r, k) float
        ``N! c_R`` (equivalently ``d_R |m_R|``) per (ridge, point).

    Returns
    -------
    values : ((2 + N-1) r + 1, k) float
        Row ``role * r + ridge`` (roles: p, q, then the ridge's vertices), then a zero
        row for the gather table's padding.
    """
    ridges = len(terms.facets)
    x = np.asarray(points, dtype=np.float64) - cage.origin
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


def floater_matrix(points, vertices, faces):
    """The linear map from Floater scalars c to homogeneous weights, per point.

    Parameters
    ----------
    points : (k, N) float
        Strictly inside the convex cage.
    vertices : (n, N) float
    faces : (m, N) int
        Closed, outward-oriented simplicial facets.

    Returns
    -------
    matrix : (k, n, r) float
        ``weights[k] = matrix[k] @ c[k]``; ridges ordered as :func:`core.ridges`.
    """
    cage = prepare_cage(vertices, faces)
    x = np.atleast_2d(np.asarray(points, dtype=np.float64))
    terms = floater_terms(cage)
    ridges = len(terms.facets)
    # Column R holds ridge R's terms for c_R = 1, each added at its vertex.
    unit = np.full((ridges, len(x)), float(factorial(cage.dimension)))
    values = floater_term_values(cage, terms, x, facet_determinants(cage, x).T, unit)[:-1]
    roles = len(terms.term_vertices) // ridges
    matrix = np.zeros((len(x), len(cage.vertices), ridges))
    np.add.at(matrix, (slice(None), terms.term_vertices, np.tile(np.arange(ridges), roles)), values.T)
    return matrix


def floater_weights(points, vertices, faces, c):
    """Homogeneous weights of Floater's construction for scalars c.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
        Closed, outward-oriented simplicial facets.
    c : (k, r) float
        One scalar per (point, ridge).

    Returns
    -------
    weights : (k, n) float
    """
    cage = prepare_cage(vertices, faces)
    x = np.atleast_2d(np.asarray(points, dtype=np.float64))
    c = np.atleast_2d(np.asarray(c, dtype=np.float64))
    scaled = factorial(cage.dimension) * c.T
    return floater_form_weights(cage, floater_terms(cage), x, facet_determinants(cage, x).T, scaled).T


def _ridge_measure(points, vertices, faces):
    cage = prepare_cage(vertices, faces)
    return point_frame(cage, np.atleast_2d(points)).ridge_measure.T, factorial(cage.dimension)


def ridge_scalars_from_floater(points, vertices, faces, c):
    """Ridge scalars d giving the same weights as Floater scalars c (Prop. 3, 9).

    Returns
    -------
    d : (k, r) float
        ``N! c / |m_R|``.
    """
    measure, scale = _ridge_measure(points, vertices, faces)
    return scale * np.asarray(c, dtype=np.float64) / measure


def floater_from_ridge_scalars(points, vertices, faces, d):
    """Inverse of :func:`ridge_scalars_from_floater`: c = d |m_R| / N!."""
    measure, scale = _ridge_measure(points, vertices, faces)
    return np.asarray(d, dtype=np.float64) * measure / scale


def floater_scalars(point, vertices, faces, w):
    """Completeness (Prop. 10): Floater scalars c reproducing given homogeneous weights.

    Parameters
    ----------
    point : (N,) float
        Strictly inside the convex cage.
    vertices : (n, N) float
    faces : (m, N) int
    w : (n,) float
        Homogeneous weights at the point (coordinates of any kind qualify).

    Returns
    -------
    c : (r,) float
        The least-norm solution of ``floater_matrix(point) @ c = w``; the map is onto
        the (n - N)-dimensional space of homogeneous weights, so the residual is only
        rounding when w is homogeneous. Ridge scalars follow from
        :func:`ridge_scalars_from_floater`.
    """
    matrix = floater_matrix(np.asarray(point, dtype=np.float64)[None, :], vertices, faces)[0]
    c, *_ = np.linalg.lstsq(matrix, np.asarray(w, dtype=np.float64), rcond=None)
    return c
