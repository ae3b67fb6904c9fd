"""Arrays as the public functions accept them: real, finite, of a known shape
(:func:`real_array`), tolerances (:func:`check_tolerance`), the frame a cage's size
is measured in (:func:`bounding_frame`), and what the checks of one call learn
(:class:`_Context`: the cage's dimension, the points). Used by :mod:`.parameters`. And a
row-wise computation made a block of rows at a time (:func:`in_row_blocks`), and rows
taken without a copy where they are all (:func:`selected_rows`).
"""

import math
import numbers

import numpy as np

from . import tolerances
from .errors import CageError

__all__ = ["check_tolerance", "real_array", "bounding_frame", "in_row_blocks", "selected_rows"]


def _as_array(value, name):
    try:
        return np.asarray(value)
    except (ValueError, TypeError) as error:  # ragged nested lists, odd objects
        raise ValueError(f"{name} must be a rectangular array of numbers ({error})") from None


def real_array(value, name, keep_float32=False):
    """``value`` as a float64 array (float32 kept if asked), refusing what is not real.

    Complex values are refused rather than cast (numpy would drop the imaginary part),
    and so are booleans, strings and objects.
    """
    array = _as_array(value, name)
    if array.dtype.kind == "c":
        raise ValueError(f"{name} must be real numbers, got complex values ({array.dtype}); "
                         "pass the real part explicitly if that is what is meant")
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be real numbers (integer or float), got {array.dtype}")
    if keep_float32 and array.dtype == np.float32:
        return array
    return array.astype(np.float64, copy=False)


def _first_bad_row(array):
    """Index of the first row (or element) with a non-finite value, and their count."""
    bad = ~np.isfinite(np.atleast_1d(array)).all(axis=tuple(range(1, max(array.ndim, 1))))
    if not bad.any():
        return None, 0
    return int(np.flatnonzero(bad)[0]), int(np.count_nonzero(bad))


def _finite(array, name, unit="rows"):
    first, count = _first_bad_row(array)
    if first is not None:
        raise ValueError(f"{name} must be finite: {count} {unit} have NaN or infinite values "
                         f"(first: {first})")
    return array


def check_tolerance(tolerance):
    """A tolerance relative to the cage's size, as a float in (0, tolerances.LARGEST]."""
    accepted = (f"a number in (0, {tolerances.LARGEST:g}] relative to the cage's size "
                f"(default {tolerances.DEFAULT:g}; {tolerances.FLOAT32:g} for float32 data)")
    if isinstance(tolerance, (bool, np.bool_)) or not isinstance(tolerance, numbers.Real):
        raise ValueError(f"tolerance must be {accepted}, got {tolerance!r} ({type(tolerance).__name__})")
    value = float(tolerance)
    if not (math.isfinite(value) and 0.0 < value <= tolerances.LARGEST):
        # Zero lets rounding decide whether a point on a facet is "on" it (a pole); large
        # values take the boundary limit visibly off the boundary.
        raise ValueError(f"tolerance must be {accepted}, got {value!r}")
    return value


def _solver_tolerance(value):
    """A relative residual for the harmonic solve: a float in [1e-14, 1e-2]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not 1e-14 <= value <= 1e-2:
        raise ValueError(f"solver_tolerance must be a relative residual from 1e-14 to 1e-2, got {value!r}")
    return float(value)


def bounding_frame(vertices):
    """The frame every formula works in: the cage centred on its bounding box and
    divided by a power of two near its size (exact in binary: no rounding is added).

    Parameters
    ----------
    vertices : (n, N) float

    Returns
    -------
    origin : (N,) float
        Centre of the bounding box.
    scale : float
        A power of two; ``(vertices - origin) / scale`` has a diagonal in [1, 2).

    Raises
    ------
    CageError
        ``problem="scale"``: a diagonal below ``tolerances.SMALLEST_SIZE`` or one that
        overflows float64.
    """
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    origin = 0.5 * low + 0.5 * high  # halves first: no overflow near the float64 limit
    half = 0.5 * high - 0.5 * low
    largest = float(half.max())
    half_diagonal = largest * float(np.linalg.norm(half / largest)) if largest > 0.0 else 0.0
    if not (tolerances.SMALLEST_SIZE <= 2.0 * half_diagonal < np.finfo(np.float64).max):
        raise CageError("scale", f"the cage's bounding-box diagonal {2.0 * half_diagonal:.3g} is "
                                 f"outside the range float64 can compute with "
                                 f"({tolerances.SMALLEST_SIZE:.3g} to {np.finfo(np.float64).max:.3g}); "
                                 "scale the cage and the points")
    return origin, math.ldexp(1.0, math.frexp(half_diagonal)[1])


class _Context:
    """What the checks of one call learn about it (the cage's dimension, counts...)."""

    def __init__(self, function):
        self.function = function
        self.dimension = self.vertex_count = self.point_count = None
        self.vertices = self.faces = self.points = self.kind = None


def in_row_blocks(compute, rows, *arrays):
    """``compute(*arrays)`` (a tuple of arrays whose row i depends on the arrays' row i
    alone) made ``rows`` rows at a time and concatenated: what it holds beside its
    result is a block's (the pairs of a block of nodes, not all of them).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.base.arrays import in_row_blocks
    >>> in_row_blocks(lambda a, b: (a + b, a * b), 2, np.arange(5), np.ones(5))
    (array([1., 2., 3., 4., 5.]), array([0., 1., 2., 3., 4.]))
    """
    if len(arrays[0]) <= rows:
        return compute(*arrays)
    parts = [compute(*(array[start:start + rows] for array in arrays)) for start in range(0, len(arrays[0]), rows)]
    return tuple(np.concatenate(part) for part in zip(*parts))


def selected_rows(array, rows):
    """``array[rows]`` for increasing, distinct ``rows`` ((j,) int), or ``array`` itself,
    not a copy, where they are all of its rows."""
    return array if len(rows) == len(array) else array[rows]
