"""Linear precision restored without losing positivity: the closest weights, in relative
entropy, that place each point exactly (docs/MATH.md, "Harmonic coordinates").

A grid's harmonic coordinates place a point near the cage only to within a fraction of a
cell (the nodes outside the cage hold their nearest boundary point's values). Reweighting
them as maximum entropy coordinates with the grid's weights as the prior,

    w_j = prior_j exp(lambda . (R_j - x)) / Z,    lambda such that sum_j w_j R_j = x,

keeps every weight positive where the prior is and zero where it is zero (so locality and
sparsity stay), keeps rows summing to 1, and reproduces x exactly wherever x lies in the
convex hull of the cage vertices the prior weighs.
"""

import numpy as np

__all__ = ["reproduce_points", "placing_largest", "largest_columns"]

_ITERATIONS = 40
_CONVERGED = 1e-14  # of each point's span: the mean offset Newton stops at
_CHUNK_ENTRIES = 1 << 16  # (point, weight) entries per batch: bounded memory (a few MB)


def _newton(prior, offsets, iterations):
    """One batch: (weights (p, K), relative residual (p,)) for offsets (3, p, K) scaled to
    unit span. Component planes, not (p, K, 3) stacks: every step is a few passes over
    (p, K) arrays (numpy's stacked 3 x 3 products are far slower)."""
    multiplier = np.zeros((3, len(prior)))
    active = np.arange(len(prior))
    weights = prior.copy()
    pairs = [(a, b) for a in range(3) for b in range(a, 3)]
    for step_count in range(iterations + 1):
        part = offsets[:, active]
        exponent = np.einsum("Npk,Np->pk", part, multiplier[:, active])
        exponent -= exponent.max(axis=1, keepdims=True)
        scaled = prior[active] * np.exp(exponent)
        scaled /= scaled.sum(axis=1, keepdims=True)
        weights[active] = scaled
        mean = np.einsum("Npk,pk->Np", part, scaled)
        moving = np.abs(mean).max(axis=0) > _CONVERGED
        if not moving.any() or step_count == iterations:
            break
        active, part, scaled, mean = active[moving], part[:, moving], scaled[moving], mean[:, moving]
        covariance = np.empty((len(active), 3, 3))
        for a, b in pairs:
            covariance[:, a, b] = covariance[:, b, a] = np.einsum("pk,pk->p", part[a] * scaled, part[b])
        covariance -= mean.T[:, :, None] * mean.T[:, None, :]
        covariance += 1e-12 * np.eye(3)
        step = np.linalg.solve(covariance, mean.T[:, :, None])[:, :, 0].T
        # Each exponent changes by at most 1 per step: Newton's step where it is small.
        largest = np.abs(np.einsum("Npk,Np->pk", part, step)).max(axis=1)
        multiplier[:, active] -= step / np.maximum(largest, 1.0)
    residual = np.linalg.norm(np.einsum("Npk,pk->pN", offsets, weights), axis=1)
    return weights, residual


def _newton_dense(prior, vertices, points, iterations):
    """:func:`_newton` for rows over every cage vertex, in matrix products: the exponent
    ``lambda . R_j`` (the ``lambda . x`` part cancels in the normalisation), the moments
    ``w @ R`` and ``w @ (R_a R_b)``; in the cage's unit frame. Returns (weights (p, n),
    residual (p,) in the frame's units)."""
    centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    size = max(float(np.abs(vertices - centre).max()), 1e-300)
    frame, places = (vertices - centre) / size, (points - centre) / size
    products = np.column_stack([frame[:, a] * frame[:, b] for a in range(3) for b in range(a, 3)])
    pairs = [(a, b) for a in range(3) for b in range(a, 3)]
    reach = np.linalg.norm(frame, axis=1).max() + np.linalg.norm(places, axis=1)  # >= |R_j - x|
    multiplier = np.zeros((len(prior), 3))
    weights = prior.copy()
    active = np.arange(len(prior))
    for step_count in range(iterations + 1):
        exponent = multiplier[active] @ frame.T
        exponent -= exponent.max(axis=1, keepdims=True)
        scaled = prior[active] * np.exp(exponent)
        scaled /= scaled.sum(axis=1, keepdims=True)
        weights[active] = scaled
        placed = scaled @ frame
        mean = placed - places[active]
        moving = np.abs(mean).max(axis=1) > _CONVERGED
        if not moving.any() or step_count == iterations:
            break
        active, scaled, placed, mean = active[moving], scaled[moving], placed[moving], mean[moving]
        moments = scaled @ products
        covariance = np.empty((len(active), 3, 3))
        for column, (a, b) in enumerate(pairs):
            covariance[:, a, b] = covariance[:, b, a] = moments[:, column] - placed[:, a] * placed[:, b]
        covariance += 1e-12 * np.eye(3)
        step = np.linalg.solve(covariance, mean[:, :, None])[:, :, 0]
        # As _newton: no exponent changes by more than 1 (bounded through |R_j - x|).
        largest = np.linalg.norm(step, axis=1) * reach[active]
        multiplier[active] -= step / np.maximum(largest, 1.0)[:, None]
    return weights, np.linalg.norm(weights @ frame - places, axis=1) * size


