"""Harmonic coordinates at the grid's nodes: the Dirichlet problem of every cage vertex,
solved together.

Column j of the result is the discrete harmonic function whose Dirichlet values are cage
vertex j's hat values. The unknowns are the nodes strictly inside the cage; each inside
node's Dirichlet neighbours put their hat values on the right-hand side. The matrix is
an M-matrix and the Dirichlet values are non-negative and sum to 1 over the columns, so
the exact discrete solution is non-negative with rows summing to 1 (the discrete maximum
principle); the iterative solution is clipped at 0 and renormalised, changes of the
order of the solver's tolerance.
"""

import numpy as np

from .multigrid import build_levels, solve

__all__ = ["SOLVER_TOLERANCE", "dirichlet_rhs", "solve_nodes"]

# Relative residual each column is solved to: errors far below the 1e-5 that sparse
# storage drops, so locality is the discretisation's, not the solver's.
SOLVER_TOLERANCE = 1e-10
# Entries of one block of columns' (unknowns x columns) arrays: the solver holds about
# ten such arrays, so blocks of 2^21 entries (16 MB each) bound its memory.
_BLOCK_ENTRIES = 1 << 21
_STEPS = np.array([(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                   if abs(dx) + abs(dy) + abs(dz) == 1])


def dirichlet_rhs(inside, node_ids, hat_columns, hat_values):
    """The right-hand side as triplets: inside node i gets the hat values of each of its
    neighbours that is not inside.

    Parameters
    ----------
    inside : (x, y, z) bool
        The unknowns (row order: ``np.argwhere(inside)``).
    node_ids : (x, y, z) int
        Each node's row in ``hat_columns`` / ``hat_values`` (-1 where it has none; every
        neighbour of an inside node that is not inside must have one).
    hat_columns : (b, 3) int
    hat_values : (b, 3) float

    Returns
    -------
    rows : (t,) int
    columns : (t,) int
    values : (t,) float
    """
    nodes = np.argwhere(inside)
    padded_inside = np.pad(inside, 1)
    padded_ids = np.pad(node_ids, 1, constant_values=-1)
    rows, hats = [], []
    for step in _STEPS:
        neighbour = tuple((nodes + 1 + step).T)
        boundary = ~padded_inside[neighbour]
        rows.append(np.flatnonzero(boundary))
        hats.append(padded_ids[neighbour][boundary])
    rows, hats = np.concatenate(rows), np.concatenate(hats)
    if (hats < 0).any():
        raise RuntimeError("an inside node's neighbour has no boundary value")
    return np.repeat(rows, 3), hat_columns[hats].reshape(-1), hat_values[hats].reshape(-1)


def solve_nodes(inside, rhs, column_count, tolerance=SOLVER_TOLERANCE, progress=None):
    """Harmonic coordinates of the inside nodes.

    Parameters
    ----------
    inside : (x, y, z) bool
        The unknowns.
    rhs : (rows, columns, values)
        From :func:`dirichlet_rhs`.
    column_count : int
        n, the cage's vertices.
    tolerance : float
        Relative residual per column.
    progress : callable, optional
        ``progress(fraction)`` as blocks of columns are solved; an exception from it
        stops the solve.

    Returns
    -------
    coordinates : (u, n) float
        Non-negative, rows summing to 1.
    history : list of float
        The largest relative residual after each conjugate-gradient iteration, of the
        block that needed most.
    """
    levels = build_levels(inside)
    count = levels[0].count
    result = np.empty((count, column_count))
    block = int(max(1, min(column_count, _BLOCK_ENTRIES // (count + 1))))
    rows, columns, values = rhs
    history = []
    for start in range(0, column_count, block):
        stop = min(start + block, column_count)
        chosen = (columns >= start) & (columns < stop)
        right = np.zeros((count + 1, stop - start))
        np.add.at(right, (rows[chosen], columns[chosen] - start), values[chosen])
        report = None if progress is None else (lambda f, a=start, b=stop: progress((a + f * (b - a)) / column_count))
        solution, reductions = solve(levels, right, tolerance, report)
        result[:, start:stop] = solution[:-1]
        history = max(history, reductions, key=len)
    np.maximum(result, 0.0, out=result)
    result /= result.sum(axis=1, keepdims=True)
    return result, history
