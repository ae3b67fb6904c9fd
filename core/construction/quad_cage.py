"""Mean value coordinates of cages of quads and triangles, each quad its bilinear patch:
the parts (:mod:`gencoords.evaluation.quad_coordinates` puts them together).

A quad's mesh-side result does not depend on how it would be split into triangles, nor
on which corner it lists first (docs/MATH.md, "Quad cages"). The integrals are
:mod:`gencoords.construction.quad_integrals`'; here the cage is checked, points on a face
take its bilinear (quad) or linear (triangle) weights, and the quadrature's small error is
removed by the smallest change that restores linear precision and partition of unity.
"""

import numpy as np

from ..base.errors import CageError
from ..base.simplex import closest_points_on_simplices
from ..surfaces.named import MEAN_VALUE_QUADS
from .quad_integrals import bilinear_hats, corner_normals, quad_weights, triangle_weights
from .validation import DEFAULT_TOLERANCE, validate_cage

__all__ = ["MEAN_VALUE_QUADS", "fan_split", "validate_polygons", "boundary_rows",
           "bilinear_parameters", "integrated_weights", "restore_linear_precision"]

# (point, quad, Gauss node) entries per chunk of points: temporaries of a few tens of MB.
_CHUNK_ENTRIES = 1 << 20
# A quad corner whose normal has less than this share of the largest corner normal along
# the quad's mean normal folds the patch over itself (or nearly: the patch is degenerate).
_FOLD_SHARE = 1e-6
_NEWTON_STEPS = 30


def fan_split(polygons):
    """Triangles of the polygons, each quad (a, b, c, d) as (a, b, c) and (a, c, d).

    Parameters
    ----------
    polygons : (m, 4) int
        A triangle's fourth index is -1.

    Returns
    -------
    triangles : (t, 3) int
    owner : (t,) int
        The polygon each triangle comes from.
    """
    quads = polygons[:, 3] >= 0
    owner = np.concatenate([np.arange(len(polygons)), np.flatnonzero(quads)])
    triangles = np.concatenate([polygons[:, :3], polygons[quads][:, [0, 2, 3]]])
    order = np.argsort(owner, kind="stable")
    return triangles[order], owner[order]


def validate_polygons(vertices, polygons, tolerance=DEFAULT_TOLERANCE):
    """Raise :class:`CageError` naming the polygon for a cage that cannot be used.

    Closed, manifold, consistently oriented outward (checked on :func:`fan_split`'s
    triangles, the faces named as polygons), and no quad folded over itself: each quad's
    corner normals (``p_u x p_v`` at its corners) all point the way of their sum, so the
    bilinear patch's normal never vanishes or turns over (a bow-tie, a corner pushed across
    the opposite diagonal, or three corners in a line).

    Parameters
    ----------
    vertices : (n, 3) float
    polygons : (m, 4) int
    tolerance : float
    """
    triangles, owner = fan_split(polygons)
    try:
        validate_cage(vertices, triangles, convex=False, tolerance=tolerance)
    except CageError as error:
        named = sorted({int(owner[face]) for face in error.faces})
        where = f" (face numbers of the quads' split into triangles; the polygons: {named})" if named else ""
        raise CageError(error.problem, f"{error}{where}", faces=named, vertices=error.vertices) from None
    quads = np.flatnonzero(polygons[:, 3] >= 0)
    normals = corner_normals(vertices[polygons[quads]])
    mean = normals.sum(axis=1)
    along = np.einsum("qij,qj->qi", normals, mean) / np.maximum(np.linalg.norm(mean, axis=1), 1e-300)[:, None]
    folded = (along <= _FOLD_SHARE * np.linalg.norm(normals, axis=2).max(axis=1)[:, None]).any(axis=1)
    if folded.any():
        face = int(quads[np.flatnonzero(folded)[0]])
        raise CageError("folded_quad", f"quad {face} folds over itself (a bow-tie, a corner pushed across the "
                                       "opposite diagonal, or three corners in a line): move the corner back "
                                       "or split the quad into triangles", faces=[face])


def bilinear_parameters(points, corners):
    """The nearest point of each bilinear patch to each point, by Gauss-Newton in (u, v).

    Parameters
    ----------
    points : (p, 3) float
    corners : (p, 4, 3) float

    Returns
    -------
    parameters : (p, 2) float
        (u, v) in [0, 1], from the centre; exact for a point on its patch.
    distance : (p,) float
    """
    u = np.full(len(points), 0.5)
    v = np.full(len(points), 0.5)
    active = np.arange(len(points))
    for _ in range(_NEWTON_STEPS):
        # A point whose step left (u, v) as they were is at a fixed point: the steps left
        # would repeat it, so only the others step on (the same values, a part of the work).
        if not len(active):
            break
        here, ua, va = corners[active], u[active], v[active]
        c0, c1, c2, c3 = (here[:, i] for i in range(4))
        du = (1 - va)[:, None] * (c1 - c0) + va[:, None] * (c2 - c3)
        dv = (1 - ua)[:, None] * (c3 - c0) + ua[:, None] * (c2 - c1)
        miss = points[active] - np.einsum("pi,pij->pj", bilinear_hats(ua, va), here)
        uu, uv, vv = np.einsum("pN,pN->p", du, du), np.einsum("pN,pN->p", du, dv), np.einsum("pN,pN->p", dv, dv)
        along_u, along_v = np.einsum("pN,pN->p", du, miss), np.einsum("pN,pN->p", dv, miss)
        determinant = uu * vv - uv * uv  # the 2 x 2 normal equations by Cramer's rule
        inverse = np.where(determinant > 0.0, 1.0 / np.where(determinant > 0.0, determinant, 1.0), 0.0)
        u[active] = np.clip(ua + (vv * along_u - uv * along_v) * inverse, 0.0, 1.0)
        v[active] = np.clip(va + (uu * along_v - uv * along_u) * inverse, 0.0, 1.0)
        active = active[(u[active] != ua) | (v[active] != va)]
    nearest = np.einsum("pi,pij->pj", bilinear_hats(u, v), corners)
    return np.stack([u, v], axis=1), np.linalg.norm(points - nearest, axis=1)


