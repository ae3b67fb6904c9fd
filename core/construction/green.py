"""Green coordinates (Lipman, Levin and Cohen-Or, SIGGRAPH 2008) of points in a closed
triangle cage, convex or not, in closed form (docs/MATH.md, "Green coordinates").

``phi`` (one per cage vertex) and ``psi`` (one per face) reproduce a point inside the
cage from the vertices and the faces' unit outward normals,
``x = sum_i phi_i v_i + sum_j psi_j n_j``, and deform it by
``sum_i phi_i v'_i + sum_j psi_j s_j n'_j`` (s_j the face's stretch factor): a
similarity of the cage moves the point by the same similarity, and a stretch keeps
details' shape better than affine-invariant coordinates.

:func:`green_rows` is the loop body over one chunk of points
(:func:`gencoords.evaluation.rows.evaluate_rows` calls it for kind ``"green"``, in this
process or in workers); :func:`gencoords.green_coordinates` is the entry point.
"""

from dataclasses import dataclass

import numpy as np

from ..base import tolerances
from .boundary import BOUNDARY, INSIDE, OUTSIDE, locate, nearest_boundary_coordinates, plane_distances
from .general import facet_determinants, sum_rows
from ..base.errors import OutsideCageError
from .units import to_world

__all__ = ["GREEN", "GREEN_LABEL", "GREEN_DESCRIPTION", "GreenTerms", "green_terms", "green_chunk_size", "green_rows",
           "GreenOutsideError"]

# The name the evaluation knows Green coordinates by (they are no generating surface
# of the paper's family, so not in KIND_TABLE), and how people see them.
GREEN = "green"
GREEN_LABEL = "Green"  # short: the Properties editor's default width shows it whole
GREEN_DESCRIPTION = ("Shape-preserving: keeps details' shape when the cage stretches or bends "
                     "(similarity invariant, uses the cage's face normals); any closed triangle cage")

# (point, face) pairs per chunk: about 20 (m, k) float64 temporaries stay within a few MB.
_CHUNK_PAIRS = 16 << 10
_FOUR_PI = 4.0 * np.pi


class GreenOutsideError(OutsideCageError):
    """Some points lie outside the cage: Green coordinates reproduce only inside points.

    An :class:`~gencoords.base.errors.OutsideCageError` (``indices`` lists every outside point),
    with a message naming what Green coordinates accept.
    """

    def __init__(self, indices, total):
        self.indices = indices
        first = ", ".join(str(int(i)) for i in indices[:5]) + (", ..." if len(indices) > 5 else "")
        ValueError.__init__(self, f"{len(indices)} of {total} points lie outside the cage (first: "
                                  f"{first}); Green coordinates do not extrapolate: pass "
                                  "outside='project' to use the nearest boundary point")


@dataclass(frozen=True)
class GreenTerms:
    """Per-face constants of the closed form, in the cage's frame (m faces; slot i of a
    face is its vertex i and the edge opposite it, from vertex i+1 to i+2).

    Attributes
    ----------
    unit_normals : (m, 3) float
        Outward unit normals.
    edge_lengths : (3, m) float
    edge_normals : (3, m, 3) float
        In-plane unit normal of each edge, pointing out of the triangle.
    edge_cosines : (3, 3, m) float
        ``edge_normals[i] . edge_normals[j]``.
    hat_gradients : (3, m) float
        ``edge_lengths / (2 area)``: the hat function of vertex i is this times the
        distance to the opposite edge's line.
    ridge_vectors : (3, r, 1) float
        Each edge of ``cage.topology.ridges``, from its first vertex to its second.
    ridge_lengths : (r, 1) float
        Their lengths.
    """

    unit_normals: np.ndarray
    edge_lengths: np.ndarray
    edge_normals: np.ndarray
    edge_cosines: np.ndarray
    hat_gradients: np.ndarray
    ridge_vectors: np.ndarray
    ridge_lengths: np.ndarray


def green_terms(cage):
    """The :class:`GreenTerms` of a prepared 3D cage (:class:`gencoords.construction.general.PreparedCage`)."""
    corners = cage.facet_corners()  # (m, 3, 3)
    doubled_normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    doubled_area = np.linalg.norm(doubled_normal, axis=1)
    unit_normals = doubled_normal / doubled_area[:, None]
    edges = np.stack([corners[:, (i + 2) % 3] - corners[:, (i + 1) % 3] for i in range(3)])  # (3, m, 3)
    lengths = np.linalg.norm(edges, axis=2)
    # Counter-clockwise seen from the outward normal: edge x normal points out of the triangle.
    edge_normals = np.cross(edges, unit_normals[None]) / lengths[..., None]
    cosines = np.einsum("imc,jmc->ijm", edge_normals, edge_normals)
    ends = cage.vertices[cage.topology.ridges]
    ridge_vectors = ends[:, 1] - ends[:, 0]
    return GreenTerms(unit_normals, lengths, edge_normals, cosines, lengths / doubled_area[None],
                      ridge_vectors.T[:, :, None], np.linalg.norm(ridge_vectors, axis=1)[:, None])


