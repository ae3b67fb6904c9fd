"""Fitting a linear blend skin to a deformation: a few rotating bones, at most K weights a vertex.

Given rest positions ``P`` (n, 3) and the same vertices deformed in F frames ``V``
(F, n, 3), find B bones, a rigid transform ``T[f, b]`` (rotation and translation, no
scale, no reflection) per frame and bone, and per vertex at most K non-negative weights
summing to one, such that linear blend skinning

    V[f, i]  ~  sum_k w[i, k] T[f, idx[i, k]] P[i]

(:func:`skin`). This is the smooth skinning decomposition of Le and Deng (SSDR, 2012),
as in Dem Bones: bones are seeded from clusters of vertices that move alike (k-means on
the vertices' trajectories), then the fit alternates between

- the weights, vertex by vertex: among the 2K bones that alone fit the vertex best, the
  subset of at most K and its non-negative weights summing to one that fit it best
  (an exact small least-squares problem per subset, every vertex and subset at once);
- the transforms, bone by bone: a weighted Procrustes problem per bone and frame (SVD
  of 3 x 3 matrices, reflections excluded), with the other bones' parts of each vertex
  held fixed; bones that share no vertex are solved together (a colouring of the bones'
  overlap graph), which is Gauss-Seidel order, vectorised;

and re-seeds bones that lost every vertex where the fit is worst. The rounds are
Anderson-accelerated (alternating least squares converges linearly, slowly where
blends are wide), with steps that would fit worse rejected. Game engines and glTF
read 4 weights per vertex and at most 255 or so bones per skin: ``max_influences`` 4,
``bones`` up to :data:`MAX_BONES`.

The transforms map rest positions to deformed ones (skinning matrices); a bone's pose
matrix (as an armature or glTF stores it) is ``T[f, b] @ rest_matrices[b]``, with the
bone resting at the centre of the vertices it weighs (:class:`SkinFit`).
"""

import itertools
from dataclasses import dataclass

import numpy as np

from ..base import tolerances

__all__ = ["SkinFit", "fit_skin", "fit_transforms", "skin", "deviations", "MAX_BONES"]

MAX_BONES = 255  # bone indices fit a byte (glTF's JOINTS_0 as UNSIGNED_BYTE)
_TRIMS = 3  # rounds of the clusters' trimmed rigid fits
_CHUNK = 2048  # vertices a batch of the weight solve (memory: chunk x subsets x K^2)


@dataclass(frozen=True)
class SkinFit:
    """A fitted linear blend skin (what :func:`fit_skin` returns).

    Attributes
    ----------
    rest_matrices : (B, 4, 4) float64
        Each bone's rest matrix: a translation to the weighted centre of its vertices.
    transforms : (F, B, 4, 4) float64
        Rigid skinning matrices: rest position to position at frame f.
    indices : (n, K) int
        Each vertex's bones; slots it does not need repeat its first bone, weight 0.
    weights : (n, K) float64
        Non-negative, each row summing to one.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skin_fit import fit_skin
    >>> rest = np.random.default_rng(0).normal(size=(50, 3))
    >>> fit = fit_skin(rest, (rest + [1.0, 0.0, 0.0])[None], bones=2, max_influences=2)
    >>> fit.pose_matrices().shape, fit.indices.shape, bool(np.allclose(fit.weights.sum(1), 1))
    ((1, 2, 4, 4), (50, 2), True)
    """

    rest_matrices: np.ndarray
    transforms: np.ndarray
    indices: np.ndarray
    weights: np.ndarray

    def pose_matrices(self):
        """The bones' matrices at each frame, ``transforms @ rest_matrices`` ((F, B, 4, 4))."""
        return self.transforms @ self.rest_matrices


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
    return np.array([_skin_frame(rest, indices, weights, frame[:, :3, :3], frame[:, :3, 3])
                     for frame in transforms]).reshape(len(transforms), len(rest), 3)


def _skin_frame(rest, indices, weights, rotations, translations):
    """One frame of :func:`skin` from rotations (B, 3, 3) and translations (B, 3): (n, 3)."""
    moved = np.einsum("nkij,nj->nki", rotations[indices], rest) + translations[indices]
    return np.einsum("nki,nk->ni", moved, weights)


