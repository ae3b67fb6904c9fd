"""Trilinear interpolation on the grid: each point's cell, its 8 corner nodes and their
weights.

Trilinear interpolation is smooth inside each cell (a polynomial there) and continuous
across the cells' faces, and exact for linear functions. Piecewise-linear interpolation
of 4 nodes (the tetrahedron of the cell's Freudenthal triangulation holding the point)
is too, with half the nodes, but bends along the tetrahedra's faces inside each cell:
posed characters creased along the cells' diagonals where Mesh Deform, trilinear, did not
(issue 35; docs/MATH.md, "Points").
"""

import numpy as np

__all__ = ["CORNERS", "CORNER_COUNT", "cell_of", "trilinear"]

# The corners of a cell as offsets from its lowest node, x slowest.
CORNERS = np.array([(a, b, c) for a in (0, 1) for b in (0, 1) for c in (0, 1)])
CORNER_COUNT = len(CORNERS)  # nodes per interpolated point


def cell_of(grid, points):
    """The cell holding each point: (k, 3) int, clipped to the grid's cells."""
    local = (points - grid.origin) / grid.spacing
    return np.floor(local).astype(np.int64).clip(0, np.array(grid.cells) - 1)


def trilinear(grid, points):
    """Each point's cell corners and trilinear weights.

    With the point's fractions ``f`` in its cell, corner ``o`` (an offset of CORNERS)
    weighs ``prod over the axes of (f if o else 1 - f)``.

    Parameters
    ----------
    grid : Grid
    points : (k, 3) float
        Inside the grid.

    Returns
    -------
    corners : (k, 8, 3) int
        Grid indices of the corners, in the order of CORNERS.
    weights : (k, 8) float
        Non-negative, each row summing to 1; ``sum weights * corner positions`` is the
        point.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> from gencoords.harmonic.interpolation import trilinear
    >>> grid = SimpleNamespace(origin=np.zeros(3), spacing=1.0, cells=(4, 4, 4))
    >>> corners, weights = trilinear(grid, np.array([[1.5, 1.2, 1.75]]))
    >>> corners[0, [0, 7]].tolist(), weights.round(3).tolist()
    ([[1, 1, 1], [2, 2, 2]], [[0.1, 0.3, 0.025, 0.075, 0.1, 0.3, 0.025, 0.075]])
    """
    cell = cell_of(grid, points)
    fraction = ((points - grid.origin) / grid.spacing - cell).clip(0.0, 1.0)
    weights = np.prod(np.where(CORNERS[None] == 1, fraction[:, None, :], 1.0 - fraction[:, None, :]), axis=2)
    return cell[:, None, :] + CORNERS[None], weights
