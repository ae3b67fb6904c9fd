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

import secrets

import numpy as np

from ..base.errors import WorkerError
from ..base.grid import node_positions
from ..evaluation.interpreters import available_cores, python_executable
from ..evaluation.parallel import WorkerPool, computed_here_instead, dispatch_units
from ..evaluation.shared_memory import SharedArrays
from .boundary_values import segment_crossings
from .elimination import elimination_plan, slab_axis, slab_layout, solve_in_slab_order
from .multigrid import STEPS, apply_matrix, build_levels, level_of, solve

__all__ = ["SOLVER_TOLERANCE", "NEAREST_CROSSING", "boundary_rhs", "solve_nodes", "solved_rows", "solve_columns_task", "worker_count"]

# Relative residual each column is solved to: errors far below the 1e-5 that sparse
# storage drops, so locality is the discretisation's, not the solver's.
SOLVER_TOLERANCE = 1e-10
# Entries of one block of columns' (unknowns x columns) arrays: the solver holds about
# ten such arrays, so blocks of 2^21 entries (16 MB each) bound its memory. The blocks
# are the same with and without workers: the same arithmetic, the same result.
_BLOCK_ENTRIES = 1 << 21
# workers=None starts processes for solves of at least this many (unknown, cage vertex)
# pairs: about a second of work in one process, against about 0.2 s to start each.
_PAIRS_PER_WORKER = 1 << 21
_MAX_ITERATIONS = 200
_CHECKED_COLUMNS = 16  # an elimination's residual is measured on about this many columns
_levels_cache = {}  # a worker's hierarchy, built once per solve
_STEPS = np.array(STEPS)
# Inside nodes nearer the cage than this fraction of a cell are Dirichlet nodes (their
# nearest boundary point's hat values place them to within it), so every crossing an
# unknown's grid edge meets is at least this far and each row's weight 1 / theta is
# bounded (conditioning). A crossing nearer still (rounding) counts as this far.
NEAREST_CROSSING = 1e-2


def boundary_rhs(inside, grid, vertices, triangles, node_ids, hat_columns, hat_values):
    """The right-hand side and the diagonal of the Shortley-Weller system.

    An inside node i whose neighbour along a grid direction is not inside sees the cage
    at the first crossing of the grid edge between them, a fraction theta of the cell
    from i: the stencil weighs that direction 1 / theta (on the diagonal) and puts
    1 / theta times the crossing's hat values on the right-hand side. Every row's
    equation, ``sum over directions of (u_i - u_other) / theta = 0`` (theta 1 towards
    inside neighbours), holds exactly for every linear function whose boundary values
    are its values at the crossings: the solved nodes reproduce their positions. The
    matrix stays symmetric (the unknowns' couplings are -1, as before) and an M-matrix.

    Parameters
    ----------
    inside : (x, y, z) bool
        The unknowns (row order: ``np.argwhere(inside)``).
    grid : Grid
    vertices : (n, 3) float
    triangles : (m, w) int
        Triangles (w = 3) or polygons (w = 4: :mod:`.boundary_values`).
    node_ids, hat_columns, hat_values
        Each Dirichlet node's row (-1 where none) in its nearest boundary point's hat
        values (b, w): used, with theta 1, where the edge to it does not cross the cage
        (an inside Dirichlet node, on the cage to within ``NEAREST_CROSSING``).

    Returns
    -------
    rhs : ((t,) int rows, (t,) int columns, (t,) float values)
    diagonal : (u,) float
        6 for a node whose neighbours are all inside; more where the cage is near.
    """
    nodes = np.argwhere(inside)
    padded_inside = np.pad(inside, 1)
    rows, directions = [], []
    for index, step in enumerate(_STEPS):
        boundary = np.flatnonzero(~padded_inside[tuple((nodes + 1 + step).T)])
        rows.append(boundary)
        directions.append(np.full(len(boundary), index))
    rows, directions = np.concatenate(rows), np.concatenate(directions)
    steps = _STEPS[directions]
    starts = node_positions(grid, nodes[rows])
    fraction, columns, values = segment_crossings(starts, steps * grid.spacing, vertices, triangles)
    found = np.isfinite(fraction)
    if not found.all():  # rounding at an edge or a vertex: the neighbour's own hat values
        neighbour = node_ids[tuple((nodes[rows[~found]] + steps[~found]).T)]
        if (neighbour < 0).any():
            raise RuntimeError("an inside node's neighbour has no boundary value")
        columns[~found], values[~found] = hat_columns[neighbour], hat_values[neighbour]
    weight = 1.0 / np.where(found, np.maximum(fraction, NEAREST_CROSSING), 1.0)
    diagonal = np.full(len(nodes), 6.0)
    np.add.at(diagonal, rows, weight - 1.0)
    return (np.repeat(rows, columns.shape[1]), columns.reshape(-1), (weight[:, None] * values).reshape(-1)), diagonal


