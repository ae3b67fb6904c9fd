"""The two least-squares steps of fitting a linear blend skin (``skin_fit``'s rounds):

- the bones' transforms with the weights held: a weighted Procrustes problem per bone
  and frame (SVD of 3 x 3 matrices, reflections excluded), with the other bones' parts
  of each vertex held fixed, bone after bone (Gauss-Seidel order);
- each vertex's weights with the transforms held: at most K bones among its 2K best
  single bones, non-negative weights summing to one, by an active set (Lawson and
  Hanson's non-negative least squares on the simplex, adding the bone whose weight most
  lowers the error until K are in: its cost grows as K^4 per vertex, where the best
  subset among 2K candidates grows as 4^K: that is searched only up to K = 4).

Array shapes: rest (n, 3), frames (F, n, 3), rotations (F, B, 3, 3), translations
(F, B, 3), indices and weights (n, K). ``tick(part)`` arguments, where taken, are called
between small steps with the part of the step done (0 to 1): an exception they raise
stops the step (a cancelled fit).
"""

import itertools
from math import comb

import numpy as np

from ..base import tolerances

_CHUNK = 512  # vertices a batch of the weight solve (memory: chunk x bones x F x 3)
_EXHAUSTIVE = 256  # subsets of the pool up to which the best one is searched exhaustively (K <= 4)
_STEP_TOLERANCE = 1e-9  # improvements below this share of a vertex's error end its active set


def skin(rest, indices, weights, transforms):
    """Linear blend skinning of ``rest`` at every frame of ``transforms``.

    Parameters
    ----------
    rest : (n, 3) float
    indices : (n, K) int
    weights : (n, K) float
    transforms : (F, B, 4, 4) float
        Skinning matrices (rest to frame).

    Returns
    -------
    positions : (F, n, 3) float64
        ``sum_k weights[i, k] * transforms[f, indices[i, k]] @ rest[i]``.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skin_fit import skin
    >>> turn = np.eye(4); turn[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    >>> transforms = np.array([[np.eye(4), turn]])
    >>> skin([[1.0, 0.0, 0.0]], [[0, 1]], [[0.5, 0.5]], transforms)
    array([[[0.5, 0.5, 0. ]]])
    """
    rest = np.asarray(rest, dtype=np.float64)
    indices, weights = np.asarray(indices), np.asarray(weights, dtype=np.float64)
    transforms = np.asarray(transforms, dtype=np.float64)
    # Slot by slot (a bone may repeat in a row): the reference the fit's own sums are checked by.
    positions = np.zeros((len(transforms), len(rest), 3))
    for slot in range(indices.shape[1]):
        chosen = transforms[:, indices[:, slot]]
        moved = np.einsum("fnij,nj->fni", chosen[..., :3, :3], rest) + chosen[..., :3, 3]
        positions += weights[None, :, slot, None] * moved
    return positions


def matrices(rotations, translations):
    """(..., 3, 3) and (..., 3) -> (..., 4, 4)."""
    out = np.zeros(rotations.shape[:-2] + (4, 4))
    out[..., :3, :3], out[..., :3, 3], out[..., 3, 3] = rotations, translations, 1.0
    return out


def bone_pairs(indices, weights, count):
    """Each bone's vertices and weights (positive weights only): a list of ``count``
    ((m_b,) int, (m_b,) float) pairs; a vertex appears once per bone (rows of ``indices``
    repeat a bone only with weight 0, as fits write them)."""
    vertex, slot = np.nonzero(weights > 0.0)
    bone, mass = indices[vertex, slot], weights[vertex, slot]
    order = np.argsort(bone, kind="stable")
    bounds = np.searchsorted(bone[order], np.arange(count + 1))
    return [(vertex[order[a:b]], mass[order[a:b]]) for a, b in zip(bounds[:-1], bounds[1:])]


def moved_by(rest, rotations, translations, bone):
    """``rest`` ((m, 3)) moved by bone ``bone`` at every frame: (F, m, 3)."""
    return rest @ rotations[:, bone].transpose(0, 2, 1) + translations[:, bone, None]


def skinned(rest, pairs, rotations, translations):
    """The skin's positions at every frame, (F, n, 3), from :func:`bone_pairs`."""
    positions = np.zeros((len(rotations), len(rest), 3))
    for bone, (vertex, mass) in enumerate(pairs):
        if len(vertex):
            positions[:, vertex] += mass[None, :, None] * moved_by(rest[vertex], rotations, translations, bone)
    return positions


