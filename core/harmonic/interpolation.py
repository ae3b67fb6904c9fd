"""Trilinear interpolation on the grid: each point's cell, its 8 corner nodes and their
weights."""

import numpy as np

__all__ = ["CORNERS", "cell_of", "trilinear"]

# The corners of a cell as offsets from its lowest node, x slowest.
CORNERS = np.array([(a, b, c) for a in (0, 1) for b in (0, 1) for c in (0, 1)])


def cell_of(grid, points):
    """The cell holding each point: (k, 3) int, clipped to the grid's cells."""
    local = (points - grid.origin) / grid.spacing
    return np.floor(local).astype(np.int64).clip(0, np.array(grid.cells) - 1)


def trilinear(grid, points):
    """Each point's cell corners and trilinear weights.

    Parameters
    ----------
    grid : Grid
    points : (k, 3) float
        Inside the grid.

    Returns
    -------
    corners : (k, 8, 3) int
        Grid indices of the corners, in :data:`CORNERS` order.
    weights : (k, 8) float
        Non-negative, each row summing to 1 (to rounding).
    """
    cell = cell_of(grid, points)
    fraction = ((points - grid.origin) / grid.spacing - cell).clip(0.0, 1.0)
    per_axis = np.where(CORNERS[None] == 1, fraction[:, None, :], 1.0 - fraction[:, None, :])
    return cell[:, None, :] + CORNERS[None], per_axis.prod(axis=2)
