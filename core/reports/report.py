"""How a kind of coordinates behaves in a given cage: positivity, well-definedness, precision.

The paper leaves open which generating surfaces give well-defined coordinates (a
vanishing sum of weights) and which stay positive; :func:`coordinate_report` measures
both on a deterministic sample of interior points, dense near the boundary where
coordinates go negative first.
"""

from dataclasses import dataclass

import numpy as np

from ..base import tolerances
from ..construction.boundary import INSIDE
from ..evaluation.cage import Cage
from .fields import linear_precision
from ..surfaces.named import KIND_TABLE, MEAN_VALUE, kind_parameter
from ..base.inputs import checked
from ..construction.validation import DEFAULT_TOLERANCE

__all__ = ["CoordinateReport", "coordinate_report", "interior_sample"]

# Points of the sample near each facet, at this fraction of the cage's size inside it.
_NEAR_BOUNDARY = tolerances.REPORT_NEAR_BOUNDARY


@dataclass(frozen=True)
class CoordinateReport:
    """What :func:`coordinate_report` found.

    Attributes
    ----------
    kind : str
    gamma : float or None
    points : int
        Points examined.
    smallest : float
        The smallest coordinate of any point.
    smallest_point : (N,) float
        Where it occurs, and ``smallest_vertex`` the cage vertex it belongs to.
    smallest_vertex : int
    negative_points : int
        Points with a coordinate below ``-tolerances.NEGATIVE``.
    smallest_weight_sum : float
        The smallest ``|sum of weights|`` relative to the largest ``|weight|`` of its
        point: near 0 the coordinates are ill-defined (a vanishing denominator).
    smallest_weight_sum_point : (N,) float
    linear_precision : float
        The worst ``|sum_i b_i v_i - x|``, relative to the cage's size.

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.cages.shapes import octahedron
    >>> report = gencoords.reports.coordinate_report(*octahedron(), "mean_value", samples=200)
    >>> report.kind, report.points, report.smallest >= 0.0
    ('mean_value', 200, True)
    """

    kind: str
    gamma: object
    points: int
    smallest: float
    smallest_point: np.ndarray
    smallest_vertex: int
    negative_points: int
    smallest_weight_sum: float
    smallest_weight_sum_point: np.ndarray
    linear_precision: float

    @property
    def positive(self):
        """Whether every coordinate examined is non-negative (to rounding): bool."""
        return self.negative_points == 0

    @property
    def headline(self):
        """One line for people, e.g. ``"Power (gamma -0.5): positive (smallest 2.2e-08); well
        defined; linear precision 3e-16"``."""
        label = next(kind.label for kind in KIND_TABLE if kind.name == self.kind)
        if self.gamma is not None:
            label += f" (gamma {self.gamma:g})"
        sign = (f"positive (smallest {self.smallest:.2g})" if self.positive else
                f"negative at {self.negative_points} of {self.points} points "
                f"(down to {self.smallest:.2g})")
        defined = ("well defined" if self.smallest_weight_sum > tolerances.WELL_DEFINED_WEIGHT_SUM else
                   f"nearly undefined somewhere (weight sum {self.smallest_weight_sum:.1g} of the weights)")
        return f"{label}: {sign}; {defined}; linear precision {self.linear_precision:.0e}"


def interior_sample(cage, count, seed=0):
    """A deterministic sample of points strictly inside a cage.

    Half uniform in the cage (rejection from its bounding box), half close to the
    boundary (random points of random facets, moved inward by 1e-3 of the size).

    Parameters
    ----------
    cage : Cage
    count : int
    seed : int

    Returns
    -------
    points : (j, N) float
        j <= count points, all inside.

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.construction.boundary import INSIDE
    >>> from gencoords.reports.report import interior_sample
    >>> from gencoords.cages.shapes import octahedron
    >>> with gencoords.Cage(*octahedron()) as cage:
    ...     points = interior_sample(cage, 100)
    ...     bool((cage.point_locations(points, workers=1) == INSIDE).all()), points.shape[1]
    (True, 3)
    """
    rng = np.random.default_rng(seed)
    vertices, faces = cage.vertices, cage.faces
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    uniform = rng.uniform(low, high, size=(4 * count, cage.dimension))
    facet = rng.integers(len(faces), size=count)
    mix = rng.dirichlet(np.ones(cage.dimension), size=count)
    on_facets = np.einsum("kN,kND->kD", mix, vertices[faces[facet]])
    inward = vertices.mean(axis=0) - on_facets
    inward /= np.linalg.norm(inward, axis=1, keepdims=True)
    near = on_facets + _NEAR_BOUNDARY * cage.size * inward
    chosen = []
    for candidates, wanted in ((uniform, count - count // 2), (near, count // 2)):
        inside = candidates[cage.point_locations(candidates, workers=1) == INSIDE]
        chosen.append(inside[:wanted])
    return np.concatenate(chosen)


@checked
def coordinate_report(vertices, faces, kind=MEAN_VALUE, gamma=None, points=None, samples=2000,
                      tolerance=DEFAULT_TOLERANCE):
    """Positivity, well-definedness and linear precision of a kind in a cage.

    Parameters
    ----------
    vertices : (n, N) float
    faces : (m, N) int
    kind : str
        One of :data:`gencoords.advanced.KINDS` (``gamma`` for ``"power"``).
    gamma : float, optional
    points : (k, N) float, optional
        Points examined besides the sample (those inside the cage).
    samples : int
        Size of the deterministic interior sample (:func:`interior_sample`).
    tolerance : float

    Returns
    -------
    CoordinateReport

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron()
    >>> report = gencoords.reports.coordinate_report(vertices, faces, "wachspress", samples=200)
    >>> report.positive
    True
    """
    with Cage(vertices, faces, tolerance) as cage:
        sample = interior_sample(cage, samples)
        if points is not None and len(points):
            sample = np.concatenate([sample, points[cage.point_locations(points) == INSIDE]])
        weights = cage.weights(sample, kind=kind, gamma=gamma, workers=1)
        sums = weights.sum(axis=1)
        relative_sum = np.abs(sums) / np.abs(weights).max(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            coordinates = weights / sums[:, None]
        flat = int(np.argmin(coordinates))
        row, vertex = divmod(flat, coordinates.shape[1])
        error = linear_precision(coordinates, cage.vertices, sample)
        return CoordinateReport(
            kind=kind, gamma=kind_parameter(kind, gamma), points=len(sample),
            smallest=float(coordinates[row, vertex]), smallest_point=sample[row],
            smallest_vertex=int(vertex),
            negative_points=int(np.count_nonzero((coordinates < -tolerances.NEGATIVE).any(axis=1))),
            smallest_weight_sum=float(relative_sum.min()),
            smallest_weight_sum_point=sample[int(np.argmin(relative_sum))],
            linear_precision=float(error))