def skin_errors(rest, frames, pairs, rotations, translations):
    """Each vertex's squared distance to the frames, summed over them ((n,))."""
    return ((skinned(rest, pairs, rotations, translations) - frames) ** 2).sum(axis=(0, 2))


def rigid_fit(mass, points, weighted_targets):
    """The rigid map that takes ``points`` ((m, 3)) closest to their targets at every
    frame, weighted: minimises sum a |R p + t - y|^2 (Kabsch: SVD of the 3 x 3
    cross-covariance, no reflection). ``mass`` (m,) holds a, ``weighted_targets``
    (F, m, 3) a * y. Returns rotations (F, 3, 3) and translations (F, 3), or None
    without mass."""
    total = mass.sum()
    if not total > tolerances.TINY:
        return None
    centre_p = mass @ points / total
    sum_y = weighted_targets.sum(axis=1)
    # sum a (y - ybar)(p - pbar)^T = sum a y p^T - (sum a y) pbar^T
    covariance = weighted_targets.transpose(0, 2, 1) @ points - sum_y[:, :, None] * centre_p
    u, _, vt = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(u @ vt))
    sign[sign == 0.0] = 1.0
    u[..., :, 2] *= sign[..., None]
    rotation = u @ vt
    return rotation, sum_y / total - rotation @ centre_p


def bone_motions(rest, frames, pairs, rotations, translations):
    """Each bone's rigid motion of the vertices it weighs, weighted (in place; bones
    without any keep theirs)."""
    for bone, (vertex, mass) in enumerate(pairs):
        solved = rigid_fit(mass, rest[vertex], mass[None, :, None] * frames[:, vertex])
        if solved is not None:
            rotations[:, bone], translations[:, bone] = solved


def gauss_seidel_sweep(rest, frames, pairs, rotations, translations, tick=None):
    """One update of every bone's transforms with the others' fixed (in place), bone
    after bone; returns the skin's summed squared error after it."""
    predicted = skinned(rest, pairs, rotations, translations)
    for bone, (vertex, mass) in enumerate(pairs):
        if tick is not None and bone % 8 == 0:
            tick(bone / len(pairs))
        if not len(vertex):
            continue
        points = rest[vertex]
        own = moved_by(points, rotations, translations, bone)
        # What the bone should carry: the frame less the other bones' parts.
        carried = frames[:, vertex] - predicted[:, vertex] + mass[None, :, None] * own
        solved = rigid_fit(mass * mass, points, mass[None, :, None] * carried)
        if solved is None:
            continue
        rotations[:, bone], translations[:, bone] = solved
        predicted[:, vertex] += mass[None, :, None] * (moved_by(points, rotations, translations, bone) - own)
    return float(((predicted - frames) ** 2).sum())


def fit_weights(rest, frames, rotations, translations, max_influences, tick=None):
    """Each vertex's at most K bones among its 2K best single bones, and their
    non-negative weights summing to one: ((n, K) int, (n, K) float64)."""
    frame_count, count = rotations.shape[:2]
    pool = min(count, 2 * max_influences)
    # Every bone's 3 x 4 matrix at every frame as one (4, B * F * 3) product.
    affine = np.concatenate([rotations, translations[..., None]], axis=3).transpose(3, 1, 0, 2).reshape(4, -1)
    indices = np.empty((len(rest), max_influences), dtype=np.int64)
    weights = np.zeros((len(rest), max_influences))
    for start in range(0, len(rest), _CHUNK):
        if tick is not None:
            tick(start / len(rest))
        rows = slice(start, start + _CHUNK)
        # Residuals of each bone alone, (c, B, F*3); with weights summing to one, the
        # skin's residual is their weighted sum.
        moved = (np.column_stack([rest[rows], np.ones(len(rest[rows]))]) @ affine).reshape(-1, count, frame_count * 3)
        residuals = moved - frames[:, rows].transpose(1, 0, 2).reshape(-1, 1, frame_count * 3)
        errors = np.einsum("cbk,cbk->cb", residuals, residuals)
        candidates = np.argpartition(errors, pool - 1, axis=1)[:, :pool] if pool < count else \
            np.broadcast_to(np.arange(count), errors.shape)
        residuals = np.take_along_axis(residuals, candidates[:, :, None], axis=1)
        chosen, w = simplex_weights(residuals @ residuals.transpose(0, 2, 1), max_influences)
        indices[rows] = np.take_along_axis(candidates, chosen, axis=1)
        weights[rows] = w
    return canonical(indices, weights)


