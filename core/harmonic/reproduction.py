"""Linear precision restored without losing positivity: the closest weights, in relative
entropy, that place each point exactly (docs/MATH.md, "Harmonic coordinates").

A grid's harmonic coordinates place a point near the cage only to within a fraction of a
cell (the nodes outside the cage hold their nearest boundary point's values). Reweighting
them as maximum entropy coordinates with the grid's weights as the prior,

    w_j = prior_j exp(lambda . (R_j - x)) / Z,    lambda such that sum_j w_j R_j = x,

keeps every weight positive where the prior is and zero where it is zero (so locality and
sparsity stay), keeps rows summing to 1, and reproduces x exactly wherever x lies in the
convex hull of the cage vertices the prior weighs.

Here too is the one "keep the K largest" of the core: :func:`largest_columns` chooses,
:func:`largest_entries` renormalises what it keeps (sparse storage, skinning and the
harmonic field's sparse rows all call it).
"""

import numpy as np

__all__ = ["batch_rows", "reproduce_points", "placing_largest", "largest_columns", "largest_entries"]

_ITERATIONS = 40
_CONVERGED = 1e-14  # of each point's span: the mean offset Newton stops at
_CHUNK_ENTRIES = 1 << 15  # (point, weight) entries per batch: bounded memory (about 4 MB in all; the cape)
_PAIRS = [(a, b) for a in range(3) for b in range(a, 3)]


class _Gathered:
    """Rows over their own K cage vertices: offsets ``R_j - x`` (3, p, K), scaled to unit
    span. Component planes, not (p, K, 3) stacks: every step is a few passes over (p, K)
    arrays (numpy's stacked 3 x 3 products are far slower)."""

    def __init__(self, offsets):
        self.offsets = offsets
        self._rows = None  # (active, its offsets): each step's rows gathered once, not per use

    def _part(self, active):
        if self._rows is None or self._rows[0] is not active:  # every row (the first step): no copy
            self._rows = (active, self.offsets if len(active) == self.offsets.shape[1] else self.offsets[:, active])
        return self._rows[1]

    def exponent(self, active, multiplier):
        return np.einsum("Npk,pN->pk", self._part(active), multiplier)

    def mean(self, active, scaled):
        """The weighted mean offset (p', 3), and what :meth:`covariance` needs (nothing)."""
        return np.einsum("Npk,pk->pN", self._part(active), scaled), None

    def covariance(self, active, scaled, mean, _):
        part = self._part(active)
        weighted = part * scaled  # each component's weighted offsets once, for its three pairs
        covariance = np.empty((len(active), 3, 3))
        for a, b in _PAIRS:
            covariance[:, a, b] = covariance[:, b, a] = np.einsum("pk,pk->p", weighted[a], part[b])
        return covariance - mean[:, :, None] * mean[:, None, :]

    def largest_change(self, active, step):
        """Each row's largest exponent change the step makes (exact)."""
        change = np.einsum("Npk,pN->pk", self._part(active), step)
        return np.abs(change, out=change).max(axis=1)

    def residual(self, weights):
        return np.linalg.norm(np.einsum("Npk,pk->pN", self.offsets, weights), axis=1)


class _Dense:
    """Rows over every cage vertex, in matrix products: the exponent ``lambda . R_j`` (the
    ``lambda . x`` part cancels in the normalisation), the moments ``w @ R`` and
    ``w @ (R_a R_b)``; in the cage's unit frame."""

    def __init__(self, vertices, points):
        centre = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
        self.size = max(float(np.abs(vertices - centre).max()), 1e-300)
        self.frame, self.places = (vertices - centre) / self.size, (points - centre) / self.size
        self.products = np.column_stack([self.frame[:, a] * self.frame[:, b] for a, b in _PAIRS])
        self.reach = np.linalg.norm(self.frame, axis=1).max() + np.linalg.norm(self.places, axis=1)  # >= |R_j - x|

    def exponent(self, active, multiplier):
        return multiplier @ self.frame.T

    def mean(self, active, scaled):
        placed = scaled @ self.frame
        return placed - self.places[active], placed

    def covariance(self, active, scaled, mean, placed):
        moments = scaled @ self.products
        covariance = np.empty((len(active), 3, 3))
        for column, (a, b) in enumerate(_PAIRS):
            covariance[:, a, b] = covariance[:, b, a] = moments[:, column] - placed[:, a] * placed[:, b]
        return covariance

    def largest_change(self, active, step):
        """A bound on each row's largest exponent change, through ``|R_j - x|``."""
        return np.linalg.norm(step, axis=1) * self.reach[active]

    def residual(self, weights):
        """In world units."""
        return np.linalg.norm(weights @ self.frame - self.places, axis=1) * self.size


