"""The values harmonic coordinates take at grid nodes on or outside the cage.

On the cage's surface harmonic coordinates are its "hat" functions: on a triangle, the
barycentric coordinates of its three corners; on a quad (a cage given as polygons), its
bilinear hats on the bilinear patch through its corners, whichever corner it lists
first. A grid node outside the cage takes the hat values of its nearest boundary point
(as Blender's Mesh Deform does), so each row has at most three (triangles) or four
(polygons) non-zero entries, all non-negative, summing to 1.

Faces are (m, 3) triangles or (m, 4) polygons, a triangle's fourth index -1; the columns
returned for polygons are 4 wide, a triangle's fourth its first corner with value 0.
"""

import numpy as np

from ..base.arrays import in_row_blocks
from ..construction.quad_cage import bilinear_parameters
from ..construction.quad_integrals import bilinear_hats, corner_normals


__all__ = ["closest_on_triangles", "boxed_pairs", "nearest_boundary_points", "segment_crossings",
           "patch_crossings", "between_split_and_patch"]

_PAIR_CHUNK = 1 << 16  # (node, facet) pairs measured at a time: bounded memory
_RANGE_CHUNK = 1 << 20  # (node, facet) pairs in x tested at a time: bounded memory
_SLAB_ROUNDING = 1e-6  # of the reach: a facet's slab grown by this against rounding
_SLACK = 1e-12  # an edge or vertex crossed belongs to both sides: no miss between them
# Positions or segments measured at a time (``in_row_blocks``): their (node, facet) pairs,
# about 25 each, are made before they are measured (the cup's: 40 MB at once).
_ROWS_AT_A_TIME = 1 << 11


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


def boxed_pairs(positions, corners, reach):
    """(node, facet) pairs whose facet's box, grown by ``reach``, holds the node: (p,) int
    each, by facet (a node's pairs thus in facet order).

    The nodes sorted along one axis, each facet's range of them along it is cut out of the
    sorted array, a batch of facets at a time (bounded memory, no loop over the facets),
    and tested on the other two axes. The axis is the one whose ranges hold the fewest
    (node, facet) pairs (a cup revolved about z: not z)."""
    low, high = corners.min(axis=1) - reach, corners.max(axis=1) + reach
    ranges = []
    for axis in range(3):
        order = np.argsort(positions[:, axis], kind="stable")
        sorted_axis = positions[order, axis]
        starts = np.searchsorted(sorted_axis, low[:, axis], side="left")
        counts = np.maximum(np.searchsorted(sorted_axis, high[:, axis], side="right") - starts, 0)
        ranges.append((int(counts.sum()), axis, order, starts, counts))
    _, axis, order, starts, counts = min(ranges, key=lambda found: found[:2])
    others = [other for other in range(3) if other != axis]
    sorted_others = np.ascontiguousarray(positions[order][:, others].T)
    ends = np.cumsum(counts)
    begins = ends - counts
    nodes, facets = [], []
    first = 0
    while first < len(counts):  # facets whose ranges hold about _RANGE_CHUNK nodes together
        last = max(first + 1, int(np.searchsorted(ends, begins[first] + _RANGE_CHUNK, side="right")))
        facet = np.repeat(np.arange(first, last), counts[first:last])
        rank = starts[facet] + np.arange(len(facet)) - (begins[facet] - begins[first])
        inside = np.ones(len(rank), dtype=bool)
        for row, other in enumerate(others):
            coordinate = sorted_others[row, rank]
            inside &= (coordinate >= low[facet, other]) & (coordinate <= high[facet, other])
        nodes.append(order[rank[inside]])
        facets.append(facet[inside])
        first = last
    return (np.concatenate(nodes) if nodes else np.empty(0, dtype=np.int64),
            np.concatenate(facets) if facets else np.empty(0, dtype=np.int64))