def simplex_weights(gram, width):
    """For each (pool, pool) Gram matrix G of residuals, weights w >= 0 summing to one
    on at most ``width`` columns that make w^T G w small. An active set grown from the
    best single column (each step adding the column of most negative reduced gradient)
    that stops below ``width`` columns is the optimum; where it reaches ``width``, the
    best subset is searched exhaustively while the subsets are few (``width`` <= 4 of 8
    columns), else the better is kept of it and the optimum over every column cut to its
    ``width`` largest weights and solved again on them.

    Returns (c, width) columns (repeated, weight 0, where fewer) and (c, width) weights.
    """
    count, pool = gram.shape[:2]
    scale = np.trace(gram, axis1=1, axis2=2) / pool
    # The ridge keeps ties (equal columns) solvable.
    gram = gram + (1e-12 * scale + tolerances.TINY ** 0.5)[:, None, None] * np.eye(pool)
    inside = np.zeros((count, pool), dtype=bool)
    inside[np.arange(count), np.argmin(np.diagonal(gram, axis1=1, axis2=2), axis=1)] = True
    w, inside = _grown(gram, inside.astype(np.float64), inside, width, scale)
    # A set that stopped growing below ``width`` is the optimum over every column already.
    full = np.flatnonzero(inside.sum(axis=1) == width) if width < pool else np.zeros(0, dtype=np.int64)
    if len(full) and sum(comb(pool, size) for size in range(1, width + 1)) <= _EXHAUSTIVE:
        w[full], inside[full] = _best_subset(gram[full], width)
    elif len(full):
        g = gram[full]
        free, _ = _grown(g, w[full], inside[full], pool, scale[full])
        largest = np.zeros((len(full), pool), dtype=bool)
        np.put_along_axis(largest, np.argsort(-free, axis=1, kind="stable")[:, :width], True, axis=1)
        cut, largest = _lawson_hanson(g, np.where(largest, free, 0.0) / (free * largest).sum(axis=1, keepdims=True),
                                      largest & (free > 0.0))
        better = np.einsum("ci,cij,cj->c", cut, g, cut) < np.einsum("ci,cij,cj->c", w[full], g, w[full])
        w[full[better]], inside[full[better]] = cut[better], largest[better]
    columns = np.argsort(~inside, axis=1, kind="stable")[:, :width]
    weights = np.take_along_axis(w, columns, axis=1) * np.take_along_axis(inside, columns, axis=1)
    short = width - columns.shape[1]  # fewer candidates than slots
    return np.pad(columns, ((0, 0), (0, short)), mode="edge"), np.pad(weights, ((0, 0), (0, short)))


def _grown(gram, w, inside, width, scale):
    """The active set grown from feasible weights ``w`` on ``inside`` ((c, pool)): each
    step adds the column of most negative reduced gradient (while fewer than ``width``
    are in) and re-solves (Lawson-Hanson); every step lowers w^T G w."""
    rows = np.arange(len(w))
    for _ in range(3 * width):
        gradient = np.einsum("cij,cj->ci", gram, w)
        reduced = np.where(inside, np.inf, gradient - np.einsum("ci,ci->c", gradient, w)[:, None])
        pick = reduced.argmin(axis=1)
        grow = (reduced[rows, pick] < -_STEP_TOLERANCE * scale) & (inside.sum(axis=1) < width)
        if not grow.any():
            break
        inside[grow, pick[grow]] = True
        w[grow], inside[grow] = _lawson_hanson(gram[grow], w[grow], inside[grow])
    return w, inside


