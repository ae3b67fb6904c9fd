"""Sparse bind-data storage: per point its K largest coordinates as (cage vertex, weight)
pairs, renormalised to sum 1.

A point with coordinates ``w`` (a row of ``W``, shape (k, n)) moves by ``w @ D`` when the
cage's vertices move by ``D`` (n, 3). Local coordinates (harmonic, and any kind on a cage
where each point sees few vertices) keep nearly all of ``w``'s mass in a few entries;
sparse storage keeps the K largest (by magnitude) and divides them by their sum, so the
stored weights still sum to 1 and translations of the cage stay exact. Evaluating costs K
gathers per point whatever the cage (the add-on's sparse deformer group).

How far the sparse form is from the exact one is measured like compact storage's
(:mod:`.pair_deviations`: the standard smooth motion and the worst single-vertex drag,
of the cage's diagonal) on the residual ``W - sparse(W)``; :func:`fewest_slots` finds
the smallest K that keeps both under a target. :func:`encode`, :func:`reproduce` and
:func:`plan_bytes` are the storage's; in two levels (harmonic coordinates) the grid
nodes carry the pairs (:mod:`.two_level`), stored stacked (:func:`stacked_columns`).
"""

import numpy as np

from ..base.arrays import in_row_blocks, selected_rows
from ..harmonic.reproduction import largest_entries, reproduce_points
from .pair_deviations import deviations, interpolated
from .spanning import spanning_pairs

__all__ = ["largest_pairs", "placed_pairs", "dense_weights", "fewest_slots", "fewest_pairs", "fewest_slots_bound", "stacked_columns", "unstacked", "layout_coordinates", "playback_seconds", "SLOT_COUNTS"]

SLOT_COUNTS = (4, 8, 12, 16, 24, 32)  # candidate K, fewest first
# Of the cage's diagonal: rows placed further from where their coordinates place them
# get other pairs (:func:`placed_pairs` with ``span``).
PLACED = 1e-9
# The deformer's time per evaluation (Geometry Nodes, Blender 5.0 on two cores): about this per
# gathered (vertex, slot), and per Repeat Zone iteration whatever the mesh. Sparse storage on the
# cape (4,320 vertices) took 0.61, 0.96 and 1.97 ms at 1, 4 and 12 pairs, on the character (43,236)
# 8 to 32 pairs added 7.7 ms (docs/bench_sparse_routes.md), exact storage on the cup 13 ms for
# 8,706 x 322 multiply-adds: on small meshes the iterations cost most.
GATHER_SECONDS, ITERATION_SECONDS = 5e-9, 90e-6
# :func:`fewest_pairs` first tries a count on every SCREEN_STEP ** 2-th point, then on every SCREEN_STEP-th,
# each where that holds at least SCREEN_POINTS points; it places PLACED_ROWS rows at a time (the cup: 5.6 MB).
SCREEN_STEP, SCREEN_POINTS, PLACED_ROWS = 8, 32, 256


def largest_pairs(coordinates, count):
    """Each row's ``count`` largest-magnitude coordinates, renormalised to sum 1
    (``gencoords.harmonic.reproduction.largest_entries``: a row of both signs gets the
    missing sum added in proportion to its values' sizes, so it never grows by a division).

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
    >>> from gencoords.storage.sparse import largest_pairs
    >>> indices, weights = largest_pairs(np.array([[0.1, 0.6, 0.05, 0.25]]), 2)
    >>> indices.tolist(), weights.round(4).tolist()
    ([[1, 3]], [[0.7059, 0.2941]])
    >>> _, weights = largest_pairs(np.array([[0.55, -0.5, 0.47, -0.01, 0.49]]), 3)
    >>> weights.round(4).tolist()  # 0.55, -0.5, 0.49 plus 0.46 by size (divided: 1.02, -0.93, 0.91)
    [[0.7143, -0.3506, 0.6364]]
    """
    indices, weights = largest_entries(coordinates, count, magnitude=True)
    return indices.astype(np.int32), weights


