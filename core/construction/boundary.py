"""Where points are with respect to the cage, and coordinates on its boundary.

On the boundary the coordinates' limit is the linear (barycentric) interpolation in the
facet, edge or vertex the point lies on; the same holds for the nearest boundary point
of an outside point (``outside="project"``).
"""

import numpy as np

from ..base.grid import column_pairs, fit_grid, inside_nodes, surface_cells
from ..base.simplex import closest_points_on_simplices

__all__ = ["INSIDE", "BOUNDARY", "OUTSIDE", "plane_distances", "locate", "winding_numbers", "inside_lookup",
           "inside_by_grid", "inside_points", "outside_points", "plane_limit_coordinates", "nearest_boundary_coordinates"]

INSIDE, BOUNDARY, OUTSIDE = 1, 0, -1
_PAIR_CHUNK = 1 << 16  # (point, facet) pairs per closest-point batch: bounded memory
_WINDING_PAIRS = 1 << 14  # (point, facet) pairs per winding-number batch: about 20 temporaries of 128 kB, held in
# the caches (at 1 << 16, 0.5 MB each, the cup's winding numbers took 2.9 times as long)
# Cells along the longest side of the grid points are looked up in before winding numbers
# (:func:`inside_lookup`): points in cells the surface does not cross need none.
LOOKUP_RESOLUTION = 128
# A cage whose facets would test more (facet, grid column) pairs than this to build the
# grid (long facets slanted across it: their boxes cover most columns, and the surface
# most cells, so the grid would save little) has none: winding numbers for every point.
LOOKUP_PAIRS = 1 << 22


def plane_distances(cage, facet_det):
    """Signed distance of each point to each facet's hyperplane, positive inside.

    Parameters
    ----------
    cage : PreparedCage
    facet_det : (k, m) float
        From :func:`gencoords.construction.general.facet_determinants`.

    Returns
    -------
    distances : (k, m) float
    """
    return facet_det / np.linalg.norm(cage.facet_normals, axis=1)[None, :]


def winding_numbers(cage, points):
    """Generalized winding number of a closed 2D or 3D cage around each point.

    1 inside, 0 outside (for nested or self-overlapping cages, the signed count).

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float

    Returns
    -------
    winding : (k,) float
    """
    dim = cage.dimension
    if dim not in (2, 3):
        raise NotImplementedError("winding numbers are implemented for 2D and 3D cages")
    x = cage.local(points)
    facets = cage.vertices[cage.topology.faces]  # (m, N corners, N)
    # One (k, m) array per corner and axis: contiguous arithmetic, several times faster
    # than (k, m, N, N) blocks reduced over their short last axis.
    corners = [[facets[None, :, corner, axis] - x[:, axis, None] for axis in range(dim)]
               for corner in range(dim)]
    if dim == 2:  # signed angle subtended by each edge
        (ax, ay), (bx, by) = corners
        angle = np.arctan2(ax * by - ay * bx, ax * bx + ay * by)
        return angle.sum(axis=1) / (2.0 * np.pi)
    # Signed solid angle of each triangle (Van Oosterom and Strackee).
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = corners
    la, lb, lc = (np.sqrt(u * u + v * v + w * w) for u, v, w in corners)
    triple = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
    denominator = (la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (ax * cx + ay * cy + az * cz) * lb
                   + (bx * cx + by * cy + bz * cz) * la)
    return (2.0 * np.arctan2(triple, denominator)).sum(axis=1) / (4.0 * np.pi)


def inside_lookup(cage, resolution=LOOKUP_RESOLUTION):
    """A grid over a 3D cage's box for :func:`inside_by_grid`: (grid, cell_inside, surface).

    Parameters
    ----------
    cage : PreparedCage
    resolution : int
        Cells along the box's longest side.

    Returns
    -------
    grid : gencoords.base.grid.Grid
        In the cage's frame.
    cell_inside : (x, y, z) bool over cells
        Whether each cell's lowest node is inside (winding number 1, one ray per grid
        column): the whole cell's status where the surface does not cross it.
    surface : (x, y, z) bool over cells
        Cells the surface may cross (conservative).

    None where building it would test more than ``LOOKUP_PAIRS`` (facet, column) pairs.
    """
    grid = fit_grid(cage.vertices, resolution)
    corners = cage.facet_corners()
    if column_pairs(grid, corners) > LOOKUP_PAIRS:
        return None
    nodes = inside_nodes(grid, corners)
    return grid, nodes[:-1, :-1, :-1], surface_cells(grid, corners, 1e-6 * grid.spacing)


