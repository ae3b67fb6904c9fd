"""Ridge scalars d of the named generating surfaces (docs/MATH.md table).

d, shape (r, k) (ridges by points, the frame's layout), is the signed (N-1)-volume
enclosed by x and the ridge projected onto the surface. Ridges have p = N-1 vertices;
everything comes from a :class:`~gencoords.construction.general.PointFrame`: the ridge's Gram matrix
of ``e = v - x`` and its generalized cross product, of norm ``|m_R|``.

Floater's form of the construction takes ``d |m_R|`` (N! times Floater's c) instead. Some
surfaces are simpler in that scaled form (the power duals' areas need neither the cross
product nor a square root), others in d: each is written in its natural form and
:func:`named_ridge_scalars` / :func:`named_scaled_ridge_scalars` convert.
"""

from dataclasses import dataclass
from itertools import combinations, permutations
from math import factorial

import numpy as np

from .numerical import unit_sphere_ridge_scalars

__all__ = ["Kind", "KIND_TABLE", "HARMONIC", "MEAN_VALUE_QUADS", "EVERY_KIND", "WACHSPRESS", "MEAN_VALUE", "DISCRETE_HARMONIC", "VORONOI", "POWER", "KINDS", "CONVEX_ONLY_KINDS",
           "named_ridge_scalars", "named_scaled_ridge_scalars",
           "kind_parameter", "mean_value", "discrete_harmonic_scaled", "wachspress_scaled",
           "voronoi_scaled", "power_scaled",
           "power_dual", "power_dual_scaled", "power_dual_by_subsets"]


def mean_value(frame):
    """Unit sphere: d = measure of the spherical (N-2)-simplex of the ridge / (N-1).

    2D: 1; 3D: a/2 with a the angle between the edge's two vectors; 4D: the solid angle
    (Van Oosterom and Strackee) / 3. Higher dimensions have no elementary closed form:
    a Gauss rule on the spherical simplex (``numerical_surfaces``, ~1e-6 relative).
    """
    gram, measure = frame.ridge_gram, frame.ridge_measure
    size = gram.shape[0]
    if size == 1:
        return np.ones_like(measure)
    if size == 2:
        return 0.5 * np.arctan2(measure, gram[0, 1])
    if size == 3:
        lengths = np.sqrt(frame.ridge_lengths_squared)
        denominator = (lengths[0] * lengths[1] * lengths[2]
                       + gram[0, 1] * lengths[2] + gram[0, 2] * lengths[1] + gram[1, 2] * lengths[0])
        return 2.0 * np.arctan2(measure, denominator) / 3.0
    # No elementary closed form above 4D: the spherical simplex measured numerically.
    return unit_sphere_ridge_scalars(gram, measure)


def discrete_harmonic_scaled(frame):
    """The polytope itself: d = (N-1)-volume of {x} + ridge = |m_R| / (N-1)!; scaled, |m_R|^2 / (N-1)!."""
    return frame.ridge_measure_squared / factorial(frame.ridge_size)


def wachspress_scaled(frame):
    """Polar dual: the power dual with heights 1 (scaled form)."""
    return power_dual_scaled(frame, 1.0)


def voronoi_scaled(frame):
    """Voronoi dual (circumcentres of {x} + facet): the power dual with heights |e|^2 / 2."""
    return power_dual_scaled(frame, 0.5 * frame.ridge_lengths_squared)


def power_scaled(frame, gamma):
    """The power family (scaled form): the power dual with heights ``l_k^(gamma+1)``.

    Its face dual to v_k is orthogonal to e_k at distance ``l_k^gamma`` from x: gamma = -1
    is Wachspress, gamma = 1 Voronoi, and in 2D (where d_k = l_k^gamma) gamma = 0 is
    mean value. Needs a convex cage; positive inside regular and irregular polytopes for
    gamma up to about 0 (measured: docs/POWER.md).
    """
    return power_dual_scaled(frame, frame.ridge_lengths_squared ** (0.5 * (gamma + 1.0)))


