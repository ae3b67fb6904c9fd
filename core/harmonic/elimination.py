"""A direct solver for the masked grid's Laplacian: block elimination over slabs.

The unknowns are ordered slab by slab along one grid axis. A 7-point stencil couples a
slab only to itself and its two neighbours, so the matrix is block tridiagonal and
Gaussian elimination of the blocks in turn,
``S_i = A_ii - B_i S_(i-1)^-1 B_i^T`` (the Schur complements, symmetric positive definite
as the matrix is), leaves dense blocks no larger than a slab. For the cages artists build
(a body and limbs: slabs of a few hundred unknowns) this costs a few hundredths of what an
iterative solver needs for every cage vertex's column, and it is exact to rounding. Its
cost grows with the slabs' sizes cubed, so a volumetric cage at a fine grid goes to the
multigrid solver instead (:func:`elimination_plan` says which is cheaper).

The matrix is ``diag(diagonal) - adjacency`` over the unknowns (:mod:`.multigrid`'s, with
the Shortley-Weller diagonal of :func:`.solve.boundary_rhs`); couplings between slabs are
-1 between a node and the one beside it along the axis, so ``B_i`` only selects.
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["SlabLayout", "slab_axis", "elimination_plan", "slab_layout", "solve_in_slab_order", "solve_by_slabs"]

# What the iterative solve costs per (unknown, column) pair, in the floating-point
# operations elimination's matrix products do in the same time (they run at about 40
# GFLOP/s here): 0.76 us a pair on a sphere's grid, 1.1 us on the character's thin limbs,
# so 30,000 to 45,000. Elimination is chosen where its own count is lower than this
# many a pair: its large slabs also cost gathers beyond their operations (a 162-vertex
# sphere cage at 48 cells: its whole field took 10 s by elimination against 6.4 s).
MULTIGRID_FLOPS_PER_PAIR = 20_000
# The Schur complements' inverses (as many bytes as they would take kept whole): no more.
MAX_INVERSE_BYTES = 1 << 30
# The 4 in-slab neighbours (axes 1 and 2 of the slab-major grid).
_IN_SLAB = np.array([(0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)])


def slab_axis(inside, column_count):
    """The axis whose slabs eliminate in the fewest operations, those operations and the
    bytes of the blocks kept.

    Parameters
    ----------
    inside : (x, y, z) bool
        The unknowns.
    column_count : int
        Right-hand sides (cage vertices).

    Returns
    -------
    axis : int
    flops : float
    block_bytes : float
    """
    costs = []
    for axis in range(3):
        sizes = np.moveaxis(inside, axis, 0).reshape(inside.shape[axis], -1).sum(axis=1).astype(np.float64)
        # Inverting each block, and two products of it with the columns (forward, back).
        flops = 2.0 * np.sum(sizes ** 3) + 4.0 * np.sum(sizes ** 2) * column_count
        costs.append((flops, axis, 8.0 * np.sum(sizes ** 2)))
    flops, axis, block_bytes = min(costs)
    return axis, flops, block_bytes


def elimination_plan(inside, column_count):
    """The axis to eliminate along (:func:`slab_axis`), or None where the multigrid
    solver is cheaper or the blocks would not fit in ``MAX_INVERSE_BYTES``."""
    axis, flops, block_bytes = slab_axis(inside, column_count)
    iterative = MULTIGRID_FLOPS_PER_PAIR * float(np.count_nonzero(inside)) * column_count
    return axis if flops < iterative and block_bytes <= MAX_INVERSE_BYTES else None


@dataclass
class SlabLayout:
    """The unknowns in slabs along one axis (:func:`slab_layout`).

    Attributes
    ----------
    order : (u,) int
        The unknowns (rows of the matrix, ``np.argwhere(inside)`` order) in slab order.
    bounds : (s + 1,) int
        Slab i holds ``order[bounds[i]:bounds[i + 1]]``.
    links : list of ((l,) int, (l,) int)
        Per slab, its unknowns beside one in the slab before (indices within the slab)
        and those (indices within the slab before): ``B_i``'s -1 entries.
    beside : list of 4 (u,) int
        Each unknown's in-slab neighbour (slab-order position, -1: none), per direction.
    """

    order: np.ndarray
    bounds: np.ndarray
    links: list
    beside: list


def slab_layout(inside, axis):
    """The unknowns ``inside`` ((x, y, z) bool) ordered in slabs along ``axis``: a
    :class:`SlabLayout`."""
    count = int(np.count_nonzero(inside))
    ids = np.full(inside.shape, -1, dtype=np.int64)
    ids[inside] = np.arange(count)
    slab_major = np.moveaxis(inside, axis, 0)
    order = np.moveaxis(ids, axis, 0)[slab_major]
    nodes = np.argwhere(slab_major)
    position = np.full(slab_major.shape, -1, dtype=np.int64)
    position[slab_major] = np.arange(count)
    padded = np.pad(position, 1, constant_values=-1)
    bounds = np.searchsorted(nodes[:, 0], np.arange(slab_major.shape[0] + 1))
    below = padded[tuple((nodes + 1 - np.array([1, 0, 0])).T)]
    links = []
    for i in range(len(bounds) - 1):
        here = np.flatnonzero(below[bounds[i]:bounds[i + 1]] >= 0)
        links.append((here, below[bounds[i]:bounds[i + 1]][here] - (bounds[i - 1] if i else 0)))
    return SlabLayout(order, bounds, links, [padded[tuple((nodes + 1 + step).T)] for step in _IN_SLAB])


def solve_in_slab_order(layout, diagonal, values, progress=None):
    """Solve ``A x = values`` in place by eliminating the slabs in turn.

    Each slab's Schur complement is inverted and applied to the right-hand side as it is
    formed (forward), and only the columns of its inverse that the next slab couples to
    are kept for the way back: the inverses whole (the cup at 96 cells: 596 MB) are
    never held at once.

    Parameters
    ----------
    layout : SlabLayout
    diagonal : (u,) float or None
        The matrix's diagonal, in the unknowns' order (None: 6).
    values : (u, c) float64
        The right-hand side, rows in slab order (``rhs[layout.order]``); overwritten
        with the solution (slab order).
    progress : callable, optional
        ``progress(fraction)`` after each slab, both ways.

    Returns
    -------
    values : (u, c) float64
    """
    bounds, links = layout.bounds, layout.links
    slabs, count = len(bounds) - 1, len(layout.order)
    own = np.full(count, 6.0) if diagonal is None else np.asarray(diagonal, dtype=np.float64)[layout.order]
    sizes = np.diff(bounds).astype(np.int64)
    widths = np.array([len(links[i + 1][0]) for i in range(slabs - 1)] + [0], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes * widths)])
    work = np.cumsum(sizes.astype(np.float64) ** 3)
    # The kept columns in one block, each slab's matrix in one scratch block: a new
    # array a slab kept (the cup: 51, up to 3 MB each) left freed blocks between them.
    kept, scratch = np.empty(int(offsets[-1])), np.empty(int(sizes.max(initial=0)) ** 2)
    backward = []
    for i in range(slabs):  # values become S_i^-1 of the eliminated right-hand side
        start, stop, size = bounds[i], bounds[i + 1], sizes[i]
        here, before = links[i]
        block = scratch[:size * size].reshape(size, size)
        block[:] = 0.0
        block[np.arange(size), np.arange(size)] = own[start:stop]
        for neighbour in layout.beside:
            rows = np.flatnonzero(neighbour[start:stop] >= 0)
            block[rows, neighbour[start:stop][rows] - start] = -1.0
        if len(here):  # S_i = A_ii - B_i S_(i-1)^-1 B_i^T (rows of the columns kept), and -B_i w_(i-1)
            block[np.ix_(here, here)] -= backward[i - 1][before]
            values[start + here] += values[bounds[i - 1] + before]
        inverse = np.linalg.inv(block) if size else np.zeros((0, 0))
        values[start:stop] = inverse @ values[start:stop]
        if i + 1 < slabs:  # S_i^-1 B_(i+1)^T: what the next slab and the way back read
            backward.append(kept[offsets[i]:offsets[i + 1]].reshape(size, widths[i]))
            np.take(inverse, links[i + 1][1], axis=1, out=backward[i])
        del inverse
        if progress is not None and work[-1] > 0:
            progress(0.9 * work[i] / work[-1])
    for i in range(slabs - 2, -1, -1):
        here = links[i + 1][0]
        if len(here):  # x_i = w_i - S_i^-1 B_(i+1)^T x_(i+1)
            values[bounds[i]:bounds[i + 1]] += backward[i] @ values[bounds[i + 1] + here]
        if progress is not None:
            progress(0.9 + 0.1 * (slabs - i) / slabs)
    return values


def solve_by_slabs(inside, diagonal, axis, rhs):
    """``A^-1 rhs`` by slab elimination along ``axis``, for (u, c) ``rhs`` whose rows
    are the unknowns ``inside`` ((x, y, z) bool) in ``np.argwhere`` order: (u, c) float64,
    in that order. ``diagonal`` as :func:`solve_in_slab_order`'s."""
    layout = slab_layout(inside, axis)
    solution = solve_in_slab_order(layout, diagonal, np.asarray(rhs, dtype=np.float64)[layout.order])
    result = np.empty_like(solution)
    result[layout.order] = solution
    return result