def inside_by_grid(cage, local, grid, cell_inside, surface):
    """Whether points are inside a 3D cage (winding number >= 1/2), looked up on a grid.

    A cell the surface does not cross is inside or outside whole, as its nodes are; the
    points in the others get their winding numbers (:func:`winding_numbers`), a batch at
    a time. The cost is thus that of the points near the surface, not of all.

    Parameters
    ----------
    cage : PreparedCage
    local : (k, 3) float
        Points in the cage's frame (``cage.local``).
    grid, cell_inside, surface
        As :func:`inside_lookup` gives them (any grid in the frame covering the cage).

    Returns
    -------
    inside : (k,) bool
    crossed : (c,) int
        The points that were in cells the surface may cross.
    """
    lowest = np.floor((local - grid.origin) / grid.spacing).astype(np.int64)
    in_grid = ((lowest >= 0) & (lowest < np.array(grid.cells))).all(axis=1)
    cell = tuple(lowest.clip(0, np.array(grid.cells) - 1).T)
    inside = in_grid & cell_inside[cell]
    crossed = np.flatnonzero(in_grid & surface[cell])
    chunk = max(1, _WINDING_PAIRS // len(cage.topology.faces))
    for start in range(0, len(crossed), chunk):
        rows = crossed[start:start + chunk]
        inside[rows] = winding_numbers(cage, local[rows] * cage.scale + cage.origin) >= 0.5
    return inside, crossed


def inside_points(cage, points):
    """Whether each point is inside the cage (winding number >= 1/2): (k,) bool. 3D cages
    look points up in their cached grid first (:func:`inside_by_grid`)."""
    if cage.dimension != 3 or cage.inside_lookup is None:
        return winding_numbers(cage, points) >= 0.5
    return inside_by_grid(cage, cage.local(points), *cage.inside_lookup)[0]


def outside_points(cage, points, tolerance, convex, inside=None):
    """The points outside the cage beyond ``tolerance`` (what :data:`OUTSIDE` means to
    :func:`locate`), found without their coordinates: those not inside (a convex cage:
    behind a facet's plane; another: the grid lookup and winding numbers of
    :func:`inside_points`), less those near enough to a facet, looked for only among the
    facets whose boxes grown by ``tolerance`` hold them (the others are farther).

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float
    tolerance : float
        Absolute distance in the cage's frame (as :func:`locate`'s).
    convex : bool
        Whether the cage is convex.
    inside : (k,) bool, optional
        Filled with whether each point is inside (behind every facet's plane, or its
        winding number at least 1/2): the rest are the candidates, for whoever tests
        the points again (a harmonic field, whose quads are patches: ``in_quad_boxes``).

    Returns
    -------
    outside : (o,) int
        Indices into ``points``, ascending.
    """
    if convex:
        normals = cage.facet_normals / np.linalg.norm(cage.facet_normals, axis=1)[:, None]
        offsets = cage.facet_offsets / np.linalg.norm(cage.facet_normals, axis=1)
        chunk = max(1, _PAIR_CHUNK * 16 // len(normals))  # (point, facet) distances a batch
        depth = np.concatenate([(offsets - cage.local(points[start:start + chunk]) @ normals.T).min(axis=1)
                                for start in range(0, len(points), chunk)] or [np.empty(0)])
        found = depth >= 0.0
    else:
        found = inside_points(cage, points)
    if inside is not None:
        inside[...] = found
    candidates = np.flatnonzero(~found)
    remaining = points[candidates]
    local = cage.local(remaining)
    corners = cage.facet_corners()  # (m, N, N)
    low, high = corners.min(axis=1) - tolerance, corners.max(axis=1) + tolerance
    touching = np.zeros(len(candidates), dtype=bool)
    chunk = max(1, _PAIR_CHUNK // len(corners))  # (point, facet) pairs a batch: bounded memory
    for start in range(0, len(candidates), chunk):
        x = local[start:start + chunk, None, :]
        point_index, facet_index = np.nonzero(((x >= low) & (x <= high)).all(axis=2))
        which, _, _, distance = _nearest_of_pairs(cage, remaining, start + point_index, facet_index)
        touching[which[distance <= tolerance]] = True
    return candidates[~touching]


def _nearest_of_pairs(cage, points, point_index, facet_index):
    """Nearest candidate facet point for each point, from (point, facet) pairs.

    Returns
    -------
    which : (u,) int
        Points that had candidates (indices into ``points``), ascending.
    facet : (u,) int
    barycentric : (u, N) float
    distance : (u,) float
    """
    corners = cage.facet_corners()
    x = cage.local(points)
    barycentric = np.empty((len(point_index), cage.dimension))
    distance = np.empty(len(point_index))
    for start in range(0, len(point_index), _PAIR_CHUNK):
        batch = slice(start, start + _PAIR_CHUNK)
        _, barycentric[batch], distance[batch] = closest_points_on_simplices(
            x[point_index[batch]], corners[facet_index[batch]])
    order = np.lexsort((distance, point_index))
    first = order[np.r_[True, point_index[order][1:] != point_index[order][:-1]]] if len(order) else order
    return point_index[first], facet_index[first], barycentric[first], distance[first]


def _scatter_barycentric(cage, facet, barycentric):
    rows = np.zeros((len(facet), len(cage.vertices)))
    rows[np.arange(len(facet))[:, None], cage.topology.faces[facet]] = barycentric
    return rows


def locate(cage, points, plane_distance, tolerance, convex):
    """Classify points as inside, on the boundary (within tolerance) or outside.

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float
    plane_distance : (k, m) float
        From :func:`plane_distances`.
    tolerance : float
        Absolute distance (already scaled by the cage size).
    convex : bool
        Convex cages need only the plane distances; others use winding numbers.

    Returns
    -------
    location : (k,) int8
        :data:`INSIDE`, :data:`BOUNDARY` or :data:`OUTSIDE`.
    limit : (b, n) float
        Limit coordinates of the b boundary points, in ascending point order.
    """
    location = np.full(len(points), INSIDE, dtype=np.int8)
    if convex:
        # A point deeper than the tolerance is inside; one beyond a facet's plane by
        # more is outside. Slightly outside near a sharp vertex can be within tolerance
        # of every plane yet farther from the cage: the facet distance decides.
        depth = plane_distance.min(axis=1)
        location[depth < 0.0] = OUTSIDE
        candidates = np.flatnonzero(np.abs(depth) <= tolerance)
    else:
        location[~inside_points(cage, points)] = OUTSIDE
        candidates = np.arange(len(points))
    # Only facets whose hyperplane passes within tolerance can be touched.
    near_point, facet_index = np.nonzero(np.abs(plane_distance[candidates]) <= tolerance)
    which, facet, barycentric, distance = _nearest_of_pairs(cage, points, candidates[near_point], facet_index)
    touching = distance <= tolerance
    location[which[touching]] = BOUNDARY
    return location, _scatter_barycentric(cage, facet[touching], barycentric[touching])


def plane_limit_coordinates(cage, points, plane_distance):
    """Coordinates of outside points lying on a facet's supporting hyperplane.

    Outside a convex cage the convex-only kinds' weights have poles on the facets'
    hyperplanes, yet the coordinates have a finite limit there: the terms of that facet
    dominate, so they tend to the affine coordinates of x in the facet's hyperplane
    (negative where x is beyond the facet's edges; linear precision holds).

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float
    plane_distance : (k, m) float
        From :func:`plane_distances`; the facet whose hyperplane is nearest is used.

    Returns
    -------
    coordinates : (k, n) float
    """
    facet = np.argmin(np.abs(plane_distance), axis=1)
    corners = cage.facet_corners()[facet]  # (k, N, N): rows are the facet's vertices
    x = cage.local(points)
    # Least squares for sum(l) = 1, sum(l_i c_i) = x (exact when x is in the hyperplane).
    system = np.concatenate([np.swapaxes(corners, 1, 2), np.ones((len(x), 1, corners.shape[1]))], axis=1)
    target = np.concatenate([x, np.ones((len(x), 1))], axis=1)[..., None]
    normal = np.swapaxes(system, 1, 2)
    affine = np.linalg.solve(normal @ system, normal @ target)[..., 0]
    return _scatter_barycentric(cage, facet, affine)


def nearest_boundary_coordinates(cage, points):
    """Coordinates of the nearest boundary point of each point (linear in its facet).

    Parameters
    ----------
    cage : PreparedCage
    points : (k, N) float

    Returns
    -------
    coordinates : (k, n) float
    distance : (k,) float
    """
    count, facets = len(points), len(cage.topology.faces)
    point_index = np.repeat(np.arange(count), facets)
    facet_index = np.tile(np.arange(facets), count)
    _, facet, barycentric, distance = _nearest_of_pairs(cage, points, point_index, facet_index)
    return _scatter_barycentric(cage, facet, barycentric), distance
