"""The general construction (paper eq. 5, 6, 8, 17, 18), in any dimension N >= 2.

For a query point x, a facet T and its vertex i (docs/MATH.md):

    m_i   = cofactor vector of E_T, e_i . m_i = det E_T        (generalized cross product)
    r^T   = sum_i d(ridge opposite i) m_i / |m_i|              (Stokes on the wedge)
    u_i^T = (r^T . m_i) / det E_T                              (reciprocal basis, eq. 8)
    w_i   = sum over facets T containing i of u_i^T            (eq. 6)

``m_i`` is, up to an orientation sign fixed by the topology, the generalized cross
product of the vectors ``e_k = v_k - x`` of the ridge opposite i. So everything is
computed once per (point, ridge) and gathered per (point, facet); ``det E_T`` is affine
in x and comes from one matrix product.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..base.arrays import bounding_frame
from ..base.simplex import generalized_cross
from ..base.topology import CageTopology, cage_topology

__all__ = ["PreparedCage", "PointFrame", "prepare_cage", "point_frame", "facet_determinants",
           "construct_weights"]


@dataclass(frozen=True)
class PreparedCage:
    """A cage in its frame with everything the formulas need that depends only on it.

    The internal, unvalidated form (:func:`prepare_cage`); :class:`gencoords.Cage` is the
    public one, validated and holding one of these.

    Attributes
    ----------
    vertices : (n, N) float
        Vertex positions in the cage's frame: ``(v - origin) / scale``. Centring keeps the
        affine formulas below free of cancellation far from the world origin; dividing
        by a power of two near the size keeps every product in range at any scale
        (1e-150 or 1e150 alike) without adding rounding. Every per-cage array below,
        and every distance the core computes, is in this frame; map points with
        :meth:`local`.
    origin : (N,) float
        Centre of the bounding box (world units).
    scale : float
        The frame's unit in world units: a power of two.
    size : float
        Diagonal of the bounding box in the frame (in [1, 2)): the length that
        tolerances are relative to (``size * scale`` in world units).
    topology : CageTopology
    facet_normals : (m, N) float
        Outward normal of each facet scaled to (N-1)! times its (N-1)-volume.
    facet_offsets : (m,) float
        ``v_t0 . facet_normal``: ``det E_T(x) = facet_offset - x . facet_normal``.
    ridge_side_lengths_squared : (p, p, r, 1) float
        ``|v_a - v_b|^2`` for ridge vertices a, b: with the vertices' ``|e|^2`` it gives
        every ``e_a . e_b = (|e_a|^2 + |e_b|^2 - |v_a - v_b|^2) / 2`` (law of cosines),
        so a ridge's Gram matrix costs gathers instead of matrix products.
    ridge_cross_constant, ridge_cross_linear : (N, r, 1), (N, r, N) float
        The ridge's generalized cross product of ``e = v - x`` is affine in x (it is
        alternating multilinear, so terms with x in two slots vanish): constant plus
        ``ridge_cross_linear @ x``.
    """

    vertices: np.ndarray
    origin: np.ndarray
    scale: float
    size: float
    topology: CageTopology
    facet_normals: np.ndarray
    facet_offsets: np.ndarray
    ridge_side_lengths_squared: np.ndarray
    ridge_cross_constant: np.ndarray
    ridge_cross_linear: np.ndarray

    @property
    def dimension(self):
        return self.vertices.shape[1]

    def facet_corners(self):
        """Vertex positions of each facet (in the frame): (m, N, N) float."""
        return self.vertices[self.topology.faces]

    @cached_property
    def inside_lookup(self):
        """The grid 3D points are located in before winding numbers
        (:func:`gencoords.construction.boundary.inside_lookup`), built once per cage."""
        from .boundary import inside_lookup  # boundary builds on this module
        return inside_lookup(self)

    def local(self, points):
        """World points in the cage's frame: ``(points - origin) / scale``, (k, N) float.

        Divided first (exact: the scale is a power of two), so nothing overflows.
        """
        return np.asarray(points, dtype=np.float64) / self.scale - self.origin / self.scale


def prepare_cage(vertices, faces, scale=None):
    """Precompute a :class:`PreparedCage` (no validation; see :func:`gencoords.advanced.validate_cage`).

    Parameters
    ----------
    vertices : (n, N) float
    faces : (m, N) int
        Outward-oriented facets.
    scale : float, optional
        The frame's unit; by default the power of two of :func:`gencoords.base.arrays.bounding_frame`.

    Returns
    -------
    PreparedCage
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if vertices.ndim != 2 or faces.ndim != 2 or faces.shape[1] != vertices.shape[1]:
        raise ValueError(
            f"vertices must be (n, N) and faces (m, N); got {vertices.shape} and {faces.shape}")
    origin, frame_scale = bounding_frame(vertices)
    scale = frame_scale if scale is None else float(scale)
    centred = vertices / scale - origin / scale
    corners = centred[faces]
    # det[v_0 - x, ..., v_{N-1} - x] = det[v_0 - x, v_1 - v_0, ...] = (v_0 - x) . normal
    edges = corners[:, 1:, :] - corners[:, :1, :]  # (m, N-1, N)
    normals = generalized_cross(np.moveaxis(edges, 0, -1)).T
    topology = cage_topology(faces, len(vertices))
    return PreparedCage(
        vertices=centred,
        origin=origin,
        scale=scale,
        size=float(np.linalg.norm(np.ptp(centred, axis=0))),
        topology=topology,
        facet_normals=normals,
        facet_offsets=np.einsum("mn,mn->m", corners[:, 0, :], normals),
        **_ridge_polynomials(centred[topology.ridges]),
    )


