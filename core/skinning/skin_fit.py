"""Fitting a linear blend skin to a deformation: a few rotating bones, at most K weights a vertex.

Given rest positions ``P`` (n, 3) and the same vertices deformed in F frames ``V``
(F, n, 3), find B bones, a rigid transform ``T[f, b]`` (rotation and translation, no
scale, no reflection) per frame and bone, and per vertex at most K non-negative weights
summing to one, such that linear blend skinning

    V[f, i]  ~  sum_k w[i, k] T[f, idx[i, k]] P[i]

(:func:`skin`). This is the smooth skinning decomposition of Le and Deng (SSDR, 2012),
as in Dem Bones: bones are seeded from clusters of vertices that move alike (k-means on
the vertices' trajectories), then the fit alternates between

- the weights, vertex by vertex: at most K of the 2K bones that alone fit the vertex
  best, non-negative and summing to one (an active set, ``skin_steps``);
- the transforms, bone by bone: a weighted Procrustes problem per bone and frame, the
  other bones' parts of each vertex held fixed (Gauss-Seidel order, ``skin_steps``);

and re-seeds bones that lost every vertex where the fit is worst. The rounds are
Anderson-accelerated (alternating least squares converges linearly, slowly where
blends are wide), with steps that would fit worse rejected. On a large mesh the rounds
fit the bones' motions to a random sample of :data:`SAMPLE` vertices (a few thousand
pin a bone's rigid motion as well as all of them), and every vertex's weights are then
solved once against them. Game engines and glTF read 4 weights per vertex (some 8)
and at most 255 or so bones per skin: ``max_influences`` 4, ``bones`` up to
:data:`MAX_BONES`.

The transforms map rest positions to deformed ones (skinning matrices); a bone's pose
matrix (as an armature or glTF stores it) is ``T[f, b] @ rest_matrices[b]``, with the
bone resting at the centre of the vertices it weighs (:class:`SkinFit`).
"""

from dataclasses import dataclass

import numpy as np

from ..base import tolerances
from .skin_steps import (bone_motions, bone_pairs, fit_weights, gauss_seidel_sweep, matrices, rigid_fit,
                         skin, skin_errors)

__all__ = ["SkinFit", "fit_skin", "fit_transforms", "skin", "deviations", "MAX_BONES"]

MAX_BONES = 255  # bone indices fit a byte (glTF's JOINTS_0 as UNSIGNED_BYTE)
SAMPLE = 6000  # vertices the rounds fit the bones' motions to (all, on smaller meshes)
_TRIMS = 3  # rounds of the clusters' trimmed rigid fits


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
        K, the most bones per vertex (4 for game engines and glTF, some take 8); the
        weight step's cost grows about as K^4 per vertex (8 costs under twice 4 here).
    iterations : int
        Rounds of weights-then-transforms.
    seed : int
        Seeds the bones' k-means: the same seed gives the same fit.
    progress : callable, optional
        ``progress(fraction)`` between small steps (a fraction of a second apart on a
        character of 43,000 vertices; fraction in [0, 1], non-decreasing, 1 at the end);
        an exception it raises cancels the fit.

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
    steps = _Progress(progress, iterations + 1)
    sample = np.arange(len(rest)) if len(rest) <= SAMPLE else np.sort(rng.choice(len(rest), SAMPLE, replace=False))
    points, moving = rest[sample], frames[:, sample]
    labels = _trajectory_clusters(points, moving, bones, rng, steps.tick)
    rotations, translations = _cluster_transforms(points, moving, labels, int(labels.max()) + 1)
    rotations, translations = _rounds(points, moving, rotations, translations, max_influences, iterations, steps)
    # Every vertex's weights against the last round's transforms.
    indices, weights = fit_weights(rest, frames, rotations, translations, max_influences, steps.tick)
    steps.tick(1.0)
    return _pruned_fit(rest, indices, weights, rotations, translations)


def _rounds(rest, frames, rotations, translations, max_influences, iterations, steps):
    """The alternation (module docstring): the transforms after ``iterations`` rounds."""
    accelerate, plain, count = _Anderson(), None, rotations.shape[1]
    for round_ in range(iterations):
        indices, weights = fit_weights(rest, frames, rotations, translations, max_influences,
                                       lambda part: steps.tick(0.5 * part))
        pairs = bone_pairs(indices, weights, count)
        if plain is not None and skin_errors(rest, frames, pairs, rotations, translations).sum() > plain[2]:
            # The extrapolated transforms fit worse than the round they came from: take that.
            rotations, translations = plain[0], plain[1]
            accelerate.reset()
            indices, weights = fit_weights(rest, frames, rotations, translations, max_influences)
            pairs = bone_pairs(indices, weights, count)
        if round_ < iterations - 1 and _reseed_unused_bones(rest, frames, pairs, rotations, translations):
            accelerate.reset()
        before = rotations.copy(), translations.copy()
        error = gauss_seidel_sweep(rest, frames, pairs, rotations, translations,
                                   lambda part: steps.tick(0.5 + 0.5 * part))
        plain = rotations, translations, error
        if round_ < iterations - 1:
            rotations, translations = accelerate.step(before, plain[:2])
        steps.next()
    return rotations, translations


