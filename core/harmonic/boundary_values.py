"""The values harmonic coordinates take at grid nodes on or outside the cage.

On the cage's surface harmonic coordinates are its piecewise-linear "hat" functions:
on a triangle, the barycentric coordinates of its three corners. A grid node outside
the cage takes the hat values of its nearest boundary point (as Blender's Mesh Deform
does), so each row has at most three non-zero entries, all non-negative, summing to 1.
"""

import numpy as np


__all__ = ["closest_on_triangles", "nearest_boundary_points", "hat_values", "segment_crossings"]

_PAIR_CHUNK = 1 << 16  # (node, facet) pairs measured at a time: bounded memory


def closest_on_triangles(points, corners):
    """Closest point of each triangle to each point.

    Parameters
    ----------
    points : (p, 3) float
    corners : (p, 3, 3) float
        One triangle per point.

    Returns
    -------
    barycentric : (p, 3) float
        Of the closest point: non-negative, summing to 1.
    distance : (p,) float
    """
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    normal = np.cross(b - a, c - a)
    area = np.einsum("pN,pN->p", normal, normal)
    # Inside the triangle: the projection's barycentric coordinates, all non-negative.
    inner = np.stack([np.einsum("pN,pN->p", np.cross(c - b, points - b), normal),
                      np.einsum("pN,pN->p", np.cross(a - c, points - c), normal),
                      np.einsum("pN,pN->p", np.cross(b - a, points - a), normal)], axis=1)
    barycentric = inner / np.where(area > 0.0, area, 1.0)[:, None]
    best = np.where((barycentric >= 0.0).all(axis=1) & (area > 0.0), 0.0, np.inf)
    # Otherwise the nearest point of the three edges.
    for first, second in ((0, 1), (1, 2), (2, 0)):
        start, edge = corners[:, first], corners[:, second] - corners[:, first]
        length = np.einsum("pN,pN->p", edge, edge)
        t = (np.einsum("pN,pN->p", points - start, edge) / np.where(length > 0.0, length, 1.0)).clip(0.0, 1.0)
        gap = points - start - t[:, None] * edge
        gap = np.einsum("pN,pN->p", gap, gap)
        closer = gap < best
        best = np.where(closer, gap, best)
        barycentric[closer] = 0.0
        barycentric[closer, first] = 1.0 - t[closer]
        barycentric[closer, second] = t[closer]
    inside = np.isfinite(best) & (best == 0.0)
    plane = np.einsum("pN,pN->p", points - a, normal) ** 2 / np.where(area > 0.0, area, 1.0)
    return barycentric, np.sqrt(np.where(inside, plane, best))


def _candidate_pairs(positions, corners, reach):
    """(node, facet) pairs whose facet's box, grown by ``reach``, holds the node."""
    low, high = corners.min(axis=1) - reach, corners.max(axis=1) + reach
    order = np.argsort(positions[:, 0], kind="stable")
    sorted_x = positions[order, 0]
    nodes, facets = [], []
    starts = np.searchsorted(sorted_x, low[:, 0], side="left")
    stops = np.searchsorted(sorted_x, high[:, 0], side="right")
    for facet, (start, stop) in enumerate(zip(starts.tolist(), stops.tolist())):
        candidates = order[start:stop]
        inside = ((positions[candidates, 1:] >= low[facet, 1:]) & (positions[candidates, 1:] <= high[facet, 1:])).all(1)
        nodes.append(candidates[inside])
        facets.append(np.full(np.count_nonzero(inside), facet))
    return np.concatenate(nodes), np.concatenate(facets)


def _nearest(positions, corners, node, facet):
    """Per node, the nearest of its candidate facets: (facet, barycentric (., 3), distance),
    with facet -1 and distance inf for nodes without candidates."""
    barycentric = np.empty((len(node), 3))
    distance = np.empty(len(node))
    for start in range(0, len(node), _PAIR_CHUNK):
        batch = slice(start, start + _PAIR_CHUNK)
        barycentric[batch], distance[batch] = closest_on_triangles(positions[node[batch]], corners[facet[batch]])
    best_facet = np.full(len(positions), -1)
    best_barycentric = np.zeros((len(positions), 3))
    best_distance = np.full(len(positions), np.inf)
    order = np.lexsort((distance, node))
    first = order[np.r_[True, node[order][1:] != node[order][:-1]]] if len(order) else order
    best_facet[node[first]] = facet[first]
    best_barycentric[node[first]] = barycentric[first]
    best_distance[node[first]] = distance[first]
    return best_facet, best_barycentric, best_distance


