"""Using bound coordinates: deformed positions, field colours and a bind summary."""

import numpy as np

from . import tolerances
from .inputs import checked

__all__ = ["deform", "field_colors", "coordinate_summary"]


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
    """
    coordinates = np.asarray(coordinates)
    cage = np.asarray(cage_positions, dtype=coordinates.dtype)
    if out is None:
        return coordinates @ cage
    if out.dtype == coordinates.dtype:
        return np.matmul(coordinates, cage, out=out)
    out[...] = coordinates @ cage
    return out


@checked
def field_colors(values):
    """Paper-style grey scale of one coordinate field (figures 9 to 11).

    Larger values are lighter, scaled to the field's maximum; negative values are black,
    so a field that stays positive never shows pure black.

    Parameters
    ----------
    values : (k,) float
        One coordinate per point (a column of the coordinate matrix).

    Returns
    -------
    colors : (k, 4) float32
        Linear RGBA in [0, 1], alpha 1.
    """
    values = np.asarray(values, dtype=np.float64)
    top = values.max(initial=0.0)
    scale = 1.0 / top if top > 0.0 else 0.0
    grey = np.where(values < 0.0, 0.0, 0.08 + 0.92 * np.clip(values * scale, 0.0, 1.0))
    colors = np.empty((len(values), 4), dtype=np.float32)
    colors[:, :3] = grey[:, None]
    colors[:, 3] = 1.0
    return colors


@checked
def coordinate_summary(coordinates):
    """Figures an artist checks after binding.

    Parameters
    ----------
    coordinates : (k, n) float

    Returns
    -------
    summary : dict
        ``min`` (smallest coordinate), ``negative_points`` (points with any coordinate
        below ``-tolerances.NEGATIVE``), ``max_affine_error`` (largest ``|row sum - 1|``) and
        ``nbytes`` (memory of the matrix).
    """
    coordinates = np.asarray(coordinates)
    if coordinates.size == 0:
        return {"min": 0.0, "negative_points": 0, "max_affine_error": 0.0, "nbytes": 0}
    row_min = coordinates.min(axis=1)
    return {
        "min": float(row_min.min()),
        "negative_points": int(np.count_nonzero(row_min < -tolerances.NEGATIVE)),
        "max_affine_error": float(np.abs(coordinates.sum(axis=1, dtype=np.float64) - 1.0).max()),
        "nbytes": int(coordinates.nbytes),
    }