def deviations(rest, frames, fit):
    """Worst and root-mean-square distance between ``frames`` and the fitted skin's
    positions, as fractions of the rest positions' bounding-box diagonal.

    Parameters
    ----------
    rest : (n, 3) float
    frames : (F, n, 3) float
        The deformation the skin should reproduce, at the frames of ``fit.transforms``.
    fit : SkinFit

    Returns
    -------
    worst, rms : float

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skin_fit import deviations, fit_skin
    >>> rest = np.random.default_rng(0).normal(size=(40, 3))
    >>> frames = np.array([rest + 1.0])
    >>> worst, rms = deviations(rest, frames, fit_skin(rest, frames, bones=1))
    >>> worst < 1e-12 and rms < 1e-12
    True
    """
    rest = np.asarray(rest, dtype=np.float64)
    gaps = np.linalg.norm(skin(rest, fit.indices, fit.weights, fit.transforms) - frames, axis=2)
    diagonal = max(float(np.linalg.norm(np.ptp(rest, axis=0))), tolerances.TINY)
    return float(gaps.max(initial=0.0)) / diagonal, float(np.sqrt(np.mean(gaps ** 2))) / diagonal


def fit_skin(rest, frames, bones=32, max_influences=4, iterations=12, seed=0, progress=None):
    """Fit a linear blend skin with rigid bones to a deformation (SSDR; module docstring).

    Parameters
    ----------
    rest : (n, 3) float
        The vertices at rest.
    frames : (F, n, 3) float
        The same vertices deformed, one frame per row.
    bones : int
        How many bones to seed (1 to :data:`MAX_BONES`, and at most n); bones that end up
        weighing no vertex are dropped, so the result may hold fewer.
    max_influences : int
        K, the most bones per vertex (4 for game engines and glTF).
    iterations : int
        Rounds of weights-then-transforms.
    seed : int
        Seeds the bones' k-means: the same seed gives the same fit.
    progress : callable, optional
        ``progress(fraction)`` after each round (fraction in (0, 1]); an exception it
        raises cancels the fit.

    Returns
    -------
    fit : SkinFit

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skin_fit import fit_skin
    >>> rest = np.random.default_rng(0).normal(size=(60, 3))
    >>> frames = np.array([rest * [1.0, 1.0, 1.2], rest + 0.5])
    >>> fit = fit_skin(rest, frames, bones=4, max_influences=4)
    >>> fit.transforms.shape[:2], bool((fit.weights >= 0).all())
    ((2, 4), True)
    """
    rest, frames = _checked(rest, frames, bones, max_influences)
    rng = np.random.default_rng(seed)
    labels = _trajectory_clusters(rest, frames, bones, rng)
    count = int(labels.max()) + 1
    rotations, translations = _cluster_transforms(rest, frames, labels, count)
    accelerate, plain = _Anderson(), None
    for round_ in range(iterations):
        indices, weights = _fit_weights(rest, frames, rotations, translations, max_influences)
        if plain is not None and _skin_errors(rest, frames, indices, weights, rotations,
                                              translations).sum() > plain[2]:
            # The extrapolated transforms fit worse than the round they came from: take that.
            rotations, translations = plain[0], plain[1]
            accelerate.reset()
            indices, weights = _fit_weights(rest, frames, rotations, translations, max_influences)
        if round_ < iterations - 1 and _reseed_unused_bones(rest, frames, indices, weights,
                                                            rotations, translations):
            accelerate.reset()
        before = rotations.copy(), translations.copy()
        error = _gauss_seidel_sweep(rest, frames, indices, weights, rotations, translations)
        plain = rotations, translations, error
        if round_ < iterations - 1:
            rotations, translations = accelerate.step(before, plain[:2])
        if progress is not None:
            progress((round_ + 1) / max(iterations, 1))
    return _pruned_fit(rest, indices, weights, rotations, translations)


def fit_transforms(rest, frames, indices, weights, sweeps=8):
    """The bones' rigid transforms that best skin ``frames`` with fixed weights (e.g. a
    fit's weights on frames it was not fitted on).

    Parameters
    ----------
    rest : (n, 3) float
    frames : (F, n, 3) float
    indices : (n, K) int
    weights : (n, K) float
        Non-negative, rows summing to one.
    sweeps : int
        Rounds of bone-by-bone Procrustes updates.

    Returns
    -------
    transforms : (F, B, 4, 4) float64
        B is ``indices.max() + 1``; bones weighing no vertex get the identity.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skin_fit import fit_transforms
    >>> rest = np.random.default_rng(0).normal(size=(30, 3))
    >>> moved = fit_transforms(rest, [rest + 2.0], np.zeros((30, 1), int), np.ones((30, 1)))
    >>> np.round(moved[0, 0, :3, 3], 6)
    array([2., 2., 2.])
    """
    rest = np.asarray(rest, dtype=np.float64)
    frames = np.asarray(frames, dtype=np.float64).reshape(-1, len(rest), 3)
    indices, weights = np.asarray(indices), np.asarray(weights, dtype=np.float64)
    count = int(indices.max(initial=0)) + 1
    rotations, translations = _initial_transforms(rest, frames, indices, weights, count)
    for _ in range(sweeps):
        _gauss_seidel_sweep(rest, frames, indices, weights, rotations, translations)
    return _matrices(rotations, translations)