def _ridge_polynomials(corners):
    """Coefficients of the per-(point, ridge) quantities as polynomials in x.

    Parameters
    ----------
    corners : (r, p, N) float
        Ridge vertex positions (centred).

    Returns
    -------
    dict of the ``ridge_*`` fields of :class:`PreparedCage`.
    """
    count, size, dim = corners.shape
    slots = corners.transpose(1, 2, 0)  # (p, N, r)
    sides = corners[:, :, None, :] - corners[:, None, :, :]  # (r, p, p, N)
    cross_linear = np.zeros((dim, count, dim))
    for slot in range(size):
        for axis in range(dim):
            # d/dx_axis of gcross(v_1 - x, ..., v_p - x): minus the cross product with
            # the unit vector in this slot (the other slots keep their vertices).
            replaced = slots.copy()
            replaced[slot] = 0.0
            replaced[slot, axis] = 1.0
            cross_linear[:, :, axis] -= generalized_cross(replaced)
    return {
        "ridge_side_lengths_squared": np.einsum("rabN,rabN->abr", sides, sides)[..., None],
        "ridge_cross_constant": generalized_cross(slots)[..., None],
        "ridge_cross_linear": cross_linear,
    }


class PointFrame:
    """Per (ridge, point) and per (facet, point) quantities for a chunk of k points.

    Points run along the last axis and components along the first, so that every
    operation works on long contiguous rows and gathering a ridge's data for a facet
    copies whole rows. Each quantity is computed on first use: Wachspress and Voronoi
    scalars, for one, need the Gram matrices but no cross products.

    Attributes
    ----------
    ridge_gram : (p, p, r, k) float
        ``e_a . e_b`` for the p = N-1 vertices a, b of each ridge (ascending order).
    ridge_cross : (N, r, k) float
        Generalized cross product of the ridge's vectors ``e`` in ascending order.
    ridge_measure_squared, ridge_measure : (r, k) float
        Its squared norm and norm: (N-1)! times the (N-1)-volume of {x} + ridge.
    facet_det : (m, k) float
        ``det E_T``: N! times the signed volume of {x} + facet (positive inside).
    """

    def __init__(self, cage, points, facet_det=None):
        self._cage = cage
        # Polynomials in x with precomputed coefficients: a few small matrix products.
        # The cage is centred, so rounding is of the order of computing e = v - x first.
        self._x = cage.local(points)
        if facet_det is not None:
            self.facet_det = np.ascontiguousarray(facet_det)  # rows are gathered per ridge

    @property
    def centred_points(self):
        """The points relative to the cage's origin: (k, N) float."""
        return self._x

    @cached_property
    def vertex_lengths_squared(self):
        """``|e|^2 = |v - x|^2`` of every cage vertex: (n, k) float.

        From the differences, not ``|v|^2 - 2 v.x + |x|^2``: exact to rounding even for
        x next to v, where the expanded form would cancel.
        """
        vertices, x = self._cage.vertices, self._x
        total = np.subtract.outer(vertices[:, 0], x[:, 0])
        total *= total
        for axis in range(1, vertices.shape[1]):
            difference = np.subtract.outer(vertices[:, axis], x[:, axis])
            difference *= difference
            total += difference
        return total

    @cached_property
    def ridge_gram(self):
        cage = self._cage
        size = cage.ridge_side_lengths_squared.shape[0]
        gram = np.empty((size, size, len(cage.topology.ridges), len(self._x)))
        for a in range(size):
            np.take(self.vertex_lengths_squared, cage.topology.ridges[:, a], axis=0, out=gram[a, a])
        for a in range(size):
            for b in range(a + 1, size):
                np.add(gram[a, a], gram[b, b], out=gram[a, b])
                gram[a, b] -= cage.ridge_side_lengths_squared[a, b]
                gram[a, b] *= 0.5
                gram[b, a] = gram[a, b]
        return gram

    @cached_property
    def ridge_cross(self):
        cross = self._cage.ridge_cross_linear @ self._x.T
        cross += self._cage.ridge_cross_constant
        return cross

    @cached_property
    def ridge_measure_squared(self):
        return _sum_of_products(self.ridge_cross, self.ridge_cross)

    @cached_property
    def ridge_measure(self):
        return np.sqrt(self.ridge_measure_squared)

    @cached_property
    def facet_det(self):
        return np.ascontiguousarray((self._cage.facet_offsets - self._x @ self._cage.facet_normals.T).T)

    @property
    def ridge_lengths_squared(self):
        """``|e|^2`` of each ridge vertex: (p, r, k) float."""
        return np.take(self.vertex_lengths_squared, self._cage.topology.ridges.T, axis=0)

    @property
    def ridge_size(self):
        """p = N-1, the vertices of a ridge: int."""
        return self._cage.topology.ridges.shape[1]