def _newton(prior, geometry, iterations):
    """The weights (p, K) closest to ``prior`` that place their points in ``geometry``
    (:class:`_Gathered` or :class:`_Dense`): Newton's method on the multipliers, each
    row until its mean offset is under ``_CONVERGED``, damped so that no exponent changes
    by more than 1 per step."""
    multiplier = np.zeros((len(prior), 3))
    active = np.arange(len(prior))
    weights = prior.copy()
    for step_count in range(iterations + 1):
        exponent = geometry.exponent(active, multiplier[active])
        exponent -= exponent.max(axis=1, keepdims=True)
        scaled = np.exp(exponent, out=exponent)
        scaled *= prior[active]
        scaled /= scaled.sum(axis=1, keepdims=True)
        mean, kept = geometry.mean(active, scaled)
        moving = np.abs(mean).max(axis=1) > _CONVERGED
        if not moving.any() or step_count == iterations:
            weights[active] = scaled
            break
        weights[active[~moving]] = scaled[~moving]  # the rows stopping here: the others are written later
        active, scaled, mean = active[moving], scaled[moving], mean[moving]
        covariance = geometry.covariance(active, scaled, mean, None if kept is None else kept[moving])
        covariance += 1e-12 * np.eye(3)
        step = np.linalg.solve(covariance, mean[:, :, None])[:, :, 0]
        multiplier[active] -= step / np.maximum(geometry.largest_change(active, step), 1.0)[:, None]
    return weights


def batch_rows(width):
    """Rows of ``width`` weights :func:`reproduce_points` reweights at a time (bounded
    memory); a caller giving it a multiple of this at a time gets the same values, bit
    for bit, as in one call.

    Examples
    --------
    >>> from gencoords.harmonic.reproduction import batch_rows
    >>> batch_rows(322), batch_rows(1 << 20)
    (101, 1)
    """
    return max(1, _CHUNK_ENTRIES // max(1, width))


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
    step = batch_rows(prior.shape[1])
    for start in range(0, len(prior), step):
        batch = slice(start, start + step)
        if indices is None:
            geometry, span = _Dense(vertices, points[batch]), 1.0
        else:
            offsets = np.stack([vertices[indices[batch], axis] - points[batch, axis, None] for axis in range(3)])
            span = np.abs(offsets).max(axis=(0, 2))
            span = np.where(span > 0.0, span, 1.0)
            geometry = _Gathered(offsets / span[:, None])
        result[batch] = _newton(prior[batch], geometry, iterations)
        residual[batch] = geometry.residual(result[batch]) * span
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
    columns, values = largest_entries(rows, count)
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


def largest_entries(rows, count, magnitude=False):
    """Each row's ``count`` largest entries (:func:`largest_columns`), renormalised to sum 1.

    A row of non-negative values is divided by their sum (a row of zeros gets 1/K each).
    A row of both signs can cancel to a small sum, which a division would multiply the row
    by (fuzz seed 261: sizes adding up to 52 became 6,500); it gets the missing sum added
    in proportion to its values' sizes instead (the same as the division for a
    non-negative row), so its sizes grow by no more than that missing sum.

    Parameters
    ----------
    rows : (p, n) float
    count : int
        K; more than n keeps n.
    magnitude : bool
        Largest by absolute value.

    Returns
    -------
    columns : (p, K) int64
        Largest first.
    values : (p, K) float64
        Rows sum to 1.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.reproduction import largest_entries
    >>> columns, values = largest_entries(np.array([[0.1, 0.6, 0.05, 0.25]]), 2)
    >>> columns.tolist(), values.round(4).tolist()
    ([[1, 3]], [[0.7059, 0.2941]])
    """
    rows = np.asarray(rows, dtype=np.float64)
    columns = largest_columns(rows, count, magnitude)
    values = np.take_along_axis(rows, columns, axis=1)
    total = values.sum(axis=1, keepdims=True)
    signed = (values < 0.0).any(axis=1)
    weights = np.empty_like(values)
    sizes = np.abs(values[signed])
    weights[signed] = values[signed] + (1.0 - total[signed]) * sizes / sizes.sum(axis=1, keepdims=True)
    even = np.full_like(values[~signed], 1.0 / max(1, values.shape[1]))  # for rows of zeros
    weights[~signed] = np.divide(values[~signed], total[~signed], out=even, where=total[~signed] > 0.0)
    return columns, weights