def _checked(rest, frames, bones, max_influences):
    rest = np.asarray(rest, dtype=np.float64)
    frames = np.asarray(frames, dtype=np.float64)
    if rest.ndim != 2 or rest.shape[1] != 3 or frames.ndim != 3 or frames.shape[1:] != rest.shape:
        raise ValueError(f"rest must be (n, 3) and frames (F, n, 3); got {rest.shape} and {frames.shape}")
    if not (np.isfinite(rest).all() and np.isfinite(frames).all()):
        raise ValueError("rest and frames must be finite")
    if not 1 <= bones <= MAX_BONES or bones > len(rest) or max_influences < 1:
        raise ValueError(f"bones must be 1 to {MAX_BONES} and at most the {len(rest)} vertices, "
                         f"max_influences at least 1; got {bones} and {max_influences}")
    return rest, frames


def _matrices(rotations, translations):
    """(F, B, 3, 3) and (F, B, 3) -> (F, B, 4, 4)."""
    matrices = np.zeros(rotations.shape[:-2] + (4, 4))
    matrices[..., :3, :3], matrices[..., :3, 3], matrices[..., 3, 3] = rotations, translations, 1.0
    return matrices


# ----------------------------------------------------------------------------- seeding


def _trajectory_clusters(rest, frames, count, rng, rounds=12):
    """k-means (k-means++ seeds) on the vertices' trajectories (rest and every frame):
    (n,) labels 0 .. c-1, c <= count, empty clusters dropped."""
    features = np.concatenate([rest[None], frames]).transpose(1, 0, 2).reshape(len(rest), -1)
    squared = np.einsum("ij,ij->i", features, features)
    centres = [features[rng.integers(len(features))]]
    nearest = np.einsum("ij,ij->i", features - centres[0], features - centres[0])
    for _ in range(count - 1):
        total = nearest.sum()
        chosen = rng.choice(len(features), p=nearest / total) if total > 0 else rng.integers(len(features))
        centres.append(features[chosen])
        nearest = np.minimum(nearest, np.einsum("ij,ij->i", features - centres[-1], features - centres[-1]))
    centres = np.array(centres)
    labels = None
    for _ in range(rounds):
        distances = squared[:, None] - 2.0 * features @ centres.T + np.einsum("ij,ij->i", centres, centres)
        new = distances.argmin(axis=1)
        if labels is not None and (new == labels).all():
            break
        labels = new
        sizes = np.bincount(labels, minlength=len(centres))
        sums = _sum_by(labels, features, len(centres))
        filled = sizes > 0
        centres[filled] = sums[filled] / sizes[filled, None]
    return np.unique(labels, return_inverse=True)[1].reshape(-1)


def _initial_transforms(rest, frames, indices, weights, count):
    """Each bone's rigid motion of the vertices it weighs (weighted by the weights), as
    rotations (F, B, 3, 3) and translations (F, B, 3); identity for bones without any."""
    rotations = np.broadcast_to(np.eye(3), (len(frames), count, 3, 3)).copy()
    translations = np.zeros((len(frames), count, 3))
    vertex, slot = np.nonzero(weights > 0.0)
    w = weights[vertex, slot]
    _procrustes(indices[vertex, slot], w, rest[vertex], w[None, :, None] * frames[:, vertex],
                rotations, translations)
    return rotations, translations


