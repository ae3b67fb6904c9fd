"""Geometry of single simplices in R^N, vectorised over leading axes.

These are the primitives the construction is built from: the generalized cross product
(the cofactor vector ``m_i`` of docs/MATH.md), and the closest point of a simplex to a point
(for boundary limits and ``outside="project"``).
"""

from itertools import combinations

import numpy as np

__all__ = ["generalized_cross", "closest_points_on_simplices"]


def generalized_cross(vectors):
    """Generalized cross product of N-1 vectors in R^N, vector axes first.

    The result ``c`` satisfies ``det[a, b_1, ..., b_{N-1}] = a . c`` for every ``a``, so it
    is orthogonal to every ``b`` and its norm is the (N-1)-volume of the parallelotope
    they span (``(N-1)!`` times that of their simplex with the origin).

    Parameters
    ----------
    vectors : (N-1, N, ...) float
        ``vectors[j, c]`` is component c of ``b_{j+1}``; trailing axes are batch axes
        (components first keeps every operation on long contiguous rows).

    Returns
    -------
    cross : (N, ...) float
        N=2: ``(b_y, -b_x)``; N=3: ``b_1 x b_2``; otherwise by cofactor expansion.
    """
    vectors = np.asarray(vectors, dtype=np.float64)
    dim = vectors.shape[1]
    if vectors.shape[0] != dim - 1:
        raise ValueError(f"need {dim - 1} vectors in R^{dim}, got shape {vectors.shape}")
    if dim == 2:
        return np.stack([vectors[0, 1], -vectors[0, 0]])
    if dim == 3:
        (a0, a1, a2), (b0, b1, b2) = vectors
        return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    # Expand det[a, B] along its first column: c_j = (-1)^j det(B without row j).
    columns = np.moveaxis(vectors, (0, 1), (-1, -2))  # (..., N, N-1): column k is b_k
    return np.stack([(-1.0) ** j * np.linalg.det(np.delete(columns, j, axis=-2)) for j in range(dim)])


def closest_points_on_simplices(points, simplices):
    """Closest point of each simplex to each point, with its barycentric coordinates.

    Every face of the simplex (vertices, edges, ..., the simplex itself) is tried: the
    closest point is the nearest orthogonal projection onto a face's affine hull that
    falls inside that face. Exact in any dimension; meant for the few points near or
    outside the boundary, not for bulk evaluation.

    Parameters
    ----------
    points : (p, N) float
    simplices : (p, s, N) float
        One simplex with s vertices (s <= N) per point.

    Returns
    -------
    closest : (p, N) float
    barycentric : (p, s) float
        Non-negative, summing to 1; zero on the vertices of faces not touched.
    distance : (p,) float
    """
    points = np.asarray(points, dtype=np.float64)
    simplices = np.asarray(simplices, dtype=np.float64)
    count, corners, _ = simplices.shape
    best_distance = np.full(count, np.inf)
    best_barycentric = np.zeros((count, corners))
    for size in range(1, corners + 1):
        for face in combinations(range(corners), size):
            face = list(face)
            base = simplices[:, face[0], :]
            offset = points - base
            if size == 1:
                local = np.zeros((count, 0))
            else:
                edges = simplices[:, face[1:], :] - base[:, None, :]  # (p, size-1, N)
                gram = edges @ np.swapaxes(edges, -1, -2)
                rhs = (edges @ offset[:, :, None])[..., 0]
                local = np.linalg.solve(gram, rhs[..., None])[..., 0]
            barycentric_face = np.concatenate([1.0 - local.sum(axis=1, keepdims=True), local], axis=1)
            inside = np.all(barycentric_face >= 0.0, axis=1)
            projected = base + (np.einsum("pk,pkn->pn", local, edges) if size > 1 else 0.0)
            distance = np.linalg.norm(points - projected, axis=1)
            better = inside & (distance < best_distance)
            if np.any(better):
                best_distance[better] = distance[better]
                best_barycentric[better] = 0.0
                best_barycentric[np.ix_(better, face)] = barycentric_face[better]
    closest = np.einsum("ps,psn->pn", best_barycentric, simplices)
    return closest, best_barycentric, best_distance