def _lawson_hanson(gram, w, inside):
    """The inner loop: the optimum on the set (``inside``), or a step towards it that
    stops where a weight reaches zero (that column leaves), until no weight would turn
    negative; (c, pool) weights and set."""
    rows = np.arange(len(w))
    for _ in range(inside.shape[1]):
        target = _set_optima(gram[rows], inside[rows])
        low = inside[rows] & (target <= 0.0)
        blocked = low.any(axis=1)
        w[rows[~blocked]] = target[~blocked]
        rows, old, new, low = rows[blocked], w[rows[blocked]], target[blocked], low[blocked]
        if not len(rows):
            break
        ratio = np.where(low, old / np.maximum(old - new, tolerances.TINY), np.inf)
        step = np.clip(ratio.min(axis=1), 0.0, 1.0)[:, None]
        moved = old + step * (new - old)
        kept = inside[rows] & (moved > 0.0) & ~(low & (ratio <= step))
        moved = np.where(kept, moved, 0.0)
        w[rows], inside[rows] = moved / moved.sum(axis=1, keepdims=True), kept
    return w, inside


def _set_optima(gram, inside):
    """argmin w^T G w over sum(w) = 1, w zero outside ``inside`` ((c, pool) bool), for
    each Gram matrix ((c, pool, pool)): (c, pool), by the KKT system (G w + mu 1 = 0)
    with identity rows outside the set."""
    count, pool = inside.shape
    system = np.zeros((count, pool + 1, pool + 1))
    both = inside[:, :, None] & inside[:, None, :]
    system[:, :pool, :pool] = np.where(both, gram, 0.0)
    system[:, :pool, :pool] += np.eye(pool) * ~inside[:, :, None]
    system[:, :pool, pool] = system[:, pool, :pool] = inside
    right = np.zeros((count, pool + 1, 1))
    right[:, pool, 0] = 1.0
    return np.linalg.solve(system, right)[:, :pool, 0]


def _best_subset(gram, width):
    """The best subset of at most ``width`` columns for each Gram matrix ((c, pool,
    pool), ridge added), exact (the optimum is the equality-constrained optimum on its
    own support, feasible, and the best of those): (c, pool) weights and set."""
    count, pool = gram.shape[:2]
    best = np.full(count, np.inf)
    weights = np.zeros((count, pool))
    for size in range(1, width + 1):
        subsets = np.array(list(itertools.combinations(range(pool), size)))
        w, error = _subset_optima(gram, subsets)
        error[(w < 0.0).any(axis=2)] = np.inf
        pick = error.argmin(axis=1)
        better = error[np.arange(count), pick] < best
        best[better] = error[better, pick[better]]
        rows = np.flatnonzero(better)
        picked = np.zeros((len(rows), pool))
        np.put_along_axis(picked, subsets[pick[rows]], w[rows, pick[rows]], axis=1)
        weights[rows] = picked
    return weights, weights > 0.0


def _subset_optima(gram, subsets):
    """argmin w^T G_S w over sum(w) = 1 for each subset S ((s, size) columns) of each
    Gram matrix ((c, pool, pool)): weights (c, s, size) and errors (c, s); one and two
    columns in closed form."""
    size = subsets.shape[1]
    g = gram[:, subsets[:, :, None], subsets[:, None, :]]
    if size == 1:
        return np.ones(g.shape[:3]), g[:, :, 0, 0]
    if size == 2:
        first = (g[..., 1, 1] - g[..., 0, 1]) / (g[..., 0, 0] + g[..., 1, 1] - 2.0 * g[..., 0, 1])
        w = np.stack([first, 1.0 - first], axis=2)
        return w, np.einsum("csi,csij,csj->cs", w, g, w)
    # KKT: G w + mu 1 = 0, 1^T w = 1; then w^T G w = -mu.
    system = np.empty(g.shape[:2] + (size + 1, size + 1))
    system[..., :size, :size] = g
    system[..., size, :] = system[..., :, size] = 1.0
    system[..., size, size] = 0.0
    right = np.zeros(g.shape[:2] + (size + 1, 1))
    right[..., size, 0] = 1.0
    solution = np.linalg.solve(system, right)[..., 0]
    return solution[..., :size], -solution[..., size]


def canonical(indices, weights):
    """Slots by decreasing weight, unused ones on the vertex's first bone with weight 0,
    weights clipped to [0, 1] and summing to one exactly in float64."""
    order = np.argsort(-weights, axis=1, kind="stable")
    indices, weights = np.take_along_axis(indices, order, 1), np.take_along_axis(weights, order, 1)
    weights = np.clip(weights, 0.0, None)
    weights /= weights.sum(axis=1, keepdims=True)
    indices = np.where(weights > 0.0, indices, indices[:, :1])
    return indices, weights