def _near_the_slab(positions, corners, node, facet, reach):
    """The (node, facet) pairs whose node is within ``reach`` of the facet's slab (the
    band between its corners' extreme heights along its normal, which holds a quad's
    patch too): a facet slanted across its box is farther than ``reach`` from most of the
    box's nodes. Conservative: a facet within ``reach`` of its node is kept."""
    normals = np.cross(corners[:, 2] - corners[:, 0], corners[:, -1] - corners[:, 1])  # a triangle's: its last is its first
    lengths = np.linalg.norm(normals, axis=1)
    normals /= np.where(lengths > 0.0, lengths, 1.0)[:, None]
    heights = np.einsum("mcN,mN->mc", corners, normals)
    slack = reach * (1.0 + _SLAB_ROUNDING)
    bottom, top = heights.min(axis=1) - slack, heights.max(axis=1) + slack
    height = np.einsum("pN,pN->p", positions[node], normals[facet])
    near = (height >= bottom[facet]) & (height <= top[facet])
    return node[near], facet[near]


def _padded(faces):
    """The faces with a polygon's padding (-1) as its first corner: valid indices."""
    return np.where(faces >= 0, faces, faces[:, :1])


def _closest(points, corners, quad):
    """Each point's closest point on its face: (hat values (p, w), distance (p,)); a
    quad's by :func:`gencoords.construction.quad_cage.bilinear_parameters` (from the
    patch's centre, so the same whichever corner is first)."""
    if corners.shape[1] == 3:
        return closest_on_triangles(points, corners)
    values, distance = np.zeros((len(points), 4)), np.empty(len(points))
    values[~quad, :3], distance[~quad] = closest_on_triangles(points[~quad], corners[~quad, :3])
    parameters, distance[quad] = bilinear_parameters(points[quad], corners[quad])
    values[quad] = bilinear_hats(parameters[:, 0], parameters[:, 1])
    return values, distance


def _possibly_nearest(positions, corners, quad, node, facet):
    """The (node, facet) pairs that may hold the node's nearest point. A quad's patch is
    within a quarter of its twist (``c0 - c1 + c2 - c3``) of its two triangles, so a quad
    whose triangles are farther than another face's by more than both quarters cannot:
    the costlier patch distances are measured for the others alone."""
    slack = np.where(quad, 0.25 * np.linalg.norm(corners[:, 0] - corners[:, 1] + corners[:, 2] - corners[:, 3],
                                                 axis=1), 0.0)
    split = np.empty(len(node))
    for start in range(0, len(node), _PAIR_CHUNK):
        batch = slice(start, start + _PAIR_CHUNK)
        here, faces = positions[node[batch]], corners[facet[batch]]
        split[batch] = np.minimum(closest_on_triangles(here, faces[:, :3])[1],
                                  closest_on_triangles(here, faces[:, [0, 2, 3]])[1])
    farthest = np.full(len(positions), np.inf)
    np.minimum.at(farthest, node, split + slack[facet])
    keep = split - slack[facet] <= farthest[node]
    return node[keep], facet[keep]


def _nearest(positions, corners, quad, node, facet):
    """Per node, the nearest of its candidate facets: (facet, hat values (., w), distance),
    with facet -1 and distance inf for nodes without candidates."""
    width = corners.shape[1]
    if width == 4:
        node, facet = _possibly_nearest(positions, corners, quad, node, facet)
    barycentric = np.empty((len(node), width))
    distance = np.empty(len(node))
    for start in range(0, len(node), _PAIR_CHUNK):
        batch = slice(start, start + _PAIR_CHUNK)
        barycentric[batch], distance[batch] = _closest(positions[node[batch]], corners[facet[batch]],
                                                       quad[facet[batch]])
    best_facet = np.full(len(positions), -1)
    best_barycentric = np.zeros((len(positions), width))
    best_distance = np.full(len(positions), np.inf)
    order = np.lexsort((distance, node))
    first = order[np.r_[True, node[order][1:] != node[order][:-1]]] if len(order) else order
    best_facet[node[first]] = facet[first]
    best_barycentric[node[first]] = barycentric[first]
    best_distance[node[first]] = distance[first]
    return best_facet, best_barycentric, best_distance