def reproduce_points(indices, weights, vertices, points, iterations=_ITERATIONS):
    """Reweight non-negative weights so that they place their points exactly.

    Parameters
    ----------
    indices : (p, K) int or None
        Cage vertices of each point's weights; None: every row weighs all n in order
        (dense rows: computed in matrix products).
    weights : (p, K) float
        Non-negative, rows summing to 1: the prior.
    vertices : (n, 3) float
        The cage the weights were computed in.
    points : (p, 3) float
    iterations : int
        Newton steps at most.

    Returns
    -------
    weights : (p, K) float64
        Positive where the prior is, zero where it is zero, rows summing to 1.
    residual : (p,) float
        ``|sum_j w_j R_j - x|`` after the correction (world units): 0 to rounding
        wherever x lies in the convex hull of its weighted vertices; elsewhere as close
        as the iterations come.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.reproduction import reproduce_points
    >>> corners = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> weights, residual = reproduce_points([[0, 1, 2, 3]], [[0.25, 0.25, 0.25, 0.25]], corners, [[0.1, 0.2, 0.3]])
    >>> weights.round(3).tolist(), bool(residual[0] < 1e-12)
    ([[0.4, 0.1, 0.2, 0.3]], True)
    """
    prior = np.asarray(weights, dtype=np.float64)
    vertices, points = np.asarray(vertices, dtype=np.float64), np.asarray(points, dtype=np.float64)
    indices = None if indices is None else np.asarray(indices)
    result, residual = np.empty_like(prior), np.empty(len(prior))
    step = max(1, _CHUNK_ENTRIES // max(1, prior.shape[1]))
    for start in range(0, len(prior), step):
        batch = slice(start, start + step)
        if indices is None:
            result[batch], residual[batch] = _newton_dense(prior[batch], vertices, points[batch], iterations)
            continue
        offsets = np.stack([vertices[indices[batch], axis] - points[batch, axis, None] for axis in range(3)])
        span = np.abs(offsets).max(axis=(0, 2))
        span = np.where(span > 0.0, span, 1.0)
        result[batch], relative = _newton(prior[batch], offsets / span[:, None], iterations)
        residual[batch] = relative * span
    return result, residual


def placing_largest(rows, count, vertices, points, iterations=_ITERATIONS):
    """Each row's ``count`` largest entries, renormalised and reweighted to place its point.

    Parameters
    ----------
    rows : (p, n) float
        Non-negative coordinates.
    count : int
    vertices : (n, 3) float
    points : (p, 3) float
    iterations : int
        As :func:`reproduce_points`.

    Returns
    -------
    columns : (p, K) int
        K = min(count, n), largest first.
    values : (p, K) float64
        Non-negative, rows summing to 1.
    residual : (p,) float
        As :func:`reproduce_points`.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.reproduction import placing_largest
    >>> corners = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> columns, values, residual = placing_largest([[0.5, 0.3, 0.2, 0.0]], 3, corners, [[0.25, 0.25, 0.0]])
    >>> sorted(columns[0].tolist()), bool(residual[0] < 1e-12)
    ([0, 1, 2], True)
    """
    rows = np.asarray(rows, dtype=np.float64)
    columns = largest_columns(rows, count)
    values = np.take_along_axis(rows, columns, axis=1)
    values /= values.sum(axis=1, keepdims=True)
    return (columns,) + reproduce_points(columns, values, vertices, points, iterations)


def largest_columns(rows, count, magnitude=False):
    """Each row's ``count`` largest entries' columns, largest first (by absolute value
    with ``magnitude``), ranked a batch of rows at a time (bounded temporaries).

    Parameters
    ----------
    rows : (p, n) float
    count : int
        K; more than n keeps n.
    magnitude : bool

    Returns
    -------
    columns : (p, K) int64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.reproduction import largest_columns
    >>> largest_columns(np.array([[0.1, -0.6, 0.05, 0.25]]), 2, magnitude=True).tolist()
    [[1, 3]]
    """
    rows = np.asarray(rows)
    kept = min(int(count), rows.shape[1])
    columns = np.empty((len(rows), kept), dtype=np.int64)
    step = max(1, _CHUNK_ENTRIES // max(1, rows.shape[1]))
    for start in range(0, len(rows), step):
        key = -np.abs(rows[start:start + step]) if magnitude else -rows[start:start + step]
        part = np.argpartition(key, kept - 1, axis=1)[:, :kept]
        order = np.argsort(np.take_along_axis(key, part, axis=1), axis=1, kind="stable")
        columns[start:start + step] = np.take_along_axis(part, order, axis=1)
    return columns
