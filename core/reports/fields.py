"""Coordinate fields shown and summarised: colours (:func:`field_colors`, over
:func:`field_range`), a bind's summary of negative coordinates
(:func:`coordinate_summary`) and how far coordinates place their points
(:func:`linear_precision`)."""

import numpy as np

from ..base import tolerances
from ..base.inputs import checked

__all__ = ["field_colors", "field_range", "coordinate_summary", "linear_precision"]

# Viridis (matplotlib's perceptually uniform colour map: its lightness rises evenly, so
# the field reads the same in grey and to colour-blind eyes), sRGB, sampled at 17 evenly
# spaced points of 0..1; linear interpolation between them keeps the lightness monotonic.
VIRIDIS_SRGB = np.array([
    (0.2670, 0.0049, 0.3294), (0.2823, 0.0950, 0.4173), (0.2788, 0.1755, 0.4834),
    (0.2590, 0.2515, 0.5247), (0.2297, 0.3224, 0.5457), (0.1994, 0.3876, 0.5546),
    (0.1727, 0.4488, 0.5579), (0.1490, 0.5081, 0.5573), (0.1276, 0.5669, 0.5506),
    (0.1206, 0.6258, 0.5335), (0.1579, 0.6838, 0.5017), (0.2461, 0.7389, 0.4520),
    (0.3692, 0.7889, 0.3829), (0.5160, 0.8312, 0.2943), (0.6785, 0.8637, 0.1895),
    (0.8456, 0.8873, 0.0997), (0.9932, 0.9062, 0.1439)])
# Negative coordinates get a ramp of their own, from light pink just below zero to deep
# magenta-red at the field's most negative value: no colour of it is near viridis, so
# where a coordinate type goes negative shows at a glance.
NEGATIVE_SRGB = np.array([(0.99, 0.75, 0.84), (0.93, 0.36, 0.55), (0.70, 0.02, 0.22)])


@checked
def field_range(values):
    """The values ``field_colors`` scales to: ``(lowest, highest)``, 0 included.

    Values above ``-tolerances.NEGATIVE`` count as zero (round-off, not a negative
    coordinate), as in ``coordinate_summary``.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> lower, upper = gencoords.reports.field_range(np.array([0.0, 0.5, 1.0]))
    >>> print(lower, upper)
    0.0 1.0
    """
    values = np.asarray(values, dtype=np.float64)
    lowest = values.min(initial=0.0)
    return (lowest if lowest < -tolerances.NEGATIVE else 0.0), values.max(initial=0.0)


@checked
def field_colors(values):
    """Colours of one coordinate field: viridis for 0 to its maximum, a separate pink to
    red ramp for negative values.

    0 is dark purple and the field's largest value yellow; negative values run from light
    pink (just below 0) to deep red (the field's most negative value). ``field_range``
    gives the two ends, for a legend.

    Parameters
    ----------
    values : (k,) float
        One coordinate per point (a column of the coordinate matrix).

    Returns
    -------
    colors : (k, 4) float32
        Linear RGBA (what Blender's colour attributes hold), alpha 1.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> colors = gencoords.reports.field_colors(np.array([0.0, 0.5, 1.0]))
    >>> colors.shape  # RGBA per value
    (3, 4)
    """
    values = np.asarray(values, dtype=np.float64)
    lowest, highest = field_range(values)
    positive = np.clip(values / highest, 0.0, 1.0) if highest > 0.0 else np.zeros_like(values)
    srgb = _ramp(VIRIDIS_SRGB, positive)
    negative = values < -tolerances.NEGATIVE
    if negative.any():
        srgb[negative] = _ramp(NEGATIVE_SRGB, values[negative] / lowest)
    colors = np.empty((len(values), 4), dtype=np.float32)
    colors[:, :3] = _srgb_to_linear(srgb)
    colors[:, 3] = 1.0
    return colors


def _ramp(table, t):
    """Colours at ``t`` in [0, 1] interpolated linearly between the rows of ``table``."""
    position = np.clip(t, 0.0, 1.0) * (len(table) - 1)
    below = np.minimum(position.astype(np.int64), len(table) - 2)
    fraction = (position - below)[:, None]
    return (1.0 - fraction) * table[below] + fraction * table[below + 1]


def _srgb_to_linear(srgb):
    """The sRGB transfer function inverted (IEC 61966-2-1)."""
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


@checked
def linear_precision(coordinates, vertices, points):
    """How far the coordinates place their points: the worst ``|sum_j b_j v_j - x|``
    with the cage's middle as origin, relative to the cage's size (its bounding-box
    diagonal).

    Parameters
    ----------
    coordinates : (k, n) float
        One row per point, e.g. as stored (float32) and read back.
    vertices : (n, N) float
    points : (k, N) float

    Returns
    -------
    error : float
        0 for no points; compare with ``tolerances.LINEAR_PRECISION``.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> b = np.array([[0.25, 0.25, 0.25, 0.25]])
    >>> gencoords.reports.linear_precision(b, square, [[0.5, 0.5]]), gencoords.reports.linear_precision(b, square, [[0.5, 0.6]]) > 0.07
    (0.0, True)
    """
    if coordinates.shape != (len(points), len(vertices)):
        raise ValueError(f"coordinates must have shape (k, n) = ({len(points)}, {len(vertices)}) for "
                         f"{len(points)} points and {len(vertices)} cage vertices, got {coordinates.shape}")
    vertices = np.asarray(vertices, dtype=np.float64)
    # About the cage's middle: a cage far from the origin does not make coordinates that
    # sum to 1 within rounding look imprecise (deformations use differences only).
    middle = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    placed = np.asarray(coordinates, dtype=np.float64) @ (vertices - middle)
    error = np.abs(placed - (np.asarray(points, dtype=np.float64) - middle)).max(initial=0.0)
    return float(error) / size


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
        below ``-tolerances.NEGATIVE``), ``negative_entries`` (how many coordinates are),
        ``max_affine_error`` (largest ``|row sum - 1|``) and ``nbytes`` (memory of the
        matrix).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> b = gencoords.coordinates([[0.5, 0.5], [0.25, 0.5]], square, edges)
    >>> summary = gencoords.reports.coordinate_summary(b)
    >>> summary["min"], summary["negative_points"]
    (0.125, 0)
    """
    coordinates = np.asarray(coordinates)
    if coordinates.size == 0:
        return {"min": 0.0, "negative_points": 0, "negative_entries": 0, "max_affine_error": 0.0, "nbytes": 0}
    row_min = coordinates.min(axis=1)
    return {
        "min": float(row_min.min()),
        "negative_points": int(np.count_nonzero(row_min < -tolerances.NEGATIVE)),
        "negative_entries": int(np.count_nonzero(coordinates < -tolerances.NEGATIVE)),
        "max_affine_error": float(np.abs(coordinates.sum(axis=1, dtype=np.float64) - 1.0).max()),
        "nbytes": int(coordinates.nbytes),
    }