def nearest_boundary_points(positions, vertices, faces, reach, widen=True):
    """Each position's nearest point on the cage.

    Parameters
    ----------
    positions : (b, 3) float
    vertices : (n, 3) float
    faces : (m, w) int
        Outward-oriented triangles (w = 3) or polygons (w = 4, a triangle's fourth -1).
    reach : float
        A distance within which most positions have their nearest boundary point (for
        speed only: positions farther away are measured again with a wider reach).
    widen : bool
        False: positions farther than ``reach`` are not measured again (distance inf,
        hat values 0, columns 0): where only the positions within it are asked for.

    Returns
    -------
    columns : (b, w) int
        Cage vertices of each position's nearest face (a triangle's fourth: its first).
    barycentric : (b, w) float
        The cage's hat values at the nearest point (on a quad its bilinear hats):
        non-negative, each row summing to 1.
    distance : (b,) float
    """
    if len(positions) > _ROWS_AT_A_TIME:
        return in_row_blocks(lambda block: nearest_boundary_points(block, vertices, faces, reach, widen),
                             _ROWS_AT_A_TIME, positions)
    quad = faces[:, -1] >= 0 if faces.shape[1] == 4 else np.zeros(len(faces), dtype=bool)
    if faces.shape[1] == 4 and not quad.any():  # polygons all triangles (the cup): no patch to bound
        columns, barycentric, distance = nearest_boundary_points(positions, vertices, faces[:, :3], reach, widen)
        return np.column_stack([columns, columns[:, 0]]), np.pad(barycentric, ((0, 0), (0, 1))), distance
    corners = vertices[_padded(faces)]
    # A facet within ``reach`` is among the candidates: wider for the others. The pairs
    # farther than ``reach`` are left out (the nearest of those left is the same).
    pairs = _near_the_slab(positions, corners, *boxed_pairs(positions, corners, reach), reach)
    facet, barycentric, distance = _nearest(positions, corners, quad, *pairs)
    far = np.flatnonzero(distance > reach)
    if not widen:
        facet[far], barycentric[far], distance[far] = -1, 0.0, np.inf
        return np.where(facet[:, None] >= 0, _padded(faces)[facet], 0), barycentric, distance
    while len(far):
        reach *= 4.0
        pairs = _near_the_slab(positions[far], corners, *boxed_pairs(positions[far], corners, reach), reach)
        found = _nearest(positions[far], corners, quad, *pairs)
        facet[far], barycentric[far], distance[far] = found
        far = far[found[2] > reach]
    return _padded(faces)[facet], barycentric, distance


def _triangle_crossings(starts, steps, corners):
    """Where each line ``start + t step`` meets the plane of its triangle: (t, u, v, usable),
    (u, v) the crossing's barycentric coordinates towards the second and third corners."""
    a = corners[:, 0]
    first, second = corners[:, 1] - a, corners[:, 2] - a
    normal = np.cross(steps, second)
    determinant = np.einsum("pN,pN->p", first, normal)
    usable = np.abs(determinant) > 1e-14 * np.einsum("pN,pN->p", first, first) * np.abs(steps).max(axis=1)
    inverse = np.where(usable, 1.0 / np.where(usable, determinant, 1.0), 0.0)
    offset = starts - a
    u = np.einsum("pN,pN->p", offset, normal) * inverse
    across = np.cross(offset, first)
    v = np.einsum("pN,pN->p", steps, across) * inverse
    t = np.einsum("pN,pN->p", second, across) * inverse
    return t, u, v, usable


def _triangle_hits(starts, steps, corners):
    """Segments ``start + t step`` (0 <= t <= 1) crossing their triangle: (hit (p,) bool,
    t (p,), barycentric (p, 3))."""
    t, u, v, usable = _triangle_crossings(starts, steps, corners)
    hit = usable & (u >= -_SLACK) & (v >= -_SLACK) & (u + v <= 1.0 + _SLACK) & (t >= -_SLACK) & (t <= 1.0)
    u, v = u.clip(0.0, 1.0), v.clip(0.0, 1.0)
    total = np.maximum(1.0, u + v)
    return hit, t.clip(0.0, 1.0), np.column_stack([1.0 - (u + v) / total, u / total, v / total])