def green_chunk_size(cage):
    """Points per chunk for a prepared cage: int."""
    return max(1, _CHUNK_PAIRS // len(cage.topology.faces))


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _edge_integrals(a, b, ra, rb, edge, length):
    """``integral over the edge [a, b] of 1/|xi - x| ds`` for offsets a = v_a - x, b = v_b - x.

    ``log((R_a + R_b + L) / (R_a + R_b - L))``, with ``R_a + R_b - L`` computed without
    cancellation: ``2 (R_a R_b + a.b) / (R_a + R_b + L)``, and where a.b < 0 (x beside the
    edge) ``R_a R_b + a.b = |a x (b - a)|^2 / (R_a R_b - a.b)``. On the edge itself the
    value is infinite: it is capped (finite, ~700), the callers' factors vanish there.

    Parameters
    ----------
    a, b : (3, r, k) float
        Offsets of the r edges' ends, components first.
    ra, rb : (r, k) float
        Their norms.
    edge : (3, r, 1) float
        ``b - a``, the edge vector (from the vertices: no rounding of the offsets in it).
    length : (r, 1) float

    Returns
    -------
    integrals : (r, k) float
    """
    dot = _dot(a, b)
    product = ra * rb
    beside = _cross(a, edge)
    gap = np.where(dot < 0.0, _dot(beside, beside) / np.maximum(product - dot, tolerances.TINY), product + dot)
    shortfall = np.maximum(2.0 * gap / (ra + rb + length), tolerances.TINY)  # R_a + R_b - L
    return np.log1p(2.0 * length / shortfall)


def _face_integrals(cage, terms, x):
    """Per (face, point) pieces of the closed form.

    Parameters
    ----------
    cage : gencoords.construction.general.PreparedCage
    terms : GreenTerms
    x : (k, 3) float
        Points, in the frame.

    Returns
    -------
    solid_angle : (m, k) float
        Signed solid angle of the face seen from x (positive from inside).
    height : (m, k) float
        ``n . (v - x)``: distance of x below the face's plane (positive inside).
    edge_distance : (3, m, k) float
        Distance of x's projection to each edge's line (positive towards the face).
    edge_integral : (3, m, k) float
        Integral of 1/|xi - x| along each edge.
    """
    # Components first: every product below runs on long contiguous (m, k) rows. Offsets
    # and distances once per vertex, edge integrals once per edge (each serves two faces).
    vertex_offsets = cage.vertices.T[:, :, None] - x.T[:, None, :]  # (3, n, k)
    vertex_distances = np.sqrt(_dot(vertex_offsets, vertex_offsets))  # (n, k)
    faces = cage.topology.faces
    offsets = [vertex_offsets[:, faces[:, corner]] for corner in range(3)]  # 3 x (3, m, k)
    e0, e1, e2 = offsets
    r0, r1, r2 = (vertex_distances[faces[:, corner]] for corner in range(3))
    # Van Oosterom and Strackee: tan(omega / 2) = det / denominator.
    denominator = r0 * r1 * r2 + _dot(e0, e1) * r2 + _dot(e0, e2) * r1 + _dot(e1, e2) * r0
    solid_angle = 2.0 * np.arctan2(_dot(e0, _cross(e1, e2)), denominator)
    height = _dot(terms.unit_normals.T[:, :, None], e0)
    edge_distance = np.stack([_dot(terms.edge_normals[i].T[:, :, None], offsets[(i + 1) % 3]) for i in range(3)])
    ends = cage.topology.ridges
    per_edge = _edge_integrals(vertex_offsets[:, ends[:, 0]], vertex_offsets[:, ends[:, 1]],
                               vertex_distances[ends[:, 0]], vertex_distances[ends[:, 1]], terms.ridge_vectors,
                               terms.ridge_lengths)
    edge_integral = per_edge[cage.topology.facet_ridges.T]  # (3, m, k): slot i's edge is opposite vertex i
    return solid_angle, height, edge_distance, edge_integral


def _combine(cage, terms, solid_angle, height, edge_distance, edge_integral):
    """phi (k, n) and psi (k, m) in the frame from the per-face pieces (docs/MATH.md).

    4 pi psi_j = sum_e d_e I_e - h omega;
    4 pi phi (slot i of face j) = (L_i / 2A) (d_i omega + h sum_e (m_i . m_e) I_e).
    """
    psi = (_dot(edge_distance, edge_integral) - height * solid_angle) / _FOUR_PI
    cosines = terms.edge_cosines[..., None]  # (3, 3, m, 1)
    slot_values = np.stack([terms.hat_gradients[i][:, None] * (
        edge_distance[i] * solid_angle + height * (cosines[i, 0] * edge_integral[0] + cosines[i, 1] * edge_integral[1]
                                                   + cosines[i, 2] * edge_integral[2])) for i in range(3)])
    faces = len(terms.unit_normals)
    rows = np.concatenate([slot_values.reshape(3 * faces, -1), np.zeros((1, slot_values.shape[2]))])
    phi = sum_rows(rows, cage.topology.vertex_slots) / _FOUR_PI  # (n, k)
    return phi.T, psi.T


def _boundary_limits(cage, terms, weights):
    """The interior limits of phi and psi at boundary points given by vertex weights.

    The single-layer psi is continuous across the surface: its formula at the point is
    its limit. phi has a jump: the faces through the point (those holding its support:
    one face, the two of an edge, the fan of a vertex) see it under solid angles that
    depend on the direction of approach, but the hat functions of the point's support
    agree on them, and the sum of every face's solid angle is 4 pi inside: those faces
    together contribute the hat values times ``4 pi - sum of the other faces' angles``.
    A point within rounding of an edge but not on it needs no snapping: the neighbour
    face's angle is then some angle, and its own face's share makes up the sum while
    the hat functions of both agree there (continuous across the edge).

    Parameters
    ----------
    weights : (b, n) float
        The boundary points as vertex weights (linear coordinates in their face, edge
        or vertex: :func:`gencoords.construction.boundary.locate`'s limits); the vertices with non-zero
        weight are the support.

    Returns
    -------
    phi : (b, n) float
    psi : (b, m) float
    """
    x = weights @ cage.vertices
    faces = cage.topology.faces
    on = weights > 0.0
    touching = (on[:, faces].sum(axis=2) == on.sum(axis=1)[:, None]).T  # (m, b)
    solid_angle, height, edge_distance, edge_integral = _face_integrals(cage, terms, x)
    height = np.where(touching, 0.0, height)
    remaining = _FOUR_PI - np.where(touching, 0.0, solid_angle).sum(axis=0)
    share = remaining / touching.sum(axis=0)
    solid_angle = np.where(touching, share[None, :], solid_angle)
    return _combine(cage, terms, solid_angle, height, edge_distance, edge_integral)


def green_rows(cage, terms, points, convex, absolute, outside, phi_out, psi_out):
    """Green coordinates of one chunk of points, written into ``phi_out`` and ``psi_out``.

    Parameters
    ----------
    cage : gencoords.construction.general.PreparedCage
        A validated, closed, outward-oriented 3D cage.
    terms : GreenTerms
        ``green_terms(cage)``.
    points : (k, 3) float
        World points.
    convex : bool
        Whether the cage is convex (faster location).
    absolute : float
        Boundary tolerance, in the frame's units (``tolerance * cage.size``).
    outside : str
        ``"raise"`` (outside rows are left unwritten) or ``"project"`` (the nearest
        boundary point's limit).
    phi_out : (k, n) float32 or float64
    psi_out : (k, m) float32 or float64
        In world units (``psi`` is a length).

    Returns
    -------
    locations : (k,) int8
        1 inside, 0 on the boundary, -1 outside.
    """
    distance = plane_distances(cage, facet_determinants(cage, points))
    pieces = None
    if convex:
        where, limit = locate(cage, points, distance, absolute, convex)
    else:
        # The winding number is the faces' solid angles over 4 pi, which the formula
        # needs anyway; only points within the tolerance of a face's plane go through
        # the locator (its winding numbers and nearest faces).
        pieces = _face_integrals(cage, terms, cage.local(points))
        where = np.where(pieces[0].sum(axis=0) < 0.5 * _FOUR_PI, OUTSIDE, INSIDE).astype(np.int8)
        near = (np.abs(distance) <= absolute).any(axis=1)
        limit = np.zeros((0, len(cage.vertices)))
        if near.any():
            where[near], limit = locate(cage, points[near], distance[near], absolute, convex)
    outside_rows = where == OUTSIDE
    if outside == "raise" and outside_rows.any():
        return where
    inside = np.flatnonzero(where == INSIDE)
    phi = np.empty((len(points), len(cage.vertices)))
    psi = np.empty((len(points), len(cage.topology.faces)))
    if len(inside):
        if pieces is None:
            pieces = _face_integrals(cage, terms, cage.local(points[inside]))
        else:
            pieces = [piece[..., inside] for piece in pieces]
        phi[inside], psi[inside] = _combine(cage, terms, *pieces)
    on = np.flatnonzero(where == BOUNDARY)
    if outside == "project" and outside_rows.any():
        projected = nearest_boundary_coordinates(cage, points[outside_rows])[0]
        on = np.concatenate([on, np.flatnonzero(outside_rows)])
        limit = np.concatenate([limit, projected])
    if len(on):
        phi[on], psi[on] = _boundary_limits(cage, terms, limit)
    phi_out[...] = phi
    psi_out[...] = to_world(psi, cage.scale, 1, "psi")
    return where


