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

__all__ = ["reproduce_points"]

_ITERATIONS = 40
_CONVERGED = 1e-14  # of each point's span: the mean offset Newton stops at
_CHUNK_ENTRIES = 1 << 21  # (point, weight) entries per batch: bounded memory


def _newton(prior, offsets, iterations):
    """One batch: (weights (p, K), relative residual (p,)) for offsets scaled to unit span."""
    multiplier = np.zeros((len(prior), 3, 1))
    active = np.arange(len(prior))
    weights = prior.copy()
    for _ in range(iterations + 1):
        part = offsets[active]
        exponent = (part @ multiplier[active])[:, :, 0]
        scaled = prior[active] * np.exp(exponent - exponent.max(axis=1, keepdims=True))
        weights[active] = scaled / scaled.sum(axis=1, keepdims=True)
        weighted = weights[active][:, :, None] * part
        mean = weighted.sum(axis=1)
        moving = np.abs(mean).max(axis=1) > _CONVERGED
        if not moving.any() or _ == iterations:
            break
        active, part, weighted, mean = active[moving], part[moving], weighted[moving], mean[moving]
        covariance = part.transpose(0, 2, 1) @ weighted - mean[:, :, None] * mean[:, None, :]
        covariance += 1e-12 * np.eye(3)
        step = np.linalg.solve(covariance, mean[:, :, None])
        # Each exponent changes by at most 1 per step: Newton's step where it is small.
        largest = np.abs(part @ step).max(axis=1)[:, :, None]
        multiplier[active] -= step / np.maximum(largest, 1.0)
    residual = np.linalg.norm(np.einsum("pK,pKN->pN", weights, offsets), axis=1)
    return weights, residual


def reproduce_points(indices, weights, vertices, points, iterations=_ITERATIONS):
    """Reweight non-negative weights so that they place their points exactly.

    Parameters
    ----------
    indices : (p, K) int
        Cage vertices of each point's weights (all n for dense rows).
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
    indices = np.asarray(indices)
    vertices, points = np.asarray(vertices, dtype=np.float64), np.asarray(points, dtype=np.float64)
    result, residual = np.empty_like(prior), np.empty(len(prior))
    step = max(1, _CHUNK_ENTRIES // max(1, prior.shape[1]))
    for start in range(0, len(prior), step):
        batch = slice(start, start + step)
        offsets = vertices[indices[batch]] - points[batch, None]
        span = np.abs(offsets).max(axis=(1, 2))
        span = np.where(span > 0.0, span, 1.0)
        result[batch], relative = _newton(prior[batch], offsets / span[:, None, None], iterations)
        residual[batch] = relative * span
    return result, residual
