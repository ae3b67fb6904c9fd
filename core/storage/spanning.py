"""Pairs that place a point where its K largest coordinates cannot: the place lies
outside the hull of those K cage vertices (a grid node of a coarse grid in an H's
crossbar), so no reweighting of them reaches it. :func:`carrying_vertices` finds 4
vertices whose hull holds it (Caratheodory's reduction), and :func:`spanning_pairs`
keeps them with the K - 4 largest others (``sparse.placed_pairs(..., span=True)``)."""

import numpy as np

from ..harmonic.reproduction import largest_columns, reproduce_points

__all__ = ["spanning_pairs", "carrying_vertices"]

_ADDED_PRIOR = 1e-3  # the least prior weight of a vertex added to place a row
SPANNING_WIDTH = 4  # times K: the largest coordinates a row that K cannot place is placed with first


def spanning_pairs(coordinates, indices, weights, rest, places):
    """Pairs that place their rows where the K largest cannot (the place outside their
    vertices' hull: a grid node of a coarse grid in an H's crossbar): each row's 4K
    largest reweighted to place it (:func:`reproduce_points`), 4 of them whose hull holds
    it (:func:`carrying_vertices`) kept with the K - 4 largest others, reweighted again.
    Rows that this does not place better keep the pairs they had. Shapes as
    :func:`gencoords.storage.sparse.placed_pairs`' (c rows, K >= 4)."""
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
    >>> from gencoords.storage.spanning import carrying_vertices
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