def nearest_boundary_points(positions, vertices, triangles, reach):
    """Each position's nearest point on the cage.

    Parameters
    ----------
    positions : (b, 3) float
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward-oriented triangles.
    reach : float
        A distance within which most positions have their nearest boundary point (for
        speed only: positions farther away are measured again with a wider reach).

    Returns
    -------
    columns : (b, 3) int
        Cage vertices of each position's nearest triangle.
    barycentric : (b, 3) float
        The nearest point's barycentric coordinates in it (the cage's hat values there):
        non-negative, each row summing to 1.
    distance : (b,) float
    """
    corners = vertices[triangles]
    facet, barycentric, distance = _nearest(positions, corners, *_candidate_pairs(positions, corners, reach))
    far = np.flatnonzero(distance > reach)
    while len(far):  # a facet within ``reach`` is among the candidates: wider for the others
        reach *= 4.0
        found = _nearest(positions[far], corners, *_candidate_pairs(positions[far], corners, reach))
        facet[far], barycentric[far], distance[far] = found
        far = far[found[2] > reach]
    return triangles[facet], barycentric, distance


def hat_values(positions, vertices, triangles, reach):
    """The cage's hat values at each position's nearest boundary point: (columns (b, 3)
    int, values (b, 3) float), as :func:`nearest_boundary_points`."""
    columns, values, _ = nearest_boundary_points(positions, vertices, triangles, reach)
    return columns, values


def _crossing_pairs(starts, steps, corners):
    """(segment, facet) pairs whose boxes overlap: every facet a segment meets is among them."""
    middles, reach = starts + 0.5 * steps, 0.5 * np.abs(steps).max(axis=1).max(initial=0.0)
    return _candidate_pairs(middles, corners, reach)


def segment_crossings(starts, steps, vertices, triangles):
    """Where each segment ``start + t step`` (0 <= t <= 1) first meets the cage.

    Parameters
    ----------
    starts, steps : (s, 3) float
    vertices : (n, 3) float
    triangles : (m, 3) int

    Returns
    -------
    fraction : (s,) float
        The smallest t of a crossing; inf where the segment meets no triangle.
    columns : (s, 3) int
        The crossed triangle's vertices.
    barycentric : (s, 3) float
        The crossing's barycentric coordinates in it (its hat values): non-negative,
        summing to 1.
    """
    corners = vertices[triangles]
    segment, facet = _crossing_pairs(starts, steps, corners)
    fraction = np.full(len(starts), np.inf)
    columns = np.zeros((len(starts), 3), dtype=np.int64)
    barycentric = np.zeros((len(starts), 3))
    for start in range(0, len(segment), _PAIR_CHUNK):
        rows, faces = segment[start:start + _PAIR_CHUNK], facet[start:start + _PAIR_CHUNK]
        a = corners[faces, 0]
        first, second = corners[faces, 1] - a, corners[faces, 2] - a
        direction = steps[rows]
        normal = np.cross(direction, second)
        determinant = np.einsum("pN,pN->p", first, normal)
        usable = np.abs(determinant) > 1e-14 * np.einsum("pN,pN->p", first, first) * np.abs(direction).max(axis=1)
        inverse = np.where(usable, 1.0 / np.where(usable, determinant, 1.0), 0.0)
        offset = starts[rows] - a
        u = np.einsum("pN,pN->p", offset, normal) * inverse
        across = np.cross(offset, first)
        v = np.einsum("pN,pN->p", direction, across) * inverse
        t = np.einsum("pN,pN->p", second, across) * inverse
        slack = 1e-12  # an edge or vertex crossed belongs to both sides: no miss between them
        hit = usable & (u >= -slack) & (v >= -slack) & (u + v <= 1.0 + slack) & (t >= -slack) & (t <= 1.0)
        rows, faces, t = rows[hit], faces[hit], t[hit].clip(0.0, 1.0)
        u, v = u[hit].clip(0.0, 1.0), v[hit].clip(0.0, 1.0)
        order = np.lexsort((t, rows))  # per segment its nearest crossing first
        rows, faces, t, u, v = rows[order], faces[order], t[order], u[order], v[order]
        nearest = np.r_[True, rows[1:] != rows[:-1]] if len(rows) else np.zeros(0, dtype=bool)
        rows, faces, t, u, v = rows[nearest], faces[nearest], t[nearest], u[nearest], v[nearest]
        closer = t < fraction[rows]
        rows, faces, t, u, v = rows[closer], faces[closer], t[closer], u[closer], v[closer]
        fraction[rows] = t
        columns[rows] = triangles[faces]
        total = np.maximum(1.0, u + v)
        barycentric[rows] = np.column_stack([1.0 - (u + v) / total, u / total, v / total])
    return fraction, columns, barycentric
