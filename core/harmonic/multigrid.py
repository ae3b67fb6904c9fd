"""A numpy multigrid solver for the 7-point Laplacian on a masked grid, many right-hand
sides at once.

The unknowns are the grid nodes inside the mask; every other node is a Dirichlet node
whose value the caller has moved to the right-hand side. The matrix, ``6 x_i - sum of
the inside neighbours' x``, is symmetric positive definite (and an M-matrix). It is
solved by conjugate gradients preconditioned by one multigrid V-cycle per iteration:
coarse levels take every other node (a coarse node is an unknown where the fine node at
its place is), trilinear prolongation P, restriction P^T, the 7-point matrix again on
each level (scaled by 2 per level, as P^T A P is for a smooth function), damped Jacobi
smoothing (as many sweeps after as before, so the V-cycle is symmetric, as conjugate
gradients need) and a dense inverse on the coarsest level.

Vectors are (u + 1, c) arrays, c right-hand sides side by side: row u is a zero that the
missing neighbours' indices point at, so every stencil is a fixed number of row gathers.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["STEPS", "Level", "level_of", "build_levels", "apply_matrix", "v_cycle", "solve"]

_COARSEST = 700  # unknowns solved with a dense inverse
_JACOBI_WEIGHT = 6.0 / 7.0  # the best smoothing factor (5/7) for the 3D 7-point stencil
_SWEEPS = 2  # before and after the coarse correction
# The 7-point stencil's neighbours, as grid index steps.
STEPS = [(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
          if abs(dx) + abs(dy) + abs(dz) == 1]


@dataclass
class Level:
    """One level of the hierarchy.

    Attributes
    ----------
    count : int
        Unknowns u.
    neighbours : (u, 6) int
        Each unknown's neighbours among the unknowns, ``u`` where the neighbour is not one.
    scale : float
        The matrix is ``scale * (6 I - adjacency)``.
    transfer : list of (rows (r,) int, parents (r, w) int, weights (r, w) float)
        Prolongation from the next coarser level, by parity class of the fine node
        (parents: coarse indices, the coarse count where a parent is not an unknown).
    inverse : (u, u) float or None
        The dense inverse, on the coarsest level only.
    diagonal : (u + 1, 1) float or None
        The finest level's own diagonal where it is not 6 everywhere (Shortley-Weller
        rows at the cage: ``solve.boundary_rhs``); the coarse levels keep 6 (a
        preconditioner needs only to be close).
    """

    count: int
    neighbours: np.ndarray
    scale: float
    transfer: list = None
    inverse: np.ndarray = None
    diagonal: np.ndarray = None

    def diagonal_of(self, dtype):
        """The diagonal as a (u + 1, 1) array of ``dtype``, or the scalar 6 * scale."""
        if self.diagonal is None:
            return 6.0 * self.scale
        return self.diagonal.astype(dtype, copy=False)


def _indices(mask):
    """Unknown index of each node of ``mask``, -1 elsewhere, padded by one node of -1."""
    ids = np.full(mask.shape, -1, dtype=np.int64)
    ids[mask] = np.arange(np.count_nonzero(mask))
    return np.pad(ids, 1, constant_values=-1)


def _neighbours(mask, ids):
    count = np.count_nonzero(mask)
    nodes = np.argwhere(mask) + 1  # in the padded grid
    table = np.stack([ids[tuple((nodes + step).T)] for step in STEPS], axis=1)
    table[table < 0] = count
    return table


def _transfer(fine_mask, coarse_ids, coarse_count):
    """Trilinear prolongation from the coarse unknowns to the fine ones, by parity class."""
    nodes = np.argwhere(fine_mask)
    parity = nodes % 2
    classes = parity @ np.array([4, 2, 1])
    groups = []
    for kind in range(8):
        rows = np.flatnonzero(classes == kind)
        odd = np.array([(kind >> 2) & 1, (kind >> 1) & 1, kind & 1])
        choices = [(0, 2) if odd[axis] else (0,) for axis in range(3)]  # fine offsets to parents
        offsets = np.array([(a, b, c) for a in choices[0] for b in choices[1] for c in choices[2]])
        base = nodes[rows] - parity[rows]  # the even node below: parent offset 0
        parents = coarse_ids[tuple(((base[:, None, :] + offsets[None]) // 2 + 1).transpose(2, 0, 1))]
        weights = np.where(parents >= 0, 0.5 ** odd.sum(), 0.0).astype(np.float32)
        parents[parents < 0] = coarse_count
        groups.append((rows, parents, weights))
    return groups


def level_of(mask, scale=1.0, diagonal=None):
    """The matrix of the unknowns ``mask`` (x, y, z bool), ``scale`` times the 7-point
    stencil with ``diagonal`` (u,) where it is not 6, as a Level (for :func:`apply_matrix`)."""
    level = Level(int(np.count_nonzero(mask)), _neighbours(mask, _indices(mask)), scale)
    if diagonal is not None:
        level.diagonal = np.append(np.asarray(diagonal, dtype=np.float64), 1.0)[:, None]
    return level


def build_levels(mask, diagonal=None):
    """The multigrid hierarchy of the unknowns ``mask`` (x, y, z bool), the finest
    level's ``diagonal`` (u,) where it is not 6: list of Level, finest first."""
    levels, scale = [], 1.0
    while True:
        level = level_of(mask, scale, None if levels else diagonal)
        levels.append(level)
        if level.count <= _COARSEST or min(mask.shape) < 3:
            break
        coarse = mask[::2, ::2, ::2]
        level.transfer = _transfer(mask, _indices(coarse), int(np.count_nonzero(coarse)))
        mask, scale = coarse, 2.0 * scale
    last = levels[-1]
    dense = np.zeros((last.count + 1, last.count + 1))
    rows = np.repeat(np.arange(last.count), 6)
    np.add.at(dense, (rows, last.neighbours.reshape(-1)), -last.scale)
    own = 6.0 * last.scale if last.diagonal is None else last.diagonal[:-1, 0]
    dense = dense[:-1, :-1] + np.diag(np.broadcast_to(own, (last.count,)))
    last.inverse = (np.linalg.inv(dense) if last.count else np.zeros((0, 0))).astype(np.float32)
    return levels