def _cluster_transforms(rest, frames, labels, count):
    """Each cluster's rigid motion, fitted again (a few times) to the half of its
    vertices that the previous fit moves best: a cluster's edge often straddles two
    bones' blend, and its rigid core is what gives a bone's motion. Returns rotations
    (F, B, 3, 3) and translations (F, B, 3)."""
    kept = np.ones(len(rest))
    sizes = np.bincount(labels, minlength=count)
    for _ in range(_TRIMS):
        rotations, translations = _initial_transforms(rest, frames, labels[:, None], kept[:, None], count)
        moved = np.einsum("fnij,nj->fni", rotations[:, labels], rest) + translations[:, labels]
        residual = ((moved - frames) ** 2).sum(axis=(0, 2))
        order = np.lexsort((residual, labels))
        rank = np.empty(len(rest), dtype=np.int64)
        rank[order] = np.arange(len(rest)) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        kept = (rank < np.maximum(3, (sizes[labels] + 1) // 2)).astype(float)
    return _initial_transforms(rest, frames, labels[:, None], kept[:, None], count)


# -------------------------------------------------------------------------- transforms


def _procrustes(bone_of_pair, mass, points, weighted_targets, rotations, translations):
    """Replace, for each bone with positive mass, its rotation and translation at every
    frame by the rigid map that takes ``points`` closest to their targets, weighted.

    bone_of_pair : (m,) int; mass : (m,) float, the weights a; points : (m, 3), the rest
    positions p; weighted_targets : (F, m, 3), a * y. Minimises sum a |R p + t - y|^2
    per bone and frame (Kabsch: SVD of the 3 x 3 cross-covariance, no reflection).
    """
    count = rotations.shape[1]
    frame_count = len(weighted_targets)
    total = _sum_by(bone_of_pair, mass, count)
    centre_p = _sum_by(bone_of_pair, mass[:, None] * points, count)
    centre_y = _sum_by(bone_of_pair, weighted_targets.transpose(1, 0, 2).reshape(len(points), -1), count)
    products = weighted_targets.transpose(1, 0, 2)[:, :, :, None] * points[:, None, None, :]
    cross = _sum_by(bone_of_pair, products.reshape(len(points), -1), count).reshape(count, frame_count, 3, 3)
    solved = total > tolerances.TINY
    centre_p = centre_p[solved] / total[solved, None]
    sum_y = centre_y[solved].reshape(-1, frame_count, 3)
    # sum a (y - ybar)(p - pbar)^T = sum a y p^T - (sum a y) pbar^T
    covariance = (cross[solved] - sum_y[:, :, :, None] * centre_p[:, None, None, :]).transpose(1, 0, 2, 3)
    u, _, vt = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(u @ vt))
    sign[sign == 0.0] = 1.0
    u[..., :, 2] *= sign[..., None]
    rotation = u @ vt
    rotations[:, solved] = rotation
    mean_y = sum_y.transpose(1, 0, 2) / total[solved][None, :, None]
    translations[:, solved] = mean_y - np.einsum("fbij,bj->fbi", rotation, centre_p)


def _sum_by(groups, values, count):
    """Sums of the rows of ``values`` ((m, ...)) by ``groups`` ((m,) int in [0, count))."""
    out = np.zeros((count,) + values.shape[1:])
    if len(groups) == 0:
        return out
    order = np.argsort(groups, kind="stable")
    ordered = groups[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    out[ordered[starts]] = np.add.reduceat(values[order], starts, axis=0)
    return out


def _colour_classes(indices, weights, count):
    """Bones in groups that share no vertex (greedy colouring of the overlap graph)."""
    used = np.zeros((len(indices), count), dtype=np.float32)
    vertex, slot = np.nonzero(weights > 0.0)
    used[vertex, indices[vertex, slot]] = 1.0
    overlap = (used.T @ used) > 0.0
    colours = np.full(count, -1)
    for bone in np.argsort(-overlap.sum(axis=1), kind="stable"):
        taken = set(colours[overlap[bone]].tolist())
        colours[bone] = next(c for c in itertools.count() if c not in taken)
    return [np.flatnonzero(colours == colour) for colour in range(colours.max() + 1)]


def _gauss_seidel_sweep(rest, frames, indices, weights, rotations, translations):
    """One update of every bone's transforms with the others' fixed (in place); returns
    the skin's summed squared error after it."""
    count = rotations.shape[1]
    predicted = np.array([_skin_frame(rest, indices, weights, r, t)
                          for r, t in zip(rotations, translations)]).reshape(frames.shape)
    in_class = np.zeros(count, dtype=bool)
    for bones in _colour_classes(indices, weights, count):
        in_class[:] = False
        in_class[bones] = True
        vertex, slot = np.nonzero((weights > 0.0) & in_class[indices])
        bone, w = indices[vertex, slot], weights[vertex, slot]
        own = (np.einsum("fmij,mj->fmi", rotations[:, bone], rest[vertex]) + translations[:, bone])
        # What the bone should carry: the frame less the other bones' parts.
        carried = frames[:, vertex] - predicted[:, vertex] + w[None, :, None] * own
        _procrustes(bone, w * w, rest[vertex], w[None, :, None] * carried, rotations, translations)
        new = np.einsum("fmij,mj->fmi", rotations[:, bone], rest[vertex]) + translations[:, bone]
        predicted[:, vertex] += w[None, :, None] * (new - own)  # a vertex is in one pair here
    return float(((predicted - frames) ** 2).sum())


# ----------------------------------------------------------------------------- weights


def _single_bone_errors(rest, frames, rotations, translations):
    """sum_f |R_fb p_i + t_fb - v_fi|^2 less its part that does not depend on b ((n, B)),
    by products of matrices (R is a rotation: |R p|^2 = |p|^2)."""
    frame_count, count = rotations.shape[:2]
    outer = (frames[:, :, :, None] * rest[None, :, None, :]).transpose(1, 0, 2, 3).reshape(len(rest), -1)
    errors = -2.0 * outer @ rotations.transpose(0, 2, 3, 1).reshape(-1, count)
    errors -= 2.0 * frames.transpose(1, 0, 2).reshape(len(rest), -1) @ translations.transpose(0, 2, 1).reshape(-1, count)
    errors += 2.0 * rest @ np.einsum("fbji,fbj->ib", rotations, translations)
    errors += np.einsum("fbi,fbi->b", translations, translations)
    return errors


def _fit_weights(rest, frames, rotations, translations, max_influences):
    """Each vertex's best at most K bones among its 2K best single bones, and their
    non-negative weights summing to one: ((n, K) int, (n, K) float64)."""
    count = rotations.shape[1]
    pool = min(count, 2 * max_influences)
    width = max_influences
    candidates = np.argsort(_single_bone_errors(rest, frames, rotations, translations),
                            axis=1, kind="stable")[:, :pool]
    indices = np.empty((len(rest), width), dtype=np.int64)
    weights = np.zeros((len(rest), width))
    for start in range(0, len(rest), _CHUNK):
        rows = slice(start, start + _CHUNK)
        # Residuals of each candidate alone, (c, pool, F*3); with weights summing to one,
        # the fit's residual is their weighted sum.
        moved = np.einsum("fcpij,cj->cpfi", rotations[:, candidates[rows]], rest[rows]) \
            + translations[:, candidates[rows]].transpose(1, 2, 0, 3)
        residuals = (moved - frames[:, rows].transpose(1, 0, 2)[:, None]).reshape(*candidates[rows].shape, -1)
        gram = residuals @ residuals.transpose(0, 2, 1)
        chosen, w = _best_subsets(gram, width)
        indices[rows] = np.take_along_axis(candidates[rows], chosen, axis=1)
        weights[rows] = w
    return _canonical(indices, weights)


def _best_subsets(gram, width):
    """For each (pool, pool) Gram matrix of residuals, the subset of at most ``width``
    columns and weights w >= 0, sum 1 minimising w^T G w; exact (the optimum is the
    equality-constrained optimum on its own support, feasible, and the best of those).
    Returns (c, width) columns (repeated, weight 0, where fewer) and (c, width) weights."""
    count, pool = gram.shape[:2]
    scale = np.trace(gram, axis1=1, axis2=2) / pool
    ridge = 1e-12 * scale + tolerances.TINY ** 0.5  # keeps ties (equal columns) solvable
    best = np.full(count, np.inf)
    columns = np.zeros((count, width), dtype=np.int64)
    weights = np.zeros((count, width))
    weights[:, 0] = 1.0
    for size in range(1, min(width, pool) + 1):
        subsets = np.array(list(itertools.combinations(range(pool), size)))
        w, error = _subset_optima(gram, subsets, ridge)
        error[(w < 0.0).any(axis=2)] = np.inf
        pick = error.argmin(axis=1)
        better = error[np.arange(count), pick] < best
        best[better] = error[better, pick[better]]
        columns[better] = np.pad(subsets[pick[better]], ((0, 0), (0, width - size)), mode="edge")
        weights[better] = np.pad(w[better, pick[better]], ((0, 0), (0, width - size)))
    return columns, weights


def _subset_optima(gram, subsets, ridge):
    """argmin w^T G_S w over sum(w) = 1 for each subset S ((s, size) columns) of each
    Gram matrix ((c, pool, pool), plus ``ridge`` (c,) on the diagonal): weights
    (c, s, size) and errors (c, s); one and two columns in closed form."""
    size = subsets.shape[1]
    g = gram[:, subsets[:, :, None], subsets[:, None, :]] + ridge[:, None, None, None] * np.eye(size)
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


def _canonical(indices, weights):
    """Slots by decreasing weight, unused ones on the vertex's first bone with weight 0,
    weights clipped to [0, 1] and summing to one exactly in float64."""
    order = np.argsort(-weights, axis=1, kind="stable")
    indices, weights = np.take_along_axis(indices, order, 1), np.take_along_axis(weights, order, 1)
    weights = np.clip(weights, 0.0, None)
    weights /= weights.sum(axis=1, keepdims=True)
    indices = np.where(weights > 0.0, indices, indices[:, :1])
    return indices, weights


def _reseed_unused_bones(rest, frames, indices, weights, rotations, translations):
    """Move each bone that weighs no vertex onto the rigid motion of the neighbourhood
    (in rest positions) of a vertex the skin fits worst (in place); whether any moved."""
    used = np.zeros(rotations.shape[1], dtype=bool)
    used[indices[weights > 0.0]] = True
    unused = np.flatnonzero(~used)
    if len(unused) == 0:
        return False
    error = _skin_errors(rest, frames, indices, weights, rotations, translations)
    worst = np.argsort(-error, kind="stable")[:len(unused)]
    size = min(len(rest), max(4, len(rest) // rotations.shape[1]))
    distances = ((rest[worst][:, None] - rest[None]) ** 2).sum(axis=2)
    nearest = np.argpartition(distances, size - 1, axis=1)[:, :size]
    bone = np.repeat(unused[:len(worst)], size)
    vertex = nearest.reshape(-1)
    _procrustes(bone, np.ones(len(vertex)), rest[vertex], frames[:, vertex], rotations, translations)
    return True


def _skin_errors(rest, frames, indices, weights, rotations, translations):
    """Each vertex's squared distance to the frames, summed over them ((n,))."""
    predicted = np.array([_skin_frame(rest, indices, weights, r, t)
                          for r, t in zip(rotations, translations)]).reshape(frames.shape)
    return ((predicted - frames) ** 2).sum(axis=(0, 2))


class _Anderson:
    """Anderson acceleration of the rounds, a fixed-point map x -> g(x) on the bones'
    transforms: the next x is the combination of the last few g that the linearised
    map sends closest to a fixed point (alternating least squares alone converges
    linearly, and slowly where blends are wide). Rotations are projected back onto
    rotations; the caller rejects steps that fit worse."""

    def __init__(self, memory=5):
        self.memory = memory
        self.reset()

    def reset(self):
        self.points, self.residuals = [], []

    def step(self, before, after):
        """``before`` and ``after`` (rotations (F, B, 3, 3), translations (F, B, 3)) of a
        round: the transforms to start the next round from."""
        x, g = (np.concatenate([r.ravel(), t.ravel()]) for r, t in (before, after))
        self.points, self.residuals = self.points[-self.memory:] + [x], self.residuals[-self.memory:] + [g - x]
        if len(self.points) < 2:
            return after
        residuals = np.diff(np.array(self.residuals), axis=0).T
        images = np.diff(np.array(self.points) + np.array(self.residuals), axis=0).T
        gamma = np.linalg.lstsq(residuals, g - x, rcond=None)[0]
        mixed = g - images @ gamma
        size = after[0].size
        u, _, vt = np.linalg.svd(mixed[:size].reshape(after[0].shape))
        u[..., :, 2] *= np.where(np.linalg.det(u @ vt) < 0.0, -1.0, 1.0)[..., None]
        return u @ vt, mixed[size:].reshape(after[1].shape)


def _pruned_fit(rest, indices, weights, rotations, translations):
    """The fit with only the bones that weigh some vertex, renumbered in order."""
    used = np.unique(indices[weights > 0.0])
    renumber = np.zeros(rotations.shape[1], dtype=np.int64)
    renumber[used] = np.arange(len(used))
    indices = renumber[indices]
    vertex, slot = np.nonzero(weights > 0.0)
    mass = _sum_by(indices[vertex, slot], weights[vertex, slot], len(used))
    centres = _sum_by(indices[vertex, slot], weights[vertex, slot, None] * rest[vertex], len(used))
    rest_matrices = np.broadcast_to(np.eye(4), (len(used), 4, 4)).copy()
    rest_matrices[:, :3, 3] = centres / mass[:, None]
    return SkinFit(rest_matrices, _matrices(rotations[:, used], translations[:, used]), indices, weights)
