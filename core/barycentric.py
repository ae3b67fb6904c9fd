"""Public entry points: coordinates, weights and ridge scalars of named kinds.

Points are processed in chunks sized so that the temporary arrays of one chunk stay
small (cache friendly, and bounded memory whatever the number of points); chunks run
on a thread pool because numpy releases the GIL inside its kernels.
"""

import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import tolerances
from .boundary import (BOUNDARY, OUTSIDE, locate, nearest_boundary_coordinates, plane_distances,
                       plane_limit_coordinates)
from .construction import construct_weights, facet_determinants, point_frame, prepare_cage
from .errors import AccuracyWarning, CageError, OutsideCageError
from .floater import floater_form_weights, floater_terms
from .generating_surfaces import CONVEX_ONLY_KINDS, named_ridge_scalars, named_scaled_ridge_scalars
from .inputs import OUTSIDE_MODES, checked
from .units import length_degree, to_world
from .validation import DEFAULT_TOLERANCE, convexity_violation, validate_cage

__all__ = ["coordinates", "weights", "ridge_scalars", "point_locations", "needs_convex",
           "OUTSIDE_MODES"]

# (point, facet) pairs per chunk: few enough that the temporaries stay in cache, enough
# that numpy's per-call overhead is amortised (measured optimum on 162- and 642-vertex
# cages: 32k pairs, 10 to 25% faster than 16k or 64k).
_CHUNK_PAIRS = 32 << 10
# Upper bound on a chunk's temporaries, for huge cages: with two workers far below the
# 256 MB budget whatever the number of points.
_CHUNK_BYTES = 24 << 20
# Locating points in a convex cage needs a few (k, m) arrays: larger chunks, less
# per-chunk overhead (winding numbers for other cages need the usual chunks).
_LOCATE_CHUNK_PAIRS = 1 << 20
_WORKERS = max(1, min(os.cpu_count() or 1, 8))


@checked
def needs_convex(kind):
    """Whether coordinates of ``kind`` require a convex cage (all but mean value)."""
    return kind in CONVEX_ONLY_KINDS


