"""Using bound coordinates: deformed positions (field colours and summaries: ``gencoords.reports``)."""

import numpy as np

from ..base.inputs import checked

__all__ = ["deform"]


@checked
def deform(coordinates, cage_positions, out=None):
    """Deformed positions: each point is its coordinates times the cage's positions.

    Parameters
    ----------
    coordinates : (k, n) float32 or float64
        Coordinates of k points with respect to the n cage vertices (rows sum to 1).
    cage_positions : (n, N) float
        Current cage vertex positions.
    out : (k, N) ndarray, optional
        Written in place when given (float32 is fine: Blender stores float32).

    Returns
    -------
    positions : (k, N) ndarray
        ``coordinates @ cage_positions``, in the dtype of ``coordinates`` (or ``out``).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> b = gencoords.coordinates([[0.5, 0.5]], square, edges)
    >>> print(gencoords.deform(b, 2.0 * square))  # the cage scaled by 2 moves the point with it
    [[1. 1.]]
    """
    coordinates = np.asarray(coordinates)
    cage = np.asarray(cage_positions, dtype=coordinates.dtype)
    if out is None:
        return coordinates @ cage
    if out.dtype == coordinates.dtype:
        return np.matmul(coordinates, cage, out=out)
    out[...] = coordinates @ cage
    return out


