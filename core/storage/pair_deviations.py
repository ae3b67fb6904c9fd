"""Deviations of (cage vertex, weight) pairs from the exact coordinates (sparse storage,
in one level or two): :func:`deviations`, on :mod:`.deviations`' motions, and
:func:`interpolated`, the two levels' rows from their grid nodes'.
"""

import numpy as np

from . import deviations as measures

__all__ = ["interpolated", "deviations"]

# The worst drag's columns are computed this many at a time (reweighted pairs leave bounds
# alike, so many are), over this many points at a time (bounded memory).
_DRAG_COLUMNS, _DRAG_POINTS = 32, 1 << 13


_BOUND_ROWS = 1024  # node rows whose residual is taken at a time (bounded temporaries: 1.6 MB at 196 columns)


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
    >>> from gencoords.storage.pair_deviations import interpolated
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
        Under the standard smooth motion (``deviations.smooth_test_motion``).
    drag : float
        Under the worst single cage vertex dragged by ``deviations.DRAG_FRACTION`` of the
        diagonal.
    drag_vertex : int
        That vertex.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.pair_deviations import deviations
    >>> from gencoords.storage.sparse import largest_pairs
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> exact = np.array([[0.5, 0.3, 0.2, 0.0, 0.0, 0.0]])
    >>> smooth, drag, vertex = deviations(exact, *largest_pairs(exact, 3), vertices)
    >>> float(drag) < 1e-15
    True
    """
    coordinates = np.asarray(coordinates, dtype=np.float64)
    # float32 weights stay float32 (subtracted from float64, each is widened exactly):
    # a float64 copy of two levels' pairs was a quadruped's Bind peak (15 MB).
    indices, weights = np.asarray(indices), np.asarray(weights)
    weights = weights if weights.dtype in (np.float32, np.float64) else weights.astype(np.float64)
    if interpolation is None:
        smooth, drag = measures.residual_deviations(_residual(coordinates, indices, weights), rest)
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
    indices, weights = indices[rows], weights[rows]
    for start in range(0, len(residual), _BOUND_ROWS):  # each row's pairs alone: no (r, K) positions
        block = slice(start, start + _BOUND_ROWS)
        row, slot = np.nonzero(position[indices[block]] >= 0)
        residual[start + row, position[indices[block][row, slot]]] -= weights[block][row, slot]
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
    motion = measures.smooth_test_motion(rest) - rest
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
    return smooth, measures.DRAG_FRACTION * worst, worst_column