def power_dual(frame, heights):
    """d of a "power dual": the region cut by the hyperplanes p . e_k = h_k.

    For each subset S of the ridge's vertices, ``p_S`` is the point of span{e_k : k in S}
    with ``p_S . e_k = h_k`` (k in S). The enclosed region is a combinatorial cube; d sums
    the signed simplex volumes (x, p_{k1}, p_{k1 k2}, ..., p_ridge) over orderings.
    Heights 1 give Wachspress, |e|^2/2 Voronoi (|e|^(gamma+1) in general).

    Parameters
    ----------
    frame : PointFrame
    heights : (N-1, r, k) float, or a float for equal heights

    Returns
    -------
    d : (r, k) float
    """
    return power_dual_scaled(frame, heights) / frame.ridge_measure


def power_dual_scaled(frame, heights):
    """``d |m_R|`` of a power dual (see :func:`power_dual`): no square root needed."""
    gram = frame.ridge_gram
    size = gram.shape[0]
    if size == 2:  # the quadrilateral of the 3D table, in closed form, times |e_a x e_b|:
        # (h_a (l_a h_b - dot h_a) / l_a + h_b (l_b h_a - dot h_b) / l_b) / 2
        h_a, h_b = (heights, heights) if np.ndim(heights) == 0 else heights  # scalars stay scalar
        dot = gram[0, 1]
        return h_a * h_b - 0.5 * dot * (h_a * h_a / gram[0, 0] + h_b * h_b / gram[1, 1])
    heights = np.broadcast_to(heights, (size,) + gram.shape[2:])
    if size == 1:  # a segment of length h / |e|, times |e|
        return heights[0].copy()
    basis_volume = power_dual_by_subsets(np.moveaxis(gram, (0, 1), (-2, -1)), np.moveaxis(heights, 0, -1))
    return basis_volume * frame.ridge_measure_squared


def power_dual_by_subsets(gram, heights):
    """:func:`power_dual` for any ridge size, by explicit subsets and orderings.

    Points ``p_S`` are expressed in the ridge basis (coefficients ``a_S``, zero off S,
    ``gram[S, S] a_S = h_S``). Returns the enclosed volume measured in that basis: d is
    it times the basis volume ``|m_R|``. Used for N >= 4 and as an independent check in
    2D and 3D.

    Parameters
    ----------
    gram : (..., p, p) float
    heights : (..., p) float

    Returns
    -------
    volume : (...) float
    """
    size = gram.shape[-1]
    points = {}
    for count in range(1, size + 1):
        for subset in combinations(range(size), count):
            index = list(subset)
            block = gram[..., index, :][..., :, index]
            # A ridge through x has a singular Gram block (its limit is taken elsewhere):
            # solve a stand-in there and mark the result undefined instead of raising.
            singular = ~(np.linalg.det(block) > 0.0)
            block = np.where(singular[..., None, None], np.eye(count), block)
            local = np.linalg.solve(block, heights[..., index, None])
            full = np.zeros(gram.shape[:-1])
            full[..., index] = np.where(singular[..., None], np.nan, local[..., 0])
            points[frozenset(subset)] = full
    total = np.zeros(gram.shape[:-2])
    for order in permutations(range(size)):
        chain = [points[frozenset(order[:j + 1])] for j in range(size)]
        inversions = sum(order[a] > order[b] for a in range(size) for b in range(a + 1, size))
        total += (-1.0) ** inversions * np.linalg.det(np.stack(chain, axis=-1))
    return total / factorial(size)


@dataclass(frozen=True)
class Kind:
    """A named generating surface: the one table the core, the add-on and the scripts
    derive their lists from (a new surface is a new row)."""

    name: str  # the core's name, e.g. "mean_value"
    label: str  # for people, e.g. "Mean Value"
    description: str
    surface: object  # function of a PointFrame: d, or d |m_R| (``form``)
    form: str  # "d" or "scaled"
    convex_only: bool  # needs a convex cage
    may_be_negative: bool  # can go negative inside a convex cage
    parameter: str = None  # the surface's parameter (passed by keyword), if it has one
    parameter_default: float = None  # its value when not given


# The kinds the evaluation treats specially (a faster form, the default), spelled once.
WACHSPRESS, MEAN_VALUE = "wachspress", "mean_value"
# The others, for scripts and benchmarks that name one (each spelled only here).
DISCRETE_HARMONIC, VORONOI, POWER = "discrete_harmonic", "voronoi", "power"