def worker_count(workers, unknowns, column_count):
    """Processes a solve of ``unknowns`` x ``column_count`` uses: ``workers``, or for None
    one per ``_PAIRS_PER_WORKER`` pairs up to the cores (1 where no Python can start)."""
    if workers is not None:
        return min(workers, column_count)
    wanted = max(1, min(available_cores(), unknowns * column_count // _PAIRS_PER_WORKER, column_count))
    if wanted > 1:
        try:
            python_executable()
        except WorkerError:
            return 1
    return wanted


def _block_size(count, column_count):
    return int(max(1, min(column_count, _BLOCK_ENTRIES // (count + 1))))


def _solve_block(levels, rhs, start, stop, tolerance, progress=None):
    """Columns ``start:stop``: ((stop - start, u) solution, residual history)."""
    rows, columns, values = rhs
    chosen = (columns >= start) & (columns < stop)
    right = np.zeros((levels[0].count + 1, stop - start))
    np.add.at(right, (rows[chosen], columns[chosen] - start), values[chosen])
    solution, history = solve(levels, right, tolerance, progress, _MAX_ITERATIONS)
    return solution[:-1].T, history


def solve_columns_task(arrays, job, start, stop):
    """A worker's share (:func:`gencoords.evaluation.parallel.serve`): columns
    ``start:stop`` into ``arrays["result"]`` (n, u) and ``arrays["history"]``."""
    if job["key"] not in _levels_cache:
        _levels_cache.clear()
        _levels_cache[job["key"]] = build_levels(arrays["inside"].astype(bool), arrays["diagonal"])
    levels = _levels_cache[job["key"]]
    rhs = (arrays["rows"], arrays["columns"], arrays["values"])
    for begin in range(start, stop, job["block"]):
        end = min(begin + job["block"], stop)
        arrays["result"][begin:end], history = _solve_block(levels, rhs, begin, end, job["tolerance"])
        arrays["history"][begin // job["block"], :len(history)] = history


def _solve_in_workers(vertices, faces, inside, rhs, column_count, count, block, tolerance, workers, progress):
    """The columns spread over ``workers`` processes: ((n, u) solution, history)."""
    rhs, diagonal = rhs
    blocks = -(-column_count // block)
    specs = {"inside": (inside.shape, np.uint8), "rows": (rhs[0].shape, np.int64),
             "columns": (rhs[1].shape, np.int64), "values": (rhs[2].shape, np.float64),
             "history": ((blocks, _MAX_ITERATIONS + 2), np.float64), "locations": ((column_count,), np.int8),
             "result": ((column_count, count), np.float64), "diagonal": (diagonal.shape, np.float64)}
    shared = SharedArrays(specs)
    for name, value in (("inside", inside), ("rows", rhs[0]), ("columns", rhs[1]), ("values", rhs[2]),
                        ("diagonal", diagonal)):
        shared.arrays[name][...] = value
    shared.arrays["history"][...] = np.nan
    job = dict(task="harmonic.solve:solve_columns_task", key=secrets.token_hex(8), block=block, tolerance=tolerance)
    pool = WorkerPool(vertices, faces, workers)
    try:
        report = None if progress is None else (lambda done: progress(done / column_count))
        pool.run(shared, job, dispatch_units(column_count, block, workers), report)
    finally:
        pool.close()
    histories = [row[~np.isnan(row)].tolist() for row in shared.arrays["history"]]
    return shared.arrays["result"], max(histories, key=len)


def solve_nodes(inside, rhs, cage, tolerance=SOLVER_TOLERANCE, progress=None, workers=None, method=None):
    """Harmonic coordinates of the inside nodes.

    Parameters
    ----------
    inside : (x, y, z) bool
        The unknowns.
    rhs : ((rows, columns, values), diagonal)
        From :func:`boundary_rhs`.
    cage : (vertices (n, 3), faces (m, 3))
        The cage (its n columns; the workers are started with it).
    tolerance : float
        Relative residual per column (the iterative solver's; elimination is exact).
    progress : callable, optional
        ``progress(fraction)`` as the solve advances; an exception from it stops the
        solve (and the workers).
    workers : int or None
        Processes for the iterative solver (:func:`worker_count`); the columns are solved
        in the same blocks whatever the number, so the result is the same. Elimination
        runs here (its matrix products use the cores already).
    method : str or None
        ``"elimination"`` (:mod:`.elimination`: direct, by slabs), ``"multigrid"``
        (:mod:`.multigrid`: conjugate gradients), or None: elimination wherever it is the
        cheaper (:func:`.elimination.elimination_plan`: a body and limbs; not a fine grid
        in a volumetric cage).

    Returns
    -------
    coordinates : (u, n) float
        Non-negative, rows summing to 1.
    history : list of float
        The largest relative residual after each conjugate-gradient iteration, of the
        block that needed most (elimination: 1 and the residual it leaves).
    """
    rows, order, history = solved_rows(inside, rhs, cage, tolerance, progress, workers, method)
    coordinates = np.empty_like(rows)
    coordinates[order] = rows
    return coordinates, history


def solved_rows(inside, rhs, cage, tolerance=SOLVER_TOLERANCE, progress=None, workers=None, method=None):
    """:func:`solve_nodes`'s solution, its rows in the order the solver leaves them (slab
    elimination: slab by slab), with no copy in the unknowns' order beside (the cup: 25 MB).

    Returns
    -------
    rows : (u, n) float
        Non-negative, rows summing to 1.
    order : (u,) int
        ``rows[j]`` is the coordinates of unknown ``order[j]`` (``np.argwhere(inside)`` order).
    history : list of float
        As :func:`solve_nodes`'.
    """
    rhs, diagonal = rhs
    column_count = len(cage[0])
    if method not in (None, "elimination", "multigrid"):
        raise ValueError(f"method must be 'elimination', 'multigrid' or None, not {method!r}")
    if method is None:
        axis = elimination_plan(inside, column_count)
    else:
        axis = slab_axis(inside, column_count)[0] if method == "elimination" else None
    if axis is not None:
        return _eliminated(inside, rhs, diagonal, column_count, axis, progress)
    count = int(np.count_nonzero(inside))
    block = _block_size(count, column_count)
    chosen = worker_count(workers, count, column_count)
    if chosen > 1:
        try:
            result, history = _solve_in_workers(*cage, inside, (rhs, diagonal), column_count, count, block,
                                                tolerance, chosen, progress)
            # Out of the shared memory, normalised as a transpose, then in rows (C order).
            return np.ascontiguousarray(_normalised(np.array(result.T))), np.arange(count), history
        except WorkerError as error:
            if workers is not None:
                raise
            computed_here_instead(error)
    levels = build_levels(inside, diagonal)
    result, history = np.empty((count, column_count)), []
    for start in range(0, column_count, block):
        stop = min(start + block, column_count)
        report = None if progress is None else (lambda f, a=start, b=stop: progress((a + f * (b - a)) / column_count))
        solution, reductions = _solve_block(levels, rhs, start, stop, tolerance, report)
        result[:, start:stop] = solution.T
        history = max(history, reductions, key=len)
    return _normalised(result), np.arange(count), history


def _eliminated(inside, rhs, diagonal, column_count, axis, progress):
    """:func:`solved_rows` by slab elimination: (u, n) coordinates in slab order, that
    order, and [1, relative residual]. The right-hand side is assembled in slab order and
    solved in place (memory: one (u, n) array)."""
    rows, columns, values = rhs
    count = int(np.count_nonzero(inside))
    layout = slab_layout(inside, axis)
    position = np.empty(count, dtype=np.int64)
    position[layout.order] = np.arange(count)
    solution = np.zeros((count, column_count))
    np.add.at(solution, (position[rows], columns), values)
    # The residual it leaves, checked on a few columns (rounding: about 1e-15).
    checked = np.arange(0, column_count, max(1, column_count // _CHECKED_COLUMNS))
    right = np.zeros((count + 1, len(checked)))
    right[layout.order] = solution[:, checked]
    solve_in_slab_order(layout, diagonal, solution, progress)
    found = np.zeros_like(right)
    found[layout.order] = solution[:, checked]
    residual = apply_matrix(level_of(inside, diagonal=diagonal), found) - right
    norms = np.linalg.norm(right, axis=0)
    relative = np.linalg.norm(residual, axis=0) / np.where(norms > 0, norms, 1.0)
    return _normalised(solution), layout.order, [1.0, float(relative.max(initial=0.0))]


def _normalised(result):
    """Clipped at 0 (solver rounding) and rows renormalised to sum 1, in place."""
    np.maximum(result, 0.0, out=result)
    result /= result.sum(axis=1, keepdims=True)
    return result