def point_frame(cage, points, facet_det=None):
    """The :class:`PointFrame` of a chunk of points.

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float
        In the caller's (world) coordinates (mapped to the cage's frame here).
    facet_det : (m, k) float, optional
        Already computed determinants (:func:`facet_determinants`, transposed).

    Returns
    -------
    PointFrame
    """
    return PointFrame(cage, points, facet_det)


def _sum_of_products(a, b):
    """Dot products over the first (component) axis: (N, ...) x (N, ...) -> (...)."""
    total = a[0] * b[0]
    for c in range(1, len(a)):
        total += a[c] * b[c]
    return total


def facet_determinants(cage, points):
    """``det E_T`` for every point and facet: N! times the signed volume of {x} + T.

    Affine in x, so one matrix product; positive inside a convex cage.

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float
        World coordinates.

    Returns
    -------
    det : (k, m) float
        In the cage's frame (world values are ``scale ** N`` times these).
    """
    x = cage.local(points)
    return cage.facet_offsets - x @ cage.facet_normals.T


def construct_weights(cage, frame, ridge_scalars, skip_facets=None):
    """Homogeneous weights of the general construction for given ridge scalars.

    With ``r^T = sum_j d_j m_j / |m_j|`` the coefficients ``u_i^T = r^T . m_i / det E``
    expand into

        u_i^T = (d_i |m_i| + sum_{j != i} (m_i . m_j) d_j / |m_j|) / det E,

    d_i being the scalar of the ridge opposite slot i. Each ``m_i`` is a ridge's cross
    product up to its orientation sign, so per facet this gathers N ridge vectors and
    two scalars per ridge; the dot products of cross products keep full precision even
    where the ridge vectors are long and the cross products short (fine cages).

    Parameters
    ----------
    cage : PreparedCage
    frame : PointFrame
        Of k points.
    ridge_scalars : (r, k) float
        d per (ridge, point): the signed (N-1)-volume enclosed by x and the projected
        ridge on the generating surface.
    skip_facets : (m, k) bool, optional
        Facets whose contribution is taken as zero (mean value coordinates, for points
        in a facet's supporting hyperplane but off the facet, where the term's limit is
        zero and its formula is 0/0).

    Returns
    -------
    weights : (n, k) float
        ``w_i = sum_T u_i^T``; homogeneous: ``sum_i w_i (v_i - x) = 0``.
    """
    topology = cage.topology
    dim = cage.dimension
    facets = len(topology.faces)
    measure = frame.ridge_measure
    # Per ridge, rows 0..N-1: the cross product; N: d / |m|; N+1: d |m| (= |m|^2 d / |m|).
    ridge_terms = np.empty((len(measure), dim + 2, measure.shape[1]))
    for c in range(dim):
        ridge_terms[:, c] = frame.ridge_cross[c]
    with np.errstate(divide="ignore", invalid="ignore"):
        # A ridge through x (|m| = 0) encloses nothing.
        ridge_terms[:, dim] = np.where(measure > 0.0, ridge_scalars / measure, 0.0)
        np.multiply(ridge_scalars, measure, out=ridge_terms[:, dim + 1])
        inverse_det = 1.0 / frame.facet_det
    if skip_facets is not None:
        inverse_det[skip_facets] = 0.0
    per_slot = [np.take(ridge_terms, topology.facet_ridges[:, i], axis=0) for i in range(dim)]  # (m, N+2, k)
    signs = topology.facet_ridge_signs
    # u_i^T for every facet slot (slot-major rows) plus a zero row for the padding.
    coefficients = np.zeros((dim * facets + 1, measure.shape[1]))
    slot_rows = [coefficients[i * facets:(i + 1) * facets] for i in range(dim)]
    for i in range(dim):
        slot_rows[i] += per_slot[i][:, dim + 1]
        for j in range(i + 1, dim):
            # m_i . m_j, shared by the terms of slots i and j
            cofactor_dot = _sum_of_products(per_slot[i][:, :dim].swapaxes(0, 1),
                                            per_slot[j][:, :dim].swapaxes(0, 1))
            cofactor_dot *= (signs[:, i] * signs[:, j])[:, None]
            slot_rows[i] += cofactor_dot * per_slot[j][:, dim]
            slot_rows[j] += cofactor_dot * per_slot[i][:, dim]
    for rows in slot_rows:
        rows *= inverse_det
    # w_i = sum over the facet slots of vertex i (eq. 6).
    return sum_rows(coefficients, topology.vertex_slots)


def sum_rows(rows, table):
    """Per-owner sums of rows, by a :func:`gencoords.base.topology.gather_table`.

    Parameters
    ----------
    rows : (L + 1, k) float
        Per-item values; the last row must be zero (the table's padding reads it).
    table : (n, w) int

    Returns
    -------
    sums : (n, k) float
    """
    total = np.take(rows, table[:, 0], axis=0)
    for column in range(1, table.shape[1]):
        total += np.take(rows, table[:, column], axis=0)
    return total