def apply_matrix(level, x, out=None, scratch=None):
    """``A x`` for (u + 1, c) ``x``: (u + 1, c), its last row zero."""
    out = np.multiply(x, 6.0 if level.diagonal is None else level.diagonal_of(x.dtype), out=out)
    total = np.empty((level.count, x.shape[1]), x.dtype) if scratch is None else scratch[:-1]
    gathered = np.empty_like(total)
    columns = level.neighbours.T
    np.take(x, columns[0], axis=0, out=total)
    for column in columns[1:]:
        np.take(x, column, axis=0, out=gathered)
        total += gathered
    out[:-1] -= total
    if level.scale != 1.0:
        out *= level.scale
    out[-1] = 0.0
    return out


def _prolong(level, coarse, fine):
    """fine += P coarse."""
    for rows, parents, weights in level.transfer:
        total = weights[:, :1] * coarse[parents[:, 0]]
        for k in range(1, parents.shape[1]):
            total += weights[:, k, None] * coarse[parents[:, k]]
        fine[rows] += total


def _restrict(level, fine, coarse_count):
    """P^T fine: (coarse count + 1, c). Within a parity class and a parent offset the
    parents are distinct, so one fancy-indexed addition per (class, offset) is exact."""
    coarse = np.zeros((coarse_count + 1, fine.shape[1]), fine.dtype)
    for rows, parents, weights in level.transfer:
        for k in range(parents.shape[1]):
            coarse[parents[:, k]] += weights[:, k, None] * fine[rows]
    coarse[-1] = 0.0
    return coarse


def _smooth(level, x, residual, step, product, scratch):
    """One damped Jacobi sweep on ``x`` in place."""
    apply_matrix(level, x, product, scratch)
    np.subtract(residual, product, out=product)
    product *= step
    x += product


def v_cycle(levels, residual, depth=0):
    """One V-cycle from zero for ``A e = residual`` on ``levels[depth]``: e, (u + 1, c).
    Symmetric in ``residual`` (a preconditioner for conjugate gradients)."""
    level = levels[depth]
    if level.inverse is not None:
        result = np.zeros_like(residual)
        result[:-1] = level.inverse @ residual[:-1]
        return result
    step = _JACOBI_WEIGHT / level.diagonal_of(residual.dtype)
    x = step * residual
    product, scratch = np.empty_like(x), np.empty_like(x)
    for _ in range(_SWEEPS - 1):
        _smooth(level, x, residual, step, product, scratch)
    apply_matrix(level, x, product, scratch)
    coarse = _restrict(level, np.subtract(residual, product, out=product), levels[depth + 1].count)
    _prolong(level, v_cycle(levels, coarse, depth + 1), x)
    for _ in range(_SWEEPS):
        _smooth(level, x, residual, step, product, scratch)
    return x


def _precondition(levels, residual):
    """One V-cycle in single precision (half the memory traffic; conjugate gradients in
    double precision keep the solution's accuracy), scaled back to the residual's size."""
    size = np.abs(residual).max(axis=0)
    size[size == 0.0] = 1.0
    return v_cycle(levels, (residual / size).astype(np.float32)).astype(np.float64) * size


def solve(levels, rhs, tolerance, progress=None, max_iterations=200):
    """Solve ``A x = rhs`` for every column by V-cycle preconditioned conjugate gradients.

    Parameters
    ----------
    levels : list of Level
    rhs : (u + 1, c) float
        Last row zero.
    tolerance : float
        Each column stops improving once its residual is below ``tolerance`` times its
        right-hand side's (columns with a zero right-hand side are zero).
    progress : callable, optional
        ``progress(fraction)`` after each iteration, the fraction estimated from the
        residual's decrease; an exception from it stops the solve.
    max_iterations : int

    Returns
    -------
    x : (u + 1, c) float
    reductions : list of float
        The largest relative residual after each iteration.
    """
    level = levels[0]
    x = np.zeros_like(rhs)
    norms = np.linalg.norm(rhs, axis=0)
    limit = tolerance * norms
    residual = rhs.copy()
    z = _precondition(levels, residual)
    direction = z.copy()
    rz = np.einsum("uc,uc->c", residual, z)
    product = np.empty_like(rhs)
    history = []
    while True:
        active = np.linalg.norm(residual, axis=0) > limit
        history.append(float(np.max(np.linalg.norm(residual, axis=0) / np.where(norms > 0, norms, 1.0))))
        if progress is not None:
            progress(min(1.0, np.log(max(history[-1], tolerance)) / np.log(tolerance)))
        if not active.any() or len(history) > max_iterations:
            return x, history
        apply_matrix(level, direction, product)
        curvature = np.einsum("uc,uc->c", direction, product)
        alpha = np.where(active, rz / np.where(curvature > 0.0, curvature, 1.0), 0.0)
        x += alpha * direction
        residual -= alpha * product
        previous = z
        z = _precondition(levels, residual)
        rz_next = np.einsum("uc,uc->c", residual, z)
        # Polak-Ribiere: robust to the single-precision preconditioner's rounding.
        change = rz_next - np.einsum("uc,uc->c", residual, previous)
        beta = np.where(active, change / np.where(rz != 0.0, rz, 1.0), 0.0)
        direction = z + beta * direction
        rz = rz_next