def placed_pairs(coordinates, count, rest, span=False, places=None):
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
        Rows the K largest cannot place get pairs that can (``spanning``): the grid
        nodes of two levels, few beside the points (for every row of a mesh, a cost of 5x
        the Bind's on mean value coordinates).
    places : (k, 3) float, optional
        ``coordinates @ rest``, where the caller has it (its rounding depends on the rows:
        given, each row's pairs are bit for bit its own among any others).

    Returns
    -------
    indices : (k, K) int32
    weights : (k, K) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.sparse import placed_pairs
    >>> from gencoords.cages.shapes import octahedron
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
        places = (coordinates @ rest if places is None else np.asarray(places, dtype=np.float64))[positive]
        weights[positive], residual = reproduce_points(indices[positive], weights[positive], rest, places)
        missing = residual > PLACED * np.linalg.norm(np.ptp(rest, axis=0))
        if span and missing.any():
            rows = positive[missing]
            indices[rows], weights[rows] = spanning_pairs(coordinates[rows], indices[rows], weights[rows], rest,
                                                          places[missing])
    return indices, weights


def dense_weights(indices, weights, column_count):
    """The (k, column_count) matrix the pairs stand for (zeros elsewhere).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.sparse import dense_weights
    >>> dense_weights(np.array([[2, 0]]), np.array([[0.75, 0.25]]), 3).tolist()
    [[0.25, 0.0, 0.75]]
    """
    dense = np.zeros((len(indices), column_count))
    np.put_along_axis(dense, np.asarray(indices, dtype=np.int64), np.asarray(weights, dtype=np.float64), axis=1)
    return dense


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
    >>> from gencoords.storage.sparse import fewest_slots
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> w = gencoords.coordinates([[0.1, 0.2, 0.3]], vertices, faces, workers=1)
    >>> count, smooth, drag = fewest_slots(w, vertices, 1e-3, counts=(4, 42))
    >>> count, drag < 1e-3
    (42, True)
    """
    return fewest_pairs(coordinates, rest, target, counts, interpolation)[:3]


def fewest_pairs(coordinates, rest, target, counts=SLOT_COUNTS, interpolation=None):
    """:func:`fewest_slots`, with the pairs of the count returned ((k, K) int32 and
    float64, of every row of ``coordinates``: the nodes' with ``interpolation``; where
    none passes, of the last count).

    A count is tried first on every SCREEN_STEP ** 2-th point, then every SCREEN_STEP-th
    (their nodes, with ``interpolation``), each try keeping the rows placed before (each
    row's pairs are its own): deviations are maxima over points, so a count that misses
    there misses on all (the quadruped's two-level Bind: 4 of 6 counts, on a thirteenth of
    its nodes). The last count is always measured on all (its deviations returned where none passes).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.sparse import fewest_pairs
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> rows = np.random.default_rng(0).dirichlet(np.full(6, 0.1), 400)
    >>> count, smooth, drag, indices, weights = fewest_pairs(rows, vertices, 1e-3, counts=(2, 6))
    >>> count, indices.shape, bool(np.allclose(weights.sum(axis=1), 1.0))
    (6, (400, 6), True)
    """
    smooth, drag, indices, weights = np.inf, np.inf, None, None
    candidates = _candidates(coordinates, counts)
    coordinates = np.asarray(coordinates, dtype=np.float64)
    places, screens = coordinates @ np.asarray(rest, dtype=np.float64), _screens(coordinates, interpolation)
    for count in candidates:
        stages = (screens if count != candidates[-1] else []) + [(np.arange(len(coordinates)), interpolation)]
        passes, (smooth, drag, indices, weights) = _passes(coordinates, stages, count, rest, target, places)
        if passes:
            return count, smooth, drag, indices, weights
    return None, smooth, drag, indices, weights


def fewest_slots_bound(coordinates, rest, target, counts=SLOT_COUNTS, interpolation=None):
    """A lower bound on the count :func:`fewest_slots` chooses (its last count where none
    passes), at a part of its cost: the first of ``counts`` passing on the points
    :func:`fewest_pairs` screens on (the first count where it screens none). Arguments
    as :func:`fewest_slots`'.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.sparse import fewest_slots, fewest_slots_bound
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> rows = np.random.default_rng(0).dirichlet(np.full(6, 0.1), 400)
    >>> fewest_slots_bound(rows, vertices, 1e-3, (2, 4, 6)) <= fewest_slots(rows, vertices, 1e-3, (2, 4, 6))[0]
    True
    """
    candidates, coordinates = _candidates(coordinates, counts), np.asarray(coordinates, dtype=np.float64)
    places, screens = coordinates @ np.asarray(rest, dtype=np.float64), _screens(coordinates, interpolation)
    if not screens:
        return candidates[0]
    return next((count for count in candidates[:-1] if _passes(coordinates, screens, count, rest, target, places)[0]),
                candidates[-1])


def _candidates(coordinates, counts):
    """The distinct counts to try on ``coordinates`` ((j, n)), fewest first: K beyond n keeps n."""
    return sorted({min(count, np.shape(coordinates)[1]) for count in counts})


def _screens(coordinates, interpolation):
    """Every SCREEN_STEP ** 2-th point, then every SCREEN_STEP-th, each where there are at least
    SCREEN_POINTS: [(rows of ``coordinates`` (j,) int, their interpolation as :func:`fewest_pairs`
    takes it: with ``interpolation``, the nodes those points use, renumbered)]."""
    points = len(coordinates) if interpolation is None else len(interpolation[0])
    steps = [step for step in (SCREEN_STEP ** 2, SCREEN_STEP) if -(-points // step) >= SCREEN_POINTS]
    if interpolation is None:
        return [(np.arange(0, len(coordinates), step), None) for step in steps]
    corners, corner_weights = interpolation
    found = [(np.unique(np.asarray(corners[::step]), return_inverse=True), step) for step in steps]
    return [(used, (local.reshape(-1, corners.shape[1]), corner_weights[::step])) for (used, local), step in found]


def _passes(coordinates, stages, count, rest, target, places):
    """Whether ``count`` pairs per row pass every stage ((rows of ``coordinates``, their interpolation),
    each placing the rows the one before did not), and the last stage's (smooth, drag, indices, weights)."""
    rows, pairs = np.zeros(0, dtype=np.int64), (np.zeros((0, 1), dtype=np.int32), np.zeros((0, 1)))
    for stage, interpolation in stages:  # the last stage's rows are every row: not copied (the hand's: 14 MB)
        passes, *found = _deviations_under(selected_rows(coordinates, stage), interpolation, count, rest, target,
                                           selected_rows(places, stage), (np.searchsorted(stage, rows), *pairs))
        if not passes:
            break
        rows, pairs = stage, found[2:]
    return passes, found


def _deviations_under(coordinates, interpolation, count, rest, target, places, known):
    """Whether ``count`` pairs per row keep both deviations under ``target``, the deviations
    and the pairs; ``known``: (rows, indices, weights) already placed."""
    others = np.setdiff1d(np.arange(len(coordinates)), known[0])
    placed = in_row_blocks(lambda rows: placed_pairs(coordinates[rows], count, rest, interpolation is not None,
                                                     places[rows]), PLACED_ROWS, others)
    indices, weights = (np.empty((len(coordinates),) + part.shape[1:], dtype=part.dtype) for part in placed)
    indices[others], weights[others] = placed
    indices[known[0]], weights[known[0]] = known[1:]
    smooth, drag, _ = deviations(coordinates, indices, weights.astype(np.float32), rest, interpolation)
    return smooth < target and drag < target, smooth, drag, indices, weights


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
    >>> from gencoords.storage.sparse import stacked_columns
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
    >>> from gencoords.storage.sparse import stacked_columns, unstacked
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
    >>> from gencoords.storage.sparse import layout_coordinates
    >>> nodes = (np.array([[0, 1], [2, 1]]), np.array([[0.5, 0.5], [1.0, 0.0]]))
    >>> layout_coordinates(np.array([[0, 1]]), np.array([[0.5, 0.5]]), 3, nodes).tolist()
    [[0.25, 0.25, 0.5]]
    """
    if nodes is None:
        return dense_weights(indices, weights, column_count)
    node_rows = dense_weights(*nodes, column_count)
    return interpolated(node_rows, indices, weights)


def playback_seconds(gathers, iterations):
    """The deformer's estimated time per evaluation for ``gathers`` gathered (vertex,
    slot) in ``iterations`` Repeat Zone iterations (sparse storage: k K and K; two levels:
    ``two_level.playback_seconds``).

    Examples
    --------
    >>> from gencoords.storage.sparse import playback_seconds
    >>> round(playback_seconds(10_000 * 8, 8) * 1e3, 2)  # 10,000 vertices, 8 pairs each: ms
    1.12
    """
    return GATHER_SECONDS * gathers + ITERATION_SECONDS * iterations


def encode(choice, coordinates, rest):
    """Each point's ``choice.pairs`` largest coordinates ((j, rows) float64), placing it
    where its coordinates do in the cage ``rest`` ((n, 3): :func:`placed_pairs`, with
    ``choice.span``): weights (j, K) float32 and cage vertices (j, K) int32."""
    indices, weights = placed_pairs(coordinates, choice.pairs, rest, span=choice.span)
    return weights.astype(np.float32), indices


def reproduce(choice, slots, indices, rows):
    """The coordinates the deformer reproduces from the pairs: (j, rows) float64."""
    return dense_weights(indices, slots, rows)


def plan_bytes(plan):
    """Bytes of a sparse plan's attributes: an int32 and a float32 per pair."""
    return len(plan.slots) * plan.slot_count * 8