def boundary_rows(points, vertices, polygons, absolute):
    """Points within ``absolute`` of a face: their face's bilinear or linear weights.

    Returns (b,) point indices and their (b, n) rows; the nearest face wins.
    """
    corners = vertices[np.where(polygons >= 0, polygons, polygons[:, :1])]  # a triangle's first corner twice
    centre = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centre[:, None], axis=2).max(axis=1)
    normal = corner_normals(corners).sum(axis=1)
    step = max(1, _CHUNK_ENTRIES // len(polygons))
    pairs = [_straddling(points[start:start + step], corners, centre, radius + absolute, normal, absolute, start)
             for start in range(0, len(points), step)]
    point, face = (np.concatenate(found) for found in zip(*pairs)) if pairs else (np.zeros(0, int),) * 2
    quad = polygons[face, 3] >= 0
    hats = np.zeros((len(point), 4))
    distance = np.zeros(len(point))
    parameters, distance[quad] = bilinear_parameters(points[point[quad]], corners[face[quad]])
    hats[quad] = bilinear_hats(parameters[:, 0], parameters[:, 1])
    _, hats[~quad, :3], distance[~quad] = closest_points_on_simplices(points[point[~quad]],
                                                                      corners[face[~quad], :3])
    near = distance <= absolute
    order = np.lexsort((distance[near], point[near]))  # by point, nearest face first
    point, face, hats = point[near][order], face[near][order], hats[near][order]
    first = np.diff(point, prepend=-1) != 0
    point, face, hats = point[first], face[first], hats[first]
    rows = np.zeros((len(point), len(vertices)))
    columns = polygons[face]
    np.add.at(rows, (np.repeat(np.arange(len(point)), 4), np.where(columns >= 0, columns, 0).ravel()),
              np.where(columns >= 0, hats, 0.0).ravel())
    return point, rows


def _straddling(points, corners, centre, reach, normal, absolute, offset):
    """(point, face) pairs of faces possibly within ``absolute`` of the points: in reach of
    the face's centre, and (a patch lies in the convex hull of its corners) the face's
    corners on both sides of the point along the face's mean normal, to ``absolute``."""
    # Squared distances as one matrix product: a filter, with a sliver of slack for rounding.
    squared = (points ** 2).sum(axis=1)[:, None] - 2.0 * points @ centre.T + (centre ** 2).sum(axis=1)
    point, face = np.nonzero(squared <= reach ** 2 * (1.0 + 1e-9) + 1e-18)
    heights = np.einsum("pij,pj->pi", corners[face] - points[point, None], normal[face])
    slack = absolute * np.linalg.norm(normal[face], axis=1)
    straddle = (heights.min(axis=1) <= slack) & (heights.max(axis=1) >= -slack)
    return point[straddle] + offset, face[straddle]


def _scatter(values, faces, vertex_count):
    """Sum face-corner values into vertex columns: (c, f, s), (f, s) int -> (c, n)."""
    cells = (np.arange(len(values))[:, None] * vertex_count + faces.ravel()[None]).ravel()
    return np.bincount(cells, values.ravel(), len(values) * vertex_count).reshape(len(values), vertex_count)


def integrated_weights(points, vertices, polygons):
    """The mean value weights (integrals) of every cage vertex, and the cage's solid angle.

    Parameters
    ----------
    points : (k, 3) float
        In the cage's unit-sized frame, none on a face.
    vertices : (n, 3) float
        In the same frame.
    polygons : (m, 4) int

    Returns
    -------
    weights : (k, n) float
    solid_angle : (k,) float
        4 pi inside the cage, 0 outside.
    """
    quads, triangles = polygons[polygons[:, 3] >= 0], polygons[polygons[:, 3] < 0, :3]
    weights, solid = np.zeros((len(points), len(vertices))), np.zeros(len(points))
    step = max(1, _CHUNK_ENTRIES // (16 * max(len(quads), 1) + 3 * len(triangles)))
    for start in range(0, len(points), step):
        chunk = points[start:start + step]
        on_quads, solid[start:start + step] = quad_weights(chunk, vertices[quads])
        relative = vertices[triangles][None] - chunk[:, None, None]
        on_triangles, angles = triangle_weights(relative.reshape(-1, 3, 3))
        weights[start:start + step] = (_scatter(on_quads, quads, len(vertices))
                                       + _scatter(on_triangles.reshape(len(chunk), -1, 3), triangles, len(vertices)))
        solid[start:start + step] += angles.reshape(len(chunk), -1).sum(axis=1)
    return weights, solid


def restore_linear_precision(coordinates, vertices, points):
    """The smallest change of each row that makes it sum to 1 and reproduce its point.

    ``coordinates - A^T (A A^T)^-1 (A coordinates - b)``, A = [vertices^T; 1], b = [x; 1].

    Parameters
    ----------
    coordinates : (k, n) float
    vertices : (n, 3) float
    points : (k, 3) float

    Returns
    -------
    corrected : (k, n) float
    change : (k,) float
        The largest entry of each row's change: the quadrature's error.
    """
    affine = np.vstack([vertices.T, np.ones(len(vertices))])
    correction = (coordinates @ affine.T - np.column_stack([points, np.ones(len(points))])) @ np.linalg.solve(
        affine @ affine.T, affine)
    return coordinates - correction, np.abs(correction).max(axis=1, initial=0.0)