class _Progress:
    """``progress(fraction)`` over a fit's stages: ``tick(part)`` within the current
    stage (part from 0 to 1), ``next()`` at its end."""

    def __init__(self, progress, stages):
        self.progress, self.stages, self.done = progress, max(stages, 1), 0

    def tick(self, part=0.0):
        if self.progress is not None:
            self.progress(min((self.done + part) / self.stages, 1.0))

    def next(self):
        self.done += 1
        self.tick()


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
    pairs = bone_pairs(indices, weights, int(indices.max(initial=0)) + 1)
    rotations, translations = _initial_transforms(rest, frames, pairs)
    for _ in range(sweeps):
        gauss_seidel_sweep(rest, frames, pairs, rotations, translations)
    return matrices(rotations, translations)


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


# ----------------------------------------------------------------------------- seeding


def _trajectory_clusters(rest, frames, count, rng, tick, rounds=12):
    """k-means (k-means++ seeds) on the vertices' trajectories (rest and every frame):
    (n,) labels 0 .. c-1, c <= count, empty clusters dropped; ``tick()`` between rounds."""
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
        tick()
        distances = squared[:, None] - 2.0 * features @ centres.T + np.einsum("ij,ij->i", centres, centres)
        new = distances.argmin(axis=1)
        if labels is not None and (new == labels).all():
            break
        labels = new
        sizes = np.bincount(labels, minlength=len(centres))
        sums = np.zeros_like(centres)
        np.add.at(sums, labels, features)
        filled = sizes > 0
        centres[filled] = sums[filled] / sizes[filled, None]
    return np.unique(labels, return_inverse=True)[1].reshape(-1)


def _initial_transforms(rest, frames, pairs):
    """Each bone's rigid motion of the vertices it weighs (``skin_steps.bone_pairs``,
    weighted by the weights), as rotations (F, B, 3, 3) and translations (F, B, 3);
    identity for bones without any."""
    rotations = np.broadcast_to(np.eye(3), (len(frames), len(pairs), 3, 3)).copy()
    translations = np.zeros((len(frames), len(pairs), 3))
    bone_motions(rest, frames, pairs, rotations, translations)
    return rotations, translations


def _cluster_transforms(rest, frames, labels, count):
    """Each cluster's rigid motion, fitted again (a few times) to the half of its
    vertices that the previous fit moves best: a cluster's edge often straddles two
    bones' blend, and its rigid core is what gives a bone's motion. Returns rotations
    (F, B, 3, 3) and translations (F, B, 3)."""
    kept = np.ones(len(rest))
    sizes = np.bincount(labels, minlength=count)
    for _ in range(_TRIMS):
        rotations, translations = _initial_transforms(rest, frames, bone_pairs(labels[:, None], kept[:, None], count))
        moved = np.einsum("fnij,nj->fni", rotations[:, labels], rest) + translations[:, labels]
        residual = ((moved - frames) ** 2).sum(axis=(0, 2))
        order = np.lexsort((residual, labels))
        rank = np.empty(len(rest), dtype=np.int64)
        rank[order] = np.arange(len(rest)) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        kept = (rank < np.maximum(3, (sizes[labels] + 1) // 2)).astype(float)
    return _initial_transforms(rest, frames, bone_pairs(labels[:, None], kept[:, None], count))


def _reseed_unused_bones(rest, frames, pairs, rotations, translations):
    """Move each bone that weighs no vertex onto the rigid motion of the neighbourhood
    (in rest positions) of a vertex the skin fits worst (in place); whether any moved."""
    unused = [bone for bone, (vertex, _) in enumerate(pairs) if not len(vertex)]
    if not unused:
        return False
    error = skin_errors(rest, frames, pairs, rotations, translations)
    worst = np.argsort(-error, kind="stable")[:len(unused)]
    size = min(len(rest), max(4, len(rest) // len(pairs)))
    distances = ((rest[worst][:, None] - rest[None]) ** 2).sum(axis=2)
    for bone, nearest in zip(unused, np.argpartition(distances, size - 1, axis=1)[:, :size]):
        rotations[:, bone], translations[:, bone] = rigid_fit(np.ones(size), rest[nearest], frames[:, nearest])
    return True


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
    rest_matrices = np.broadcast_to(np.eye(4), (len(used), 4, 4)).copy()
    for bone, (vertex, mass) in enumerate(bone_pairs(indices, weights, len(used))):
        rest_matrices[bone, :3, 3] = mass @ rest[vertex] / mass.sum()
    return SkinFit(rest_matrices, matrices(rotations[:, used], translations[:, used]), indices, weights)
