"""Self-intersection of triangle meshes: which pairs of triangles cross each other.

A cage that passes through itself has no inside: its winding number is 2 or -1 in places
and its coordinates are meaningless there. Two triangles intersect when an edge of one
crosses the other (signed volumes of opposite signs at the edge's ends, and the edge's
line passing inside the triangle's three edges); triangles in one plane intersect when
their edges cross or a corner of one lies inside the other. Contacts at shared
corners and edges (every neighbour in a closed mesh) are not crossings: only proper
crossings count, judged to a tolerance relative to the mesh's size, so triangles that
only touch are not reported.

Candidate pairs come from overlapping bounding boxes (all pairs, a block at a time), the
tests are vectorised over pairs.
"""

import numpy as np

__all__ = ["triangles_intersect", "self_intersections"]

_BLOCK = 1 << 18  # pairs of triangles per block: bounded memory on large meshes


def _orient(a, b, c, d):
    """Six times the signed volume of the tetrahedra (a, b, c, d); each (p, 3)."""
    return np.einsum("pi,pi->p", np.cross(b - a, c - a), d - a)


def _edge_crosses(a, b, c, p, q, eps):
    """Whether segment p-q crosses triangle (a, b, c) at one interior point; each (p, 3)."""
    dp, dq = _orient(a, b, c, p), _orient(a, b, c, q)
    ends = ((dp > eps) & (dq < -eps)) | ((dp < -eps) & (dq > eps))
    sides = np.stack([_orient(p, q, a, b), _orient(p, q, b, c), _orient(p, q, c, a)])
    inside = (sides > eps).all(axis=0) | (sides < -eps).all(axis=0)
    return ends & inside


def _cross_2d(a, b, c):
    """Twice the signed area of the triangles (a, b, c); each (p, 2)."""
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _strictly_inside_2d(point, tri, eps):
    """Whether ``point`` (p, 2) lies inside the triangles ``tri`` (p, 3, 2), off their edges."""
    areas = np.stack([_cross_2d(tri[:, i], tri[:, (i + 1) % 3], point) for i in range(3)])
    return (areas > eps).all(axis=0) | (areas < -eps).all(axis=0)


def _coplanar_overlap(first, second, normal, eps):
    """Whether coplanar triangles (p, 3, 3) overlap in more than shared corners or edges."""
    # Project on the coordinate plane the normal is most perpendicular to.
    drop = np.abs(normal).argmax(axis=1)
    keep = np.stack([(drop + 1) % 3, (drop + 2) % 3], axis=1)
    a = np.take_along_axis(first, keep[:, None, :], axis=2)
    b = np.take_along_axis(second, keep[:, None, :], axis=2)
    found = np.zeros(len(first), dtype=bool)
    for i in range(3):
        found |= _strictly_inside_2d(a[:, i], b, eps) | _strictly_inside_2d(b[:, i], a, eps)
        for j in range(3):
            p, q = a[:, i], a[:, (i + 1) % 3]
            r, s = b[:, j], b[:, (j + 1) % 3]
            d1, d2 = _cross_2d(r, s, p), _cross_2d(r, s, q)
            d3, d4 = _cross_2d(p, q, r), _cross_2d(p, q, s)
            found |= (((d1 > eps) & (d2 < -eps)) | ((d1 < -eps) & (d2 > eps))) \
                & (((d3 > eps) & (d4 < -eps)) | ((d3 < -eps) & (d4 > eps)))
    return found


def triangles_intersect(first, second, tolerance=1e-9):
    """Whether each pair of triangles crosses (more than touching at corners or edges).

    Parameters
    ----------
    first, second : (p, 3, 3) float
        The pairs' corners.
    tolerance : float
        Relative to the largest extent of the pairs: volumes and areas below it (to the
        power 3 or 2) count as zero, so coplanar pairs are tested in their plane.

    Returns
    -------
    crossing : (p,) bool

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.self_intersection import triangles_intersect
    >>> flat = np.array([[[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]])
    >>> upright = np.array([[[0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [3.0, 3.0, 0.0]]])
    >>> triangles_intersect(flat, upright).tolist(), triangles_intersect(flat, upright + 5.0).tolist()
    ([True], [False])
    """
    first = np.asarray(first, dtype=np.float64).reshape(-1, 3, 3)
    second = np.asarray(second, dtype=np.float64).reshape(-1, 3, 3)
    if not len(first):
        return np.zeros(0, dtype=bool)
    scale = float(np.ptp(np.concatenate([first, second]).reshape(-1, 3), axis=0).max()) or 1.0
    volume_eps, area_eps = tolerance * scale ** 3, tolerance * scale ** 2
    normal = np.cross(first[:, 1] - first[:, 0], first[:, 2] - first[:, 0])
    heights = np.einsum("pki,pi->pk", second - first[:, :1], normal)
    coplanar = (np.abs(heights) <= volume_eps).all(axis=1)
    crossing = np.zeros(len(first), dtype=bool)
    for one, other in ((first, second), (second, first)):
        for i in range(3):
            crossing |= _edge_crosses(other[:, 0], other[:, 1], other[:, 2], one[:, i],
                                      one[:, (i + 1) % 3], volume_eps)
    if coplanar.any():
        crossing[coplanar] = _coplanar_overlap(first[coplanar], second[coplanar],
                                               normal[coplanar], area_eps)
    return crossing


def self_intersections(vertices, triangles, tolerance=1e-9):
    """Pairs of triangles of a mesh that cross each other (see :func:`triangles_intersect`).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
    tolerance : float
        Relative to the mesh's size (its bounding-box diagonal).

    Returns
    -------
    pairs : (q, 2) int64
        Indices of crossing triangles, ``pairs[:, 0] < pairs[:, 1]``; empty when the mesh
        does not pass through itself.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.self_intersection import self_intersections
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron()
    >>> self_intersections(vertices, faces).shape
    (0, 2)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    corners = vertices[triangles]
    low, high = corners.min(axis=1), corners.max(axis=1)
    slack = tolerance * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    count = len(triangles)
    found = []
    rows = max(1, _BLOCK // max(count, 1))
    for start in range(0, count, rows):
        block = np.arange(start, min(start + rows, count))
        overlap = ((low[block, None] <= high[None] + slack)
                   & (high[block, None] >= low[None] - slack)).all(axis=2)
        overlap &= block[:, None] < np.arange(count)[None]  # each pair once, no self-pairs
        i, j = np.nonzero(overlap)
        i = block[i]
        crossing = triangles_intersect(corners[i], corners[j], tolerance)
        found.append(np.column_stack([i[crossing], j[crossing]]))
    return np.concatenate(found).astype(np.int64) if found else np.zeros((0, 2), dtype=np.int64)
