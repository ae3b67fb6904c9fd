"""Floater's construction (paper eq. 14, 21, N-D in MATH.md) and completeness (Prop. 10).

Each ridge R is shared by two facets R+p and R+q. With D_p, D_q their determinants
``det E`` (N! times the signed volumes of {x} + facet), the N+1 vectors
``e_p, e_q, e_R`` satisfy the barycentric identity

    D_q e_p + D_p e_q + sum_{k in R} C_k e_k = 0,

so dividing by D_p D_q and weighting by any scalar c_R gives homogeneous weights

    w_p += N! c_R / D_p,   w_q += N! c_R / D_q,   w_k += N! c_R C_k / (D_p D_q).

They equal the general construction's for ``d_R = N! c_R / |m_R|``, where ``|m_R|`` is
(N-1)! times the (N-1)-volume of {x} + R (2D: d = 2c/l, 3D: d = 6c/|e_j x e_k|).
"""

from math import factorial

import numpy as np

from .construction import facet_determinants, point_frame, prepare_cage

__all__ = ["floater_matrix", "floater_weights", "ridge_scalars_from_floater",
           "floater_from_ridge_scalars", "floater_scalars"]


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
    facets, opposite = cage.topology.ridge_facets()
    det = facet_determinants(cage, x)  # (k, m)
    det_p, det_q = det[:, facets[:, 0]], det[:, facets[:, 1]]  # (k, r)
    e = cage.vertices[None] - (x - cage.origin)[:, None, :]  # (k, n, N)
    ridge_vertices = cage.topology.ridges
    size = ridge_vertices.shape[1]
    e_pq = e[:, opposite]  # (k, r, 2, N)
    scale = factorial(cage.dimension)
    count, ridge_count = len(x), len(ridge_vertices)
    matrix = np.zeros((count, len(cage.vertices), ridge_count))
    points_index = np.arange(count)[:, None]
    ridges_index = np.arange(ridge_count)[None, :]
    matrix[points_index, opposite[None, :, 0], ridges_index] += scale / det_p
    matrix[points_index, opposite[None, :, 1], ridges_index] += scale / det_q
    for slot in range(size):
        # C_k = -(-1)^slot det[e_p, e_q, e_R without k] (Cramer's null vector of the N+1 vectors)
        others = np.delete(ridge_vertices, slot, axis=1)
        columns = np.concatenate([e_pq, e[:, others]], axis=2)  # (k, r, N, N)
        c_slot = -((-1.0) ** slot) * np.linalg.det(columns)
        matrix[points_index, ridge_vertices[None, :, slot], ridges_index] += scale * c_slot / (det_p * det_q)
    return matrix


def floater_weights(points, vertices, faces, c):
    """Homogeneous weights of Floater's construction for scalars c.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
    c : (k, r) float
        One scalar per (point, ridge).

    Returns
    -------
    weights : (k, n) float
    """
    c = np.atleast_2d(np.asarray(c, dtype=np.float64))
    return np.einsum("knr,kr->kn", floater_matrix(points, vertices, faces), c)


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
