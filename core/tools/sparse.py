"""Sparse bind-data storage: per point its K largest coordinates as (cage vertex, weight)
pairs, renormalised to sum 1.

A point with coordinates ``w`` (a row of ``W``, shape (k, n)) moves by ``w @ D`` when the
cage's vertices move by ``D`` (n, 3). Local coordinates (harmonic, and any kind on a cage
where each point sees few vertices) keep nearly all of ``w``'s mass in a few entries;
sparse storage keeps the K largest (by magnitude) and divides them by their sum, so the
stored weights still sum to 1 and translations of the cage stay exact. Evaluating costs K
gathers per point whatever the cage (``gencoords_addon/sparse_graph.py``).

Two levels (harmonic coordinates: interpolations of grid-node values): the grid nodes
that interpolate the points carry their own sparse pairs over the cage, and each point
keeps its corner nodes (4: ``gencoords.harmonic.interpolation``) with their weights. The truncation then happens
at the nodes only, and a node can keep many pairs cheaply: the N nodes are few beside the
k points. Their pairs are stored stacked (:func:`stacked_columns`) in columns as long as
the points, so they take about N x K' numbers each, not k x K'.

How far the sparse form is from the exact one is measured like compact storage's
(``compact.residual_deviations``: the standard smooth motion and the worst single-vertex
drag, of the cage's diagonal) on the residual ``W - sparse(W)``; :func:`fewest_slots`
finds the smallest K that keeps both under a target.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..base import tolerances
from ..harmonic.reproduction import largest_columns, reproduce_points
from . import compact

__all__ = ["largest_pairs", "placed_pairs", "dense_weights", "interpolated", "deviations", "fewest_slots", "used_nodes",
           "stacked_columns", "unstacked", "layout_coordinates", "two_level_layout", "TwoLevelLayout", "SLOT_COUNTS", "NODE_SLOT_COUNTS",
           "filled_node_slot_counts", "automatic_node_slot_counts", "carrying_vertices"]

SLOT_COUNTS = (4, 8, 12, 16, 24, 32)  # candidate K, fewest first
# Candidate K' of grid nodes (two levels): few nodes beside the points, so many pairs are
# cheap (bench_sparse_routes.py: 48 pairs on 1,286 nodes play back in 0.8x Mesh Deform's time).
NODE_SLOT_COUNTS = (8, 16, 24, 32, 48, 64, 96, 128)
# Beyond those, Automatic tries more K', up to every cage vertex, while the nodes' pairs
# fill at most this many stored columns (each a gather over the mesh's vertex count, as one
# of the 4 corners is): the node stage then costs at most twice the vertex stage. Harmonic
# coordinates deep inside a convex cage are not local (a million points in a 642-vertex
# icosphere: 128 pairs deviate 2e-2), and there the nodes are few beside the points.
MORE_NODE_SLOT_COUNTS, NODE_COLUMN_BUDGET = (192, 256, 384, 512), 8
# Of the cage's diagonal: rows placed further from where their coordinates place them
# get other pairs (:func:`placed_pairs`).
PLACED = 1e-9
_ADDED_PRIOR = 1e-3  # the least prior weight of a vertex added to place a row
SPANNING_WIDTH = 4  # times K: the largest coordinates a row that K cannot place is placed with first
SAMPLE_POINTS = 2000  # points the fewest K' is chosen on (then measured on all)
SAMPLE_MARGIN = 0.8  # of the target, for the points the sample skipped
# The worst drag's columns are computed this many at a time (reweighted pairs leave bounds
# alike, so many are), over this many points at a time (bounded memory).
_DRAG_COLUMNS, _DRAG_POINTS = 32, 1 << 13
_BOUND_ROWS = 1024  # node rows whose residual is taken at a time (bounded temporaries: 1.6 MB at 196 columns)


def largest_pairs(coordinates, count):
    """Each row's ``count`` largest-magnitude coordinates, renormalised to sum 1.

    A row of non-negative values is divided by their sum. A row of both signs can cancel
    to a small sum, which a division would multiply the row by (fuzz seed 261: sizes
    adding up to 52 became 6,500); it gets the missing sum added in proportion to its
    values' sizes instead (the same as the division for a non-negative row), so its sizes
    grow by no more than that missing sum.

    Parameters
    ----------
    coordinates : (k, n) float
    count : int
        K; at most n (more are clipped to n).

    Returns
    -------
    indices : (k, K) int32
        Column indices, largest magnitude first.
    weights : (k, K) float64
        Rows sum to 1.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import largest_pairs
    >>> indices, weights = largest_pairs(np.array([[0.1, 0.6, 0.05, 0.25]]), 2)
    >>> indices.tolist(), weights.round(4).tolist()
    ([[1, 3]], [[0.7059, 0.2941]])
    >>> _, weights = largest_pairs(np.array([[0.55, -0.5, 0.47, -0.01, 0.49]]), 3)
    >>> weights.round(4).tolist()  # 0.55, -0.5, 0.49 plus 0.46 by size (divided: 1.02, -0.93, 0.91)
    [[0.7143, -0.3506, 0.6364]]
    """
    coordinates = np.asarray(coordinates, dtype=np.float64)
    indices = largest_columns(coordinates, count, magnitude=True)
    values = np.take_along_axis(coordinates, indices, axis=1)
    total = values.sum(axis=1, keepdims=True)
    signed = (values < 0.0).any(axis=1)
    weights = np.empty_like(values)
    sizes = np.abs(values[signed])
    weights[signed] = values[signed] + (1.0 - total[signed]) * sizes / sizes.sum(axis=1, keepdims=True)
    # Non-negative rows sum to at least their largest value (1/n of 1): a guard for
    # degenerate input only.
    positive_total = total[~signed]
    positive_total[positive_total < tolerances.WELL_DEFINED_WEIGHT_SUM] = 1.0
    weights[~signed] = values[~signed] / positive_total
    return indices.astype(np.int32), weights


def placed_pairs(coordinates, count, rest, span=False):
    """:func:`largest_pairs`, reweighted to place each row where its full coordinates do.

    Dropping the smaller weights moves the point a row places (``sum_j w_j R_j``); rows
    whose kept weights are non-negative are reweighted by maximum entropy
    (``gencoords.harmonic.reproduction``) to place it again, so a rotated or scaled cage
    still moves the points exactly, with the same cage vertices, still non-negative.
    Rows with a negative weight keep :func:`largest_pairs`' weights.

    Parameters
    ----------
    coordinates : (k, n) float
    count : int
    rest : (n, 3) float
        The cage the coordinates were computed in.
    span : bool
        Rows the K largest cannot place get pairs that can (:func:`_spanning_pairs`):
        the grid nodes of two levels, few beside the points (for every row of a mesh, a
        cost of 5x the Bind's on mean value coordinates).

    Returns
    -------
    indices : (k, K) int32
    weights : (k, K) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import placed_pairs
    >>> from gencoords.tools.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> row = np.array([[0.3, 0.1, 0.25, 0.15, 0.12, 0.08]])
    >>> indices, weights = placed_pairs(row, 4, vertices)
    >>> bool(np.allclose(weights @ vertices[indices[0]], row @ vertices)), bool(weights.min() > 0)
    (True, True)
    """
    coordinates = np.asarray(coordinates, dtype=np.float64)
    indices, weights = largest_pairs(coordinates, count)
    rest = np.asarray(rest, dtype=np.float64)
    positive = np.flatnonzero((weights >= 0.0).all(axis=1))
    if count < coordinates.shape[1] and len(positive):
        places = (coordinates @ rest)[positive]
        weights[positive], residual = reproduce_points(indices[positive], weights[positive], rest, places)
        missing = residual > PLACED * np.linalg.norm(np.ptp(rest, axis=0))
        if span and missing.any():
            rows = positive[missing]
            indices[rows], weights[rows] = _spanning_pairs(coordinates[rows], indices[rows], weights[rows], rest,
                                                           places[missing])
    return indices, weights


def _spanning_pairs(coordinates, indices, weights, rest, places):
    """Pairs that place their rows where the K largest cannot (the place outside their
    vertices' hull: a grid node of a coarse grid in an H's crossbar): each row's 4K
    largest reweighted to place it (:func:`reproduce_points`), 4 of them whose hull holds
    it (:func:`carrying_vertices`) kept with the K - 4 largest others, reweighted again.
    Rows that this does not place better keep the pairs they had. Shapes as
    :func:`placed_pairs`' (c rows, K >= 4)."""
    count = indices.shape[1]
    if count < 4:
        return indices, weights
    wide = largest_columns(coordinates, SPANNING_WIDTH * count)
    prior = np.take_along_axis(coordinates, wide, axis=1)
    prior /= prior.sum(axis=1, keepdims=True)
    spread, _ = reproduce_points(wide, prior, rest, places)
    carrying = np.take_along_axis(wide, carrying_vertices(spread, rest[wide]), axis=1)  # (c, 4)
    trial = np.empty_like(indices)
    for row in range(len(indices)):  # fixed-width merges of 4 and K columns
        others = wide[row][~np.isin(wide[row], carrying[row])]
        trial[row] = np.concatenate([carrying[row], others[:count - 4]])
    prior = np.take_along_axis(coordinates, trial.astype(np.int64), axis=1)
    prior = np.maximum(prior, _ADDED_PRIOR * prior.max(axis=1, keepdims=True))
    prior /= prior.sum(axis=1, keepdims=True)
    values, residual = reproduce_points(trial, prior, rest, places)
    before = np.linalg.norm(places - np.einsum("rk,rkd->rd", weights, rest[indices]), axis=1)
    better = residual < before
    indices, weights = indices.copy(), weights.copy()
    indices[better], weights[better] = trial[better], values[better]
    return indices, weights


def carrying_vertices(weights, points):
    """4 of each row's points whose hull holds its place ``sum_j w_j points_j``
    (Caratheodory's reduction, all rows at once): a step takes each row's 5 smallest
    positive weights, moves along their affine dependency until one is 0 and drops it.

    Parameters
    ----------
    weights : (c, M) float
        Non-negative, summing to 1; M >= 4.
    points : (c, M, 3) float
        Each row's points.

    Returns
    -------
    (c, 4) int
        Positions in the rows (the 4 largest remaining weights: where a row weighs fewer
        than 4, some weigh 0).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import carrying_vertices
    >>> square = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 1], [0.5, 0.5, -1]])
    >>> kept = carrying_vertices(np.full((1, 6), 1 / 6), square[None])[0]
    >>> len(set(kept.tolist()))
    4
    """
    weights = np.where(weights > 0.0, weights, 0.0)
    points = np.asarray(points, dtype=np.float64)
    while True:
        pending = np.flatnonzero((weights > 0.0).sum(axis=1) > 4)
        if not len(pending):
            break
        part = weights[pending]
        key = np.where(part > 0.0, part, np.inf)
        five = np.argpartition(key, 4, axis=1)[:, :5]
        corners = np.take_along_axis(points[pending], five[:, :, None], axis=1)  # (p, 5, 3)
        system = np.concatenate([corners.transpose(0, 2, 1), np.ones((len(pending), 1, 5))], axis=1)  # (p, 4, 5)
        dependency = np.linalg.svd(system)[2][:, -1, :]  # system @ dependency = 0
        dependency *= np.where(dependency.max(axis=1, keepdims=True) > 0.0, 1.0, -1.0)
        current = np.take_along_axis(part, five, axis=1)
        rising = dependency > 0.0
        ratios = np.where(rising, current / np.where(rising, dependency, 1.0), np.inf)
        dropped = np.argmin(ratios, axis=1)
        updated = np.maximum(current - ratios[np.arange(len(pending)), dropped][:, None] * dependency, 0.0)
        updated[np.arange(len(pending)), dropped] = 0.0
        np.put_along_axis(part, five, updated, axis=1)
        weights[pending] = part
    return np.argsort(-weights, axis=1, kind="stable")[:, :4]


def dense_weights(indices, weights, column_count):
    """The (k, column_count) matrix the pairs stand for (zeros elsewhere).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import dense_weights
    >>> dense_weights(np.array([[2, 0]]), np.array([[0.75, 0.25]]), 3).tolist()
    [[0.25, 0.0, 0.75]]
    """
    dense = np.zeros((len(indices), column_count))
    np.put_along_axis(dense, np.asarray(indices, dtype=np.int64), np.asarray(weights, dtype=np.float64), axis=1)
    return dense


def interpolated(values, corners, corner_weights):
    """Rows interpolated from node rows: ``sum_c corner_weights[:, c] * values[corners[:, c]]``.

    Parameters
    ----------
    values : (N, n) float
        Per grid node.
    corners : (k, c) int
        Each point's corner nodes (rows of ``values``).
    corner_weights : (k, c) float
        Their interpolation weights.

    Returns
    -------
    (k, n) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import interpolated
    >>> nodes = np.eye(8)
    >>> float(interpolated(nodes, np.arange(8)[None], np.full((1, 8), 0.125)).sum())
    1.0
    """
    values = np.asarray(values, dtype=np.float64)
    corners, corner_weights = np.asarray(corners), np.asarray(corner_weights, dtype=np.float64)
    result = np.zeros((len(corners), values.shape[1]))
    term = np.empty_like(result)
    for c in range(corners.shape[1]):
        np.multiply(np.take(values, corners[:, c], axis=0), corner_weights[:, c, None], out=term)
        result += term
    return result


def deviations(coordinates, indices, weights, rest, interpolation=None):
    """How far the pairs as stored are from the exact coordinates, of the cage's diagonal.

    Parameters
    ----------
    coordinates : (k, n) float
        Exact coordinates; with ``interpolation``, of the grid nodes ((N, n)).
    indices, weights : (k, K) (or (N, K')) int and float
        The pairs, weights as stored (float32 is measured as float32).
    rest : (n, 3) float
        The cage at rest.
    interpolation : ((p, c) int, (p, c) float), optional
        The points' corner nodes (rows of ``coordinates``) and their weights: the
        deviations are then those of the p points.

    Returns
    -------
    smooth : float
        Under the standard smooth motion (``compact.smooth_test_motion``).
    drag : float
        Under the worst single cage vertex dragged by ``compact.DRAG_FRACTION`` of the
        diagonal.
    drag_vertex : int
        That vertex.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import deviations, largest_pairs
    >>> from gencoords.tools.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> exact = np.array([[0.5, 0.3, 0.2, 0.0, 0.0, 0.0]])
    >>> smooth, drag, vertex = deviations(exact, *largest_pairs(exact, 3), vertices)
    >>> float(drag) < 1e-15
    True
    """
    coordinates = np.asarray(coordinates, dtype=np.float64)
    indices, weights = np.asarray(indices), np.asarray(weights, dtype=np.float64)
    if interpolation is None:
        smooth, drag = compact.residual_deviations(_residual(coordinates, indices, weights), rest)
        if len(drag) == 0:
            return float(smooth), 0.0, 0
        return float(smooth), float(drag.max()), int(np.argmax(drag))
    return _interpolated_deviations(coordinates, indices, weights, *interpolation, rest)


def _residual(coordinates, indices, weights, rows=slice(None), columns=None):
    """Rows ``rows`` of ``coordinates - dense(pairs)`` ((r, n) float64), or only their
    ``columns`` ((r, c): the pairs in other columns skipped)."""
    if columns is None:
        residual = np.array(coordinates[rows], dtype=np.float64)
        residual[np.arange(len(residual))[:, None], indices[rows]] -= weights[rows]
        return residual
    position = np.full(coordinates.shape[1], -1)
    position[columns] = np.arange(len(columns))
    residual = np.array(coordinates[rows][:, columns], dtype=np.float64)
    row, slot = np.nonzero(position[indices[rows]] >= 0)
    residual[row, position[indices[rows][row, slot]]] -= weights[rows][row, slot]
    return residual


def _interpolated_deviations(coordinates, indices, weights, corners, corner_weights, rest):
    """``deviations`` of the points interpolated from the nodes' ``coordinates`` ((N, n))
    and pairs, without the (k, n) point residual or even the (N, n) node residual (both
    taken a batch at a time): the smooth motion is linear (interpolate the nodes' moves),
    and a dragged vertex j deviates ``DRAG_FRACTION * max_i |point residual_ij|``, bounded
    by the nodes' largest ``|residual_aj|`` (the corner weights are a convex
    combination): exact columns are computed, a batch at a time, in decreasing bound order
    until no bound can beat the worst found, so the largest and where it is are exact."""
    rest = np.asarray(rest, dtype=np.float64)
    diagonal = np.linalg.norm(np.ptp(rest, axis=0))
    if len(corners) == 0 or coordinates.shape[1] == 0:
        return 0.0, 0.0, 0
    motion = compact.smooth_test_motion(rest) - rest
    node_moves = np.empty((len(coordinates), 3))
    used = np.zeros(len(coordinates), dtype=bool)
    used[np.asarray(corners).reshape(-1)] = True
    bounds = np.zeros(coordinates.shape[1])
    for start in range(0, len(coordinates), _BOUND_ROWS):
        rows = slice(start, start + _BOUND_ROWS)
        residual = _residual(coordinates, indices, weights, rows)
        node_moves[rows] = residual @ motion
        np.abs(residual, out=residual)
        np.maximum(bounds, residual.max(axis=0, initial=0.0, where=used[rows, None]), out=bounds)
    moves = interpolated(node_moves, corners, corner_weights)
    smooth = float(np.linalg.norm(moves, axis=1).max() / diagonal)
    worst, worst_column = -1.0, 0
    order = np.argsort(-bounds)
    for start in range(0, len(order), _DRAG_COLUMNS):
        batch = order[start:start + _DRAG_COLUMNS]
        if bounds[batch[0]] <= worst:
            break
        largest = np.zeros(len(batch))
        residual = _residual(coordinates, indices, weights, columns=batch)
        for first in range(0, len(corners), _DRAG_POINTS):
            rows = slice(first, first + _DRAG_POINTS)
            part = interpolated(residual, corners[rows], corner_weights[rows])
            np.maximum(largest, np.abs(part).max(axis=0), out=largest)
        best = int(np.argmax(largest))
        if largest[best] > worst:
            worst, worst_column = float(largest[best]), int(batch[best])
    return smooth, compact.DRAG_FRACTION * worst, worst_column


def fewest_slots(coordinates, rest, target, counts=SLOT_COUNTS, interpolation=None):
    """The fewest pairs per row (:func:`placed_pairs`) whose deviations both stay under
    ``target``.

    Parameters
    ----------
    coordinates : (k, n) float
        Exact coordinates of sample points; with ``interpolation``, of the grid nodes
        ((N, n)), the points' coordinates being their interpolation.
    rest : (n, 3) float
        The cage at rest.
    target : float
        Largest deviation allowed, of the cage's diagonal.
    counts : increasing sequence of int
        Candidate K.
    interpolation : ((k, c) int, (k, c) float), optional
        The points' corner nodes and weights (two-level layout).

    Returns
    -------
    count : int or None
        The first of ``counts`` (at most n) whose smooth and worst drag deviations
        (weights rounded to float32, as stored) are below ``target``; None if none is.
    smooth, drag : float
        Those deviations at ``count`` (at the last count when None).

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.tools.sparse import fewest_slots
    >>> from gencoords.tools.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> w = gencoords.coordinates([[0.1, 0.2, 0.3]], vertices, faces, workers=1)
    >>> count, smooth, drag = fewest_slots(w, vertices, 1e-3, counts=(4, 42))
    >>> count, drag < 1e-3
    (42, True)
    """
    smooth = drag = np.inf
    columns = np.shape(coordinates)[1]
    for count in sorted({min(count, columns) for count in counts}):  # K beyond n keeps n
        indices, weights = placed_pairs(coordinates, count, rest, span=interpolation is not None)
        smooth, drag, _ = deviations(coordinates, indices, weights.astype(np.float32), rest, interpolation)
        if smooth < target and drag < target:
            return count, smooth, drag
    return None, smooth, drag


def used_nodes(corners):
    """The grid nodes that interpolate the points, and the corners renumbered into them.

    Parameters
    ----------
    corners : (k, c) int
        Each point's corner nodes (rows of a grid's nodes).

    Returns
    -------
    used : (N,) int
        Sorted node rows.
    local : (k, c) int32
        ``corners`` as rows of ``used``.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import used_nodes
    >>> used, local = used_nodes(np.array([[7, 3, 7, 9, 3, 3, 9, 7]]))
    >>> used.tolist(), local.tolist()
    ([3, 7, 9], [[1, 0, 1, 2, 0, 0, 2, 1]])
    """
    used, local = np.unique(np.asarray(corners), return_inverse=True)
    return used, local.reshape(np.shape(corners)).astype(np.int32)


def automatic_node_slot_counts(point_count, node_count, column_count, per_vector=3):
    """Automatic's candidate K' for N grid nodes beside k points: NODE_SLOT_COUNTS, then
    MORE_NODE_SLOT_COUNTS and every column (n) as far as NODE_COLUMN_BUDGET stored columns,
    filled (:func:`filled_node_slot_counts`).

    Examples
    --------
    >>> from gencoords.tools.sparse import automatic_node_slot_counts
    >>> automatic_node_slot_counts(1_000_000, 7960, 642)  # 375 slots a column: all 642 in 2
    (375, 642)
    >>> automatic_node_slot_counts(43236, 5524, 196)  # all 196 would take 10 columns
    (21, 42, 63, 84, 105, 147)
    """
    per_column = _slots_per_column(point_count, node_count, per_vector)
    more = [count for count in MORE_NODE_SLOT_COUNTS + (column_count,)
            if -(-min(count, column_count) // per_column) <= NODE_COLUMN_BUDGET]
    return filled_node_slot_counts(NODE_SLOT_COUNTS + tuple(more), point_count, node_count, column_count, per_vector)


def _slots_per_column(point_count, node_count, per_vector):
    """Node slots one stored column holds (:func:`stacked_columns`): ``per_vector`` times
    the nodes' copies that fit its ``point_count`` rows."""
    return per_vector * max(1, point_count // max(1, node_count))


def filled_node_slot_counts(counts, point_count, node_count, column_count, per_vector=3):
    """Candidate K' rounded up to fill whole stacked columns (:func:`stacked_columns` of
    ``per_vector`` slots to a stored vector): the deformer's cost grows with the columns,
    not the slots, so a column's spare slots are free accuracy.

    Parameters
    ----------
    counts : increasing sequence of int
        Candidate K'.
    point_count, node_count : int
        The column length (the mesh's vertex count) and N.
    column_count : int
        The cage's vertex count n (no node keeps more pairs).

    Returns
    -------
    tuple of int
        Increasing, distinct, each a whole number of columns or n.

    Examples
    --------
    >>> from gencoords.tools.sparse import filled_node_slot_counts
    >>> filled_node_slot_counts((8, 16, 24, 48), 1000, 140, 200)  # 7 vectors, 21 slots a column
    (21, 42, 63)
    """
    per_column = _slots_per_column(point_count, node_count, per_vector)
    return tuple(sorted({min(-(-count // per_column) * per_column, column_count) for count in counts}))


def stacked_columns(values, row_count):
    """Node slots stacked into columns of ``row_count`` rows: slot j of node a at row
    ``(j % S) * N + a`` of column ``j // S``, with ``S = row_count // N`` slots a column.

    Parameters
    ----------
    values : (N, K') array
        Per node its K' slot values (indices or weights); N <= ``row_count``.
    row_count : int
        The column length (the mesh's vertex count).

    Returns
    -------
    columns : (row_count, C) array of ``values``' dtype
        ``C = ceil(K' / S)``; zeros where no slot is stored.
    per_column : int
        S.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import stacked_columns
    >>> columns, per_column = stacked_columns(np.array([[1, 2, 3], [4, 5, 6]]), 5)
    >>> per_column, columns.T.tolist()
    (2, [[1, 4, 2, 5, 0], [3, 6, 0, 0, 0]])
    """
    values = np.asarray(values)
    count, slots = values.shape[:2]
    if count == 0 or count > row_count:
        raise ValueError(f"{count} nodes do not fit in columns of {row_count} rows")
    per_column = row_count // count
    columns = np.zeros((row_count, -(-slots // per_column)) + values.shape[2:], dtype=values.dtype)
    for j in range(slots):
        start = (j % per_column) * count
        columns[start:start + count, j // per_column] = values[:, j]
    return columns, per_column


def unstacked(columns, node_count, slot_count):
    """The inverse of :func:`stacked_columns`: (N, K') from the stacked columns.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import stacked_columns, unstacked
    >>> values = np.arange(1, 7).reshape(2, 3)
    >>> unstacked(stacked_columns(values, 5)[0], 2, 3).tolist()
    [[1, 2, 3], [4, 5, 6]]
    """
    columns = np.asarray(columns)
    per_column = len(columns) // node_count
    values = np.empty((node_count, slot_count) + columns.shape[2:], dtype=columns.dtype)
    for j in range(slot_count):
        start = (j % per_column) * node_count
        values[:, j] = columns[start:start + node_count, j // per_column]
    return values


def layout_coordinates(indices, weights, column_count, nodes=None):
    """The coordinates sparse bind data stands for: (k, n) float64.

    Parameters
    ----------
    indices, weights : (k, K) int and float
        The points' pairs: cage vertices, or with ``nodes`` rows of the grid nodes.
    column_count : int
        n, the cage's vertex count.
    nodes : ((N, K') int, (N, K') float), optional
        The grid nodes' pairs over the cage (two levels).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import layout_coordinates
    >>> nodes = (np.array([[0, 1], [2, 1]]), np.array([[0.5, 0.5], [1.0, 0.0]]))
    >>> layout_coordinates(np.array([[0, 1]]), np.array([[0.5, 0.5]]), 3, nodes).tolist()
    [[0.25, 0.25, 0.5]]
    """
    if nodes is None:
        return dense_weights(indices, weights, column_count)
    node_rows = dense_weights(*nodes, column_count)
    return interpolated(node_rows, indices, weights)


@dataclass(frozen=True, eq=False)
class TwoLevelLayout:
    """Sparse bind data in two levels (:func:`two_level_layout`), as written: float32
    weights, int32 indices.

    Attributes
    ----------
    corners : (k, c) int32
        Each point's corner nodes (c = 4: ``gencoords.harmonic.interpolation``), as
        rows of the N nodes kept.
    corner_weights : (k, c) float32
        Their interpolation weights.
    node_indices : (N, K') int32
        Each node's cage vertices, largest weight first.
    node_weights : (N, K') float32
        Their weights, summing to 1 per node.
    deviation_smooth, deviation_drag : float
        Of the cage's diagonal, measured on every point against the points' exact
        (interpolated) coordinates.
    deviation_drag_vertex : int
    reason : str or None
        Why K' is what it is, where the target was missed.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import TwoLevelLayout
    >>> one_node = TwoLevelLayout(np.zeros((1, 4), np.int32), np.full((1, 4), 0.25, np.float32),
    ...                           np.zeros((1, 4), np.int32), np.full((1, 4), 0.25, np.float32),
    ...                           0.0, 0.0, 0)
    >>> one_node.node_count, one_node.node_slot_count
    (1, 4)
    """

    corners: np.ndarray
    corner_weights: np.ndarray
    node_indices: np.ndarray
    node_weights: np.ndarray
    deviation_smooth: float
    deviation_drag: float
    deviation_drag_vertex: int
    reason: Optional[str] = None

    @property
    def node_count(self):
        return len(self.node_indices)

    @property
    def node_slot_count(self):
        return self.node_indices.shape[1]


def two_level_layout(node_coordinates, corners, corner_weights, rest, target, counts=NODE_SLOT_COUNTS):
    """The two-level sparse layout of points interpolated from nodes: the nodes with the
    fewest pairs each (of ``counts``: :func:`placed_pairs`) whose deviations stay under
    ``target`` (chosen on a sample of the points, measured on all).

    Parameters
    ----------
    node_coordinates : (N, n) float
        The nodes' coordinates (rows summing to 1): the grid nodes that interpolate the
        points (:func:`used_nodes`), and any point's own row where it is not
        interpolated (its corners all that row, its first corner weight 1).
    corners : (k, c) int
        Each point's corner nodes (rows of ``node_coordinates``).
    corner_weights : (k, c) float
        Their interpolation weights.
    rest : (n, 3) float
        The cage at rest.
    target : float
        Of the cage's diagonal.
    counts : increasing sequence of int
        Candidate K'; the last is used when none meets the target.

    Returns
    -------
    TwoLevelLayout

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.sparse import two_level_layout
    >>> from gencoords.tools.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> nodes = np.random.default_rng(0).dirichlet(np.ones(6), 16)
    >>> corners = np.arange(8).reshape(2, 4)
    >>> layout = two_level_layout(nodes[:8], corners, np.full((2, 4), 0.25), vertices, 1e-3, counts=(2, 6))
    >>> layout.node_count, layout.node_slot_count, layout.deviation_drag < 1e-6
    (8, 6, True)
    """
    nodes = np.asarray(node_coordinates, dtype=np.float64)
    corners = np.asarray(corners, dtype=np.int32)
    corner_weights = np.asarray(corner_weights, dtype=np.float32)
    sample = slice(None, None, max(1, len(corners) // SAMPLE_POINTS))
    sampled, sample_corners = used_nodes(corners[sample])  # only the sample's nodes are paired
    count, _, _ = fewest_slots(nodes[sampled], rest, target * SAMPLE_MARGIN, counts,
                               interpolation=(sample_corners, corner_weights[sample]))
    reason = None
    if count is None:
        count = counts[-1]
    indices, weights = placed_pairs(nodes, count, rest, span=True)
    weights = weights.astype(np.float32)
    smooth, drag, vertex = deviations(nodes, indices, weights, rest, (corners, corner_weights))
    if max(smooth, drag) >= target:
        reason = (f"{count} pairs per grid node deviate {max(smooth, drag):.1e} of the cage's "
                  f"diagonal (more than {target:.0e})")
    return TwoLevelLayout(corners, corner_weights, indices, weights, smooth, drag, vertex, reason)