def patch_crossings(starts, steps, corners):
    """Where each line ``start + t step`` meets its bilinear patch (u, v in [0, 1]).

    The line is the meet of two planes through it; on the patch
    ``c0 + u e1 + v e3 + u v twist`` each plane's equation is bilinear in (u, v), and
    eliminating v leaves a quadratic in u (docs/MATH.md, "Harmonic coordinates on quads").

    Parameters
    ----------
    starts, steps : (p, 3) float
    corners : (p, 4, 3) float

    Returns
    -------
    t : (p, 2) float
        The line's parameter at the (up to two) crossings; nan where there is none.
    hats : (p, 2, 4) float
        The patch's bilinear hats there.
    """
    c0, c1, c2, c3 = (corners[:, i] for i in range(4))
    helper = np.eye(3)[np.argmin(np.abs(steps), axis=1)]
    first = np.cross(steps, helper)
    planes = (first, np.cross(steps, first))
    terms = [[np.einsum("pN,pN->p", normal, part) for part in (c0 - starts, c1 - c0, c3 - c0, c0 - c1 + c2 - c3)]
             for normal in planes]
    (a1, b1, c1_, d1), (a2, b2, c2_, d2) = terms
    square, linear, constant = b1 * d2 - b2 * d1, a1 * d2 - a2 * d1 + b1 * c2_ - b2 * c1_, a1 * c2_ - a2 * c1_
    discriminant = linear * linear - 4.0 * square * constant
    with np.errstate(divide="ignore", invalid="ignore"):
        half = -0.5 * (linear + np.copysign(np.sqrt(discriminant), linear))  # no cancellation
        u = np.stack([half / square, constant / half], axis=1)  # a vanishing square: the second only
        below1, below2 = c1_[:, None] + d1[:, None] * u, c2_[:, None] + d2[:, None] * u
        v = np.where(np.abs(below1) >= np.abs(below2), -(a1[:, None] + b1[:, None] * u) / below1,
                     -(a2[:, None] + b2[:, None] * u) / below2)
    inside = np.isfinite(u) & np.isfinite(v) & (u >= -_SLACK) & (u <= 1 + _SLACK) & (v >= -_SLACK) & (v <= 1 + _SLACK)
    u, v = np.where(inside, u, 0.5).clip(0.0, 1.0), np.where(inside, v, 0.5).clip(0.0, 1.0)
    hats = bilinear_hats(u, v)
    miss = np.einsum("pki,piN->pkN", hats, corners) - starts[:, None]
    t = np.einsum("pkN,pN->pk", miss, steps) / np.einsum("pN,pN->p", steps, steps)[:, None]
    return np.where(inside, t, np.nan), hats


def _crossings(starts, steps, corners, quad):
    """Each segment's crossings of its face: (hit (p,) bool, t (p,), hat values (p, w)), a
    segment crossing a quad's patch twice counted at the nearer crossing."""
    if corners.shape[1] == 3:
        return _triangle_hits(starts, steps, corners)
    hit, t, values = np.zeros(len(starts), dtype=bool), np.zeros(len(starts)), np.zeros((len(starts), 4))
    hit[~quad], t[~quad], values[~quad, :3] = _triangle_hits(starts[~quad], steps[~quad], corners[~quad, :3])
    found, hats = patch_crossings(starts[quad], steps[quad], corners[quad])
    found = np.where((found >= -_SLACK) & (found <= 1.0), found, np.inf)
    nearer = np.argmin(found, axis=1)
    rows = np.arange(len(found))
    hit[quad], t[quad] = np.isfinite(found[rows, nearer]), found[rows, nearer].clip(0.0, 1.0)
    values[quad] = hats[rows, nearer]
    return hit, t, values


