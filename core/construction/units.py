"""World units of the frame's raw values (weights, ridge scalars, Floater scalars).

Every formula runs in the cage's frame, where lengths are world lengths divided by
``cage.scale``, a power of two (:class:`~gencoords.construction.general.PreparedCage`). Coordinates are
ratios and need nothing; the raw values the public functions also return are
homogeneous in length, of a known degree, so the world value is the frame's times
``scale ** degree``: for the same ridge scalars d the general construction's weights
have degree -1 (``u = r . m / det E``, with ``m`` of degree N-1 and ``det E`` of N), and
for the same Floater scalars c Floater's weights have degree -N. A named surface's d
has a degree of its own (mean value 0, discrete harmonic and Voronoi N-1, Wachspress
1-N), measured by :func:`length_degree`.
"""

from functools import lru_cache
from itertools import combinations

import numpy as np

from ..base import tolerances
from ..surfaces.named import named_ridge_scalars
from .general import point_frame, prepare_cage

__all__ = ["to_world", "length_degree"]


def to_world(values, scale, degree, what):
    """``values * scale ** degree``, refusing results that overflow or underflow float64.

    Parameters
    ----------
    values : ndarray
        Frame values.
    scale : float
        ``cage.scale`` (a power of two: exact).
    degree : float
        Length degree of the values.
    what : str
        Named in the error message.

    Returns
    -------
    values : ndarray float64
    """
    exponent = np.frexp(scale)[1] - 1  # scale == 2 ** exponent
    power = degree * exponent
    with np.errstate(over="ignore", under="ignore"):
        world = np.ldexp(values, int(power)) if float(power).is_integer() else values * 2.0 ** power
    lost = (np.isinf(world) & np.isfinite(values)) | ((world == 0.0) & (values != 0.0))
    if lost.any():
        raise ValueError(f"{what} overflow or underflow float64 at this cage's scale (its size is "
                         f"about 2^{exponent}; they scale as size^{degree:g}); coordinates are "
                         "scale-free, or scale the cage and points")
    return world


@lru_cache(maxsize=None)
def length_degree(kind, dimension, gamma=None):
    """The degree in length of the named surface ``kind``'s ridge scalars d in R^dimension
    (``gamma``: the power family's parameter).

    Measured: d of a simplex around its centroid, at unit size and at size 2 (exact powers
    of two), so any homogeneous surface, whatever its formula, is converted right.
    """
    simplex = np.vstack([np.zeros(dimension), np.eye(dimension)])
    facets = np.array(list(combinations(range(dimension + 1), dimension)))
    centre = simplex.mean(axis=0)[None]
    values = [np.abs(named_ridge_scalars(kind, point_frame(prepare_cage(simplex, facets, scale=s),
                                                           centre), gamma)).max()
              for s in (1.0, 0.5)]  # the simplex at sizes 1 and 2
    degree = float(np.log2(values[1] / values[0]))
    return round(degree) if abs(degree - round(degree)) < tolerances.INTEGER_DEGREE else degree
