"""Piecewise-linear interpolation on the grid: each point's cell, the 4 corner nodes of
the tetrahedron of the cell's Freudenthal (Kuhn) triangulation that holds it, and their
barycentric weights.

Each cube is cut into 6 tetrahedra along its diagonal from the lowest corner to the
highest, one per order of the point's three fractions; the same cut in every cell makes
the triangulation conforming, so the interpolation is continuous. It is exact for linear
functions, as trilinear interpolation is, with half the nodes per point: the deformer
gathers 4 node displacements per mesh vertex instead of 8 (docs/MATH.md).
"""

import numpy as np

__all__ = ["CORNERS", "CORNER_COUNT", "cell_of", "tetrahedron"]

# The corners of a cell as offsets from its lowest node, x slowest.
CORNERS = np.array([(a, b, c) for a in (0, 1) for b in (0, 1) for c in (0, 1)])
CORNER_COUNT = 4  # nodes per interpolated point


def cell_of(grid, points):
    """The cell holding each point: (k, 3) int, clipped to the grid's cells."""
    local = (points - grid.origin) / grid.spacing
    return np.floor(local).astype(np.int64).clip(0, np.array(grid.cells) - 1)


def tetrahedron(grid, points):
    """Each point's tetrahedron corners and barycentric weights.

    With the point's fractions in its cell sorted, ``f_a >= f_b >= f_c``, the
    tetrahedron's corners are the cell's lowest node, one step along a, then along b,
    then the highest node, weighted ``1 - f_a, f_a - f_b, f_b - f_c, f_c``.

    Parameters
    ----------
    grid : Grid
    points : (k, 3) float
        Inside the grid.

    Returns
    -------
    corners : (k, 4, 3) int
        Grid indices of the corners.
    weights : (k, 4) float
        Non-negative, each row summing to 1; ``sum weights * corner positions`` is the
        point.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> from gencoords.harmonic.interpolation import tetrahedron
    >>> grid = SimpleNamespace(origin=np.zeros(3), spacing=1.0, cells=(4, 4, 4))
    >>> corners, weights = tetrahedron(grid, np.array([[1.5, 1.2, 1.7]]))
    >>> corners[0].tolist(), weights.round(3).tolist()
    ([[1, 1, 1], [1, 1, 2], [2, 1, 2], [2, 2, 2]], [[0.3, 0.2, 0.3, 0.2]])
    """
    cell = cell_of(grid, points)
    fraction = ((points - grid.origin) / grid.spacing - cell).clip(0.0, 1.0)
    order = np.argsort(-fraction, axis=1, kind="stable")
    sorted_fraction = np.take_along_axis(fraction, order, axis=1)
    weights = -np.diff(np.column_stack([np.ones(len(points)), sorted_fraction, np.zeros(len(points))]), axis=1)
    steps = np.eye(3, dtype=np.int64)[order]  # (k, 3, 3): the unit step along a, b, c
    offsets = np.concatenate([np.zeros((len(points), 1, 3), dtype=np.int64), np.cumsum(steps, axis=1)], axis=1)
    return cell[:, None, :] + offsets, weights