KIND_TABLE = (
    Kind(WACHSPRESS, "Wachspress", "Smooth, positive and affine invariant; needs a convex "
         "cage", wachspress_scaled, "scaled", True, False),
    # Mean value coordinates stay well defined on non-convex closed cages (Ju et al. 2005).
    Kind(MEAN_VALUE, "Mean Value", "Smooth and positive inside convex cages; also works "
         "on non-convex closed cages", mean_value, "d", False, False),
    Kind(DISCRETE_HARMONIC, "Discrete Harmonic", "Cotangent weights; needs a convex cage "
         "and can be negative", discrete_harmonic_scaled, "scaled", True, True),
    Kind(VORONOI, "Voronoi", "Voronoi-cell weights; needs a convex cage and can be "
         "negative", voronoi_scaled, "scaled", True, True),
    # gamma = -1 Wachspress, 1 Voronoi; 2D gamma = 0 mean value. Default -0.5: positive
    # in every 3D and 4D polytope measured, not in an irregular 2D 9-gon (docs/POWER.md).
    Kind(POWER, "Power", "The power family through Wachspress (gamma -1) and Voronoi "
         "(gamma 1); needs a convex cage", power_scaled, "scaled", True, True, "gamma", -0.5),
)
_NAMED = {kind.name: kind for kind in KIND_TABLE}
KINDS = tuple(_NAMED)
CONVEX_ONLY_KINDS = tuple(kind.name for kind in KIND_TABLE if kind.convex_only)
# Harmonic coordinates have no generating surface: they are solved on a grid
# (gencoords.harmonic), so they are not in KIND_TABLE, but every function computing
# coordinates or weights takes them by this name (3D cages; ``resolution`` its grid).
HARMONIC = "harmonic"
# Mean value coordinates of cages of quads and triangles, each quad a bilinear patch
# (gencoords.mean_value_quad_coordinates): integrated, not from a generating surface;
# gencoords.coordinates and gencoords.weights take them by this name, faces quads too.
MEAN_VALUE_QUADS = "mean_value_quads"
EVERY_KIND = KINDS + (HARMONIC, MEAN_VALUE_QUADS)  # what ``kind`` may name


def _named(kind):
    if kind == HARMONIC:
        raise ValueError("harmonic coordinates are solved on a grid, not from a generating surface: "
                         "they have no ridge scalars or surface parameter")
    try:
        return _NAMED[kind]
    except KeyError:
        raise ValueError(f"unknown kind {kind!r}; expected one of {', '.join(KINDS)}") from None


def kind_parameter(kind, value):
    """The value of ``kind``'s parameter: ``value``, or its default when None.

    Raises ValueError for a value given to a kind without a parameter.
    """
    entry = None if kind in (HARMONIC, MEAN_VALUE_QUADS) else _named(kind)
    if entry is None or entry.parameter is None:
        if value is not None:
            with_parameter = [k.name for k in KIND_TABLE if k.parameter == "gamma"]
            raise ValueError(f"gamma applies to kind={' or '.join(map(repr, with_parameter))} only, "
                             f"not {kind!r}")
        return None
    return entry.parameter_default if value is None else value


def _surface_values(kind, frame, parameter):
    entry = _named(kind)
    return entry.surface(frame) if entry.parameter is None else entry.surface(frame, parameter)


def named_ridge_scalars(kind, frame, gamma=None):
    """d of the named generating surface ``kind`` (one of :data:`KINDS`; ``gamma`` for
    the power family): (r, k) float."""
    with np.errstate(divide="ignore", invalid="ignore"):
        values = _surface_values(kind, frame, gamma)
        return values if _named(kind).form == "d" else values / frame.ridge_measure


def named_scaled_ridge_scalars(kind, frame, gamma=None):
    """``d |m_R|`` (N! times Floater's c) of the named surface ``kind``: (r, k) float."""
    with np.errstate(divide="ignore", invalid="ignore"):
        values = _surface_values(kind, frame, gamma)
        return values * frame.ridge_measure if _named(kind).form == "d" else values