def _chunk_size(cage):
    dim = cage.dimension
    ridges, facets = len(cage.topology.ridges), len(cage.topology.faces)
    per_point = 8 * (ridges * (dim * dim + 2 * dim) + facets * (3 * dim * dim + 4 * dim + 4)
                     + len(cage.vertices) * (cage.topology.vertex_slots.shape[1] + 2))
    return max(1, min(_CHUNK_PAIRS // facets, _CHUNK_BYTES // per_point))


def _keep_freed_memory_for_reuse():
    """Let glibc keep the chunks' temporaries on its heap instead of returning them.

    Each chunk allocates and frees a few MB of temporaries. By default glibc serves
    blocks over 128 kB with fresh mmaps and trims its heap beyond 256 kB free, so every
    chunk page-faults its memory anew (measured: twice the arithmetic's cost). Freeing
    one mapped block raises both thresholds (glibc's documented dynamic adjustment, as
    any large numpy free would); settings are not touched, and elsewhere this is a no-op.
    """
    np.empty(3 << 20)  # 24 MB: below the 32 MB cap of the adjustment


def _map_chunks(function, count, chunk, progress=None):
    """Run ``function(slice)`` over consecutive slices of ``range(count)``, in parallel.

    ``progress(fraction)`` is called on the calling thread as slices complete.
    """
    _keep_freed_memory_for_reuse()
    slices = [slice(start, min(start + chunk, count)) for start in range(0, count, chunk)]
    report = progress or (lambda fraction: None)
    if len(slices) <= 1 or _WORKERS == 1:
        for piece in slices:
            function(piece)
            report(piece.stop / count)
        return
    with ThreadPoolExecutor(max_workers=_WORKERS) as pool:
        for piece, _ in zip(slices, pool.map(function, slices)):  # re-raises worker errors
            report(piece.stop / count)


def _prepare(points, vertices, faces, kind, tolerance):
    convex_required = needs_convex(kind)
    cage = validate_cage(vertices, faces, convex=convex_required, tolerance=tolerance)
    convex = convex_required or convexity_violation(cage, tolerance) is None
    if not convex and cage.dimension > 3:
        raise CageError("non_convex", "mean value coordinates on non-convex cages are implemented "
                                      "for 2D and 3D cages only")
    return points, cage, convex  # points: (k, N) float64, checked by @checked


def _evaluate(points, cage, kind, convex, tolerance, outside, normalise, progress=None,
              dtype=np.float64):
    """Shared driver of :func:`coordinates` and :func:`weights` (see there)."""
    absolute = tolerance * cage.size
    count = len(points)
    result = np.empty((count, len(cage.vertices)), dtype=dtype)
    location = np.empty(count, dtype=np.int8)
    mean_value = kind == "mean_value"
    terms = floater_terms(cage)
    # With outside="raise", once any chunk has an outside point the others only locate
    # theirs (the error counts them all): weights would be thrown away.
    outside_found = threading.Event()

    @np.errstate(divide="ignore", invalid="ignore")  # per thread: boundary rows are replaced
    def run(rows):
        x = points[rows]
        det = facet_determinants(cage, x)  # (k, m)
        distance = plane_distances(cage, det)
        where, limit = locate(cage, x, distance, absolute, convex)
        location[rows] = where
        if outside == "raise" and (where == OUTSIDE).any():
            outside_found.set()
        if outside_found.is_set():
            return
        frame = point_frame(cage, x, det.T)
        # Mean value terms of facets whose hyperplane passes through x (off the facet)
        # tend to zero and their formula is 0/0: only the reciprocal-basis form can drop
        # single facets. Otherwise Floater's form, the same weights grouped by ridge
        # (Prop. 9), is cheaper.
        skip = (np.abs(distance.T) <= absolute) if mean_value else None
        if skip is not None and skip.any():
            values = construct_weights(cage, frame, named_ridge_scalars(kind, frame), skip).T
        else:
            values = floater_form_weights(cage, terms, x, frame.facet_det,
                                          named_scaled_ridge_scalars(kind, frame)).T
        total = values.sum(axis=1, keepdims=True)
        if normalise:
            values = values / total
        values[where == BOUNDARY] = limit
        outside_rows = where == OUTSIDE
        # Where the formula has no value (a pole, a vanishing sum) the coordinates' limit
        # is taken: extrapolated outside points on a facet's hyperplane take their affine
        # coordinates in it; anything else (rounding at a tolerance below the data's
        # precision) the nearest boundary point's.
        undefined = ~np.isfinite(values).all(axis=1) | (np.abs(total[:, 0]) <= tolerances.TINY)
        on_plane = outside_rows & undefined if outside == "extrapolate" else np.zeros_like(undefined)
        if on_plane.any():
            values[on_plane] = plane_limit_coordinates(cage, x[on_plane], distance[on_plane])
        project = (undefined | (outside_rows if outside == "project" else False)) & ~on_plane
        if project.any():
            values[project] = nearest_boundary_coordinates(cage, x[project])[0]
        result[rows] = values

    _map_chunks(run, count, _chunk_size(cage), progress)
    if outside == "raise" and (location == OUTSIDE).any():
        raise OutsideCageError(np.flatnonzero(location == OUTSIDE), count)
    return result, location


@checked
def coordinates(points, vertices, faces, kind="mean_value", outside="raise",
                tolerance=DEFAULT_TOLERANCE, progress=None, dtype=np.float64, locations=None):
    """Generalized barycentric coordinates of points with respect to a cage.

    Parameters
    ----------
    points : (k, N) float
        Query points (a single (N,) point is accepted).
    vertices : (n, N) float
        Cage vertices.
    faces : (m, N) int
        Simplicial facets, outward oriented (2D: counter-clockwise polygon edges;
        3D: triangles counter-clockwise seen from outside).
    kind : str
        ``"wachspress"``, ``"mean_value"``, ``"discrete_harmonic"`` or ``"voronoi"``.
        Mean value coordinates accept any closed, consistently oriented 2D/3D cage;
        the others need a convex one.
    outside : str
        What to do with points outside the cage: ``"raise"`` (OutsideCageError naming
        them), ``"extrapolate"`` (the formula, smooth for mean value; on a facet's
        hyperplane, where the other kinds' weights have a pole, its limit: the affine
        coordinates of the point in that hyperplane) or ``"project"`` (the coordinates
        of the nearest boundary point).
    tolerance : float
        Relative to the cage's bounding-box diagonal. Points this close to the boundary
        count as on it and get the exact limit: linear coordinates of the facet, edge or
        vertex they touch.
    progress : callable, optional
        ``progress(fraction)`` is called from the calling thread as work completes
        (fraction in (0, 1]), for progress bars on long computations.
    dtype : numpy dtype
        Of the result. Computation is always float64; ``np.float32`` halves the
        result's memory (a large bind) without a float64 copy of it ever existing.
    locations : (k,) int8 ndarray, optional
        Filled with each point's location, as :func:`point_locations` gives it (1 inside,
        0 on the boundary, -1 outside), at no extra cost.

    Returns
    -------
    coordinates : (k, n) dtype
        Rows sum to 1 and reproduce the points: ``coordinates @ vertices == points``
        (for inside and boundary points).

    Raises
    ------
    CageError
        The cage is unusable (open, non-manifold, inverted, non-convex for the kind...).
    OutsideCageError
        ``outside="raise"`` and some points are outside.
    """
    points, cage, convex = _prepare(points, vertices, faces, kind, tolerance)
    result, where = _evaluate(points, cage, kind, convex, tolerance, outside, normalise=True,
                              progress=progress, dtype=dtype)
    if kind == "mean_value" and outside == "extrapolate":
        _warn_if_flat_extrapolation(points, vertices, faces, cage, convex, tolerance, result, where)
    if locations is not None:
        locations[...] = where
    return result


def _warn_if_flat_extrapolation(points, vertices, faces, cage, convex, tolerance, result, where):
    """AccuracyWarning when mean value extrapolation outside a near-flat cage lost accuracy.

    The solid angles of a thin cage seen from outside nearly cancel. Coordinates are
    invariant under scaling both the cage and the points, so evaluating the outside
    points again on a copy scaled by a non-dyadic factor changes only the rounding: the
    gap estimates the error (1:1:1e-6 icosphere: estimate 5e4, error 9e4).
    """
    outside_rows = np.flatnonzero(where == OUTSIDE)
    extent = np.linalg.svd(cage.vertices - cage.vertices.mean(axis=0), compute_uv=False)
    if not len(outside_rows) or extent[-1] > tolerances.FLAT * extent[0]:
        return
    factor = 1.0 + 1.0 / 3.0
    twin = prepare_cage(vertices * factor, faces)
    again = _evaluate(points[outside_rows] * factor, twin, "mean_value", convex, tolerance,
                      "extrapolate", normalise=True)[0]
    error = float(np.abs(again - result[outside_rows]).max())
    if error > tolerances.ACCURACY:
        warnings.warn(f"mean value coordinates extrapolated outside this thin cage (thickness "
                      f"{extent[-1] / extent[0]:.1e} of its extent) are accurate only to about "
                      f"{error:.1e} (estimated; {len(outside_rows)} outside points); use "
                      "outside='project', or a thicker cage", AccuracyWarning, stacklevel=3)


@checked
def weights(points, vertices, faces, kind="mean_value", tolerance=DEFAULT_TOLERANCE):
    """Homogeneous weights of a named kind: ``sum_i w_i (v_i - x) = 0``.

    Parameters and cage requirements as :func:`coordinates`. Inside the cage these are
    the unnormalised weights of the construction (coordinates are ``w / w.sum()``); at
    boundary points, where the formula has a pole, the limit coordinates (themselves
    homogeneous weights) are returned; outside points get the formula's value, or on a
    facet's hyperplane (a pole, for a convex-only kind) the limit coordinates there.

    Returns
    -------
    weights : (k, n) float
    """
    points, cage, convex = _prepare(points, vertices, faces, kind, tolerance)
    values, where = _evaluate(points, cage, kind, convex, tolerance, "extrapolate", normalise=False)
    # Frame weights to world units (limit coordinates on the boundary are unit-free).
    formula = where != BOUNDARY
    values[formula] = to_world(values[formula], cage.scale, length_degree(kind, cage.dimension) - 1,
                               "weights")
    return values


@checked
def ridge_scalars(points, vertices, faces, kind):
    """Ridge scalars d of a named generating surface.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
    kind : str
        One of ``"wachspress"``, ``"mean_value"``, ``"discrete_harmonic"``, ``"voronoi"``.

    Returns
    -------
    d : (k, r) float
        Columns follow :func:`core.ridges` (2D: vertices, 3D: edges).
    """
    cage = validate_cage(vertices, faces, convex=False)
    d = named_ridge_scalars(kind, point_frame(cage, points)).T
    return to_world(d, cage.scale, length_degree(kind, cage.dimension), "ridge scalars")


@checked
def point_locations(points, vertices, faces, tolerance=DEFAULT_TOLERANCE):
    """Where each point is: 1 inside, 0 on the boundary (within tolerance), -1 outside.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
        A closed, consistently oriented cage (convex or, in 2D and 3D, not).
    tolerance : float
        Relative to the cage's bounding-box diagonal.

    Returns
    -------
    locations : (k,) int8
    """
    cage = validate_cage(vertices, faces, convex=False, tolerance=tolerance)
    convex = convexity_violation(cage, tolerance) is None
    absolute = tolerance * cage.size
    result = np.empty(len(points), dtype=np.int8)

    def run(rows):
        x = points[rows]
        distance = plane_distances(cage, facet_determinants(cage, x))
        result[rows] = locate(cage, x, distance, absolute, convex)[0]

    chunk = max(1, _LOCATE_CHUNK_PAIRS // len(cage.topology.faces)) if convex else _chunk_size(cage)
    _map_chunks(run, len(points), chunk)
    return result