def segment_crossings(starts, steps, vertices, faces):
    """Where each segment ``start + t step`` (0 <= t <= 1) first meets the cage.

    Parameters
    ----------
    starts, steps : (s, 3) float
    vertices : (n, 3) float
    faces : (m, w) int
        Triangles (w = 3) or polygons (w = 4, a triangle's fourth -1; a quad its patch).

    Returns
    -------
    fraction : (s,) float
        The smallest t of a crossing; inf where the segment meets no face.
    columns : (s, w) int
        The crossed face's vertices (a triangle's fourth: its first).
    barycentric : (s, w) float
        The cage's hat values at the crossing: non-negative, summing to 1.
    """
    padded, reach = _padded(faces), 0.5 * np.abs(steps).max(axis=1).max(initial=0.0)
    quad = faces[:, -1] >= 0 if faces.shape[1] == 4 else np.zeros(len(faces), dtype=bool)
    # Blocks of segments, each boxed with every segment's reach: a segment's candidates
    # (the facets whose boxes meet its own) do not depend on its block.
    return in_row_blocks(lambda *block: _first_crossings(*block, vertices[padded], quad, padded, reach),
                         _ROWS_AT_A_TIME, starts, steps)


def _first_crossings(starts, steps, corners, quad, padded, reach):
    """:func:`segment_crossings` among the facets whose boxes, grown by ``reach``, hold the middles."""
    segment, facet = boxed_pairs(starts + 0.5 * steps, corners, reach)
    fraction = np.full(len(starts), np.inf)
    columns = np.zeros((len(starts), padded.shape[1]), dtype=np.int64)
    barycentric = np.zeros((len(starts), padded.shape[1]))
    for start in range(0, len(segment), _PAIR_CHUNK):
        rows, chosen = segment[start:start + _PAIR_CHUNK], facet[start:start + _PAIR_CHUNK]
        hit, t, values = _crossings(starts[rows], steps[rows], corners[chosen], quad[chosen])
        rows, chosen, t, values = rows[hit], chosen[hit], t[hit], values[hit]
        order = np.lexsort((t, rows))  # per segment its nearest crossing first
        rows, chosen, t, values = rows[order], chosen[order], t[order], values[order]
        nearest = np.r_[True, rows[1:] != rows[:-1]] if len(rows) else np.zeros(0, dtype=bool)
        rows, chosen, t, values = rows[nearest], chosen[nearest], t[nearest], values[nearest]
        closer = t < fraction[rows]
        rows, chosen, t, values = rows[closer], chosen[closer], t[closer], values[closer]
        fraction[rows] = t
        columns[rows] = padded[chosen]
        barycentric[rows] = values
    return fraction, columns, barycentric


def between_split_and_patch(positions, vertices, polygons):
    """Whether each position lies between a quad's bilinear patch and its two triangles
    of :func:`gencoords.construction.quad_cage.fan_split` (the cage inside or outside
    there depending on which surface is taken): (b,) bool.

    The patch and the two triangles close a thin volume; a point is in it when a ray
    from it along the quad's mean normal crosses the two surfaces an odd number of times
    (the diagonal counted once: the second triangle's side of it open).
    """
    quads = np.flatnonzero(polygons[:, 3] >= 0)
    corners = vertices[polygons[quads]]
    normal = corner_normals(corners).sum(axis=1)
    twist = corners[:, 0] - corners[:, 1] + corners[:, 2] - corners[:, 3]
    bent = np.abs(np.einsum("qN,qN->q", twist, normal)) > 1e-12 * np.einsum("qN,qN->q", normal, normal)
    corners, normal = corners[bent], normal[bent]  # flat quads: the patch is its two triangles
    flips = np.zeros(len(positions), dtype=bool)
    if not len(corners):
        return flips
    node, face = boxed_pairs(positions, corners, 0.0)
    for start in range(0, len(node), _PAIR_CHUNK):
        rows, chosen = node[start:start + _PAIR_CHUNK], face[start:start + _PAIR_CHUNK]
        here, ahead, patch = positions[rows], normal[chosen], corners[chosen]
        count = (patch_crossings(here, ahead, patch)[0] > 0.0).sum(axis=1)
        for triangle, open_diagonal in (([0, 1, 2], False), ([0, 2, 3], True)):
            t, u, v, usable = _triangle_crossings(here, ahead, patch[:, triangle])
            edge = v > 0.0 if open_diagonal else v >= -_SLACK  # (0, 2, 3)'s v = 0: the diagonal
            count += usable & (t > 0.0) & (u >= -_SLACK) & edge & (u + v <= 1.0 + _SLACK)
        np.logical_xor.at(flips, rows, count % 2 == 1)
    return flips
