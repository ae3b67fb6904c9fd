"""Coordinates of one chunk of points: the loop body shared by one process and workers.

Points are processed in chunks sized so that the temporary arrays of one chunk stay
small (cache friendly, and bounded memory whatever the number of points). Each row of
the result depends only on its point and on the chunking, so splitting the points over
processes at chunk boundaries gives bitwise the same coordinates as one process.
"""

from dataclasses import dataclass

import numpy as np

from ..base import tolerances
from ..construction.boundary import (BOUNDARY, OUTSIDE, locate, nearest_boundary_coordinates, plane_distances,
                       plane_limit_coordinates)
from ..construction.general import construct_weights, facet_determinants, point_frame
from ..construction.floater import FloaterTerms, floater_form_weights, floater_terms
from ..surfaces.named import MEAN_VALUE, WACHSPRESS, named_ridge_scalars, named_scaled_ridge_scalars
from ..construction.green import GREEN, GreenTerms, green_rows, green_terms
from ..construction.polar_dual import PolarDualTerms, polar_dual_terms, wachspress_polar_weights

__all__ = ["EvaluationTerms", "evaluation_terms", "chunk_size", "evaluate_rows", "locate_rows"]

# (point, facet) pairs per chunk: few enough that the temporaries stay in cache, enough
# that numpy's per-call overhead is amortised (measured optimum on 162- and 642-vertex
# cages: 32k pairs, 10 to 25% faster than 16k or 64k).
_CHUNK_PAIRS = 32 << 10
# Upper bound on a chunk's temporaries, for huge cages.
_CHUNK_BYTES = 24 << 20
# Locating points in a convex cage needs a few (k, m) arrays: larger chunks, less
# per-chunk overhead (winding numbers for other cages need the usual chunks).
_LOCATE_CHUNK_PAIRS = 1 << 20


@dataclass(frozen=True)
class EvaluationTerms:
    """Per-cage data of the evaluators: Floater's form, Wachspress's closed form (None
    above 3D) and Green coordinates' per-face constants (None but in 3D)."""

    floater: FloaterTerms
    polar_dual: PolarDualTerms
    green: GreenTerms


def evaluation_terms(cage):
    """The :class:`EvaluationTerms` of a prepared, closed and oriented cage."""
    return EvaluationTerms(floater_terms(cage), polar_dual_terms(cage),
                           green_terms(cage) if cage.dimension == 3 else None)


def chunk_size(cage, locate_only=False, convex=True):
    """Points per chunk for a prepared cage (:class:`gencoords.construction.general.PreparedCage`): int."""
    facets = len(cage.topology.faces)
    if locate_only and convex:
        return max(1, _LOCATE_CHUNK_PAIRS // facets)
    dim = cage.dimension
    ridges = len(cage.topology.ridges)
    per_point = 8 * (ridges * (dim * dim + 2 * dim) + facets * (3 * dim * dim + 4 * dim + 4)
                     + len(cage.vertices) * (cage.topology.vertex_slots.shape[1] + 2))
    return max(1, min(_CHUNK_PAIRS // facets, _CHUNK_BYTES // per_point))


def keep_freed_memory_for_reuse():
    """Let glibc keep the chunks' temporaries on its heap instead of returning them.

    Each chunk allocates and frees a few MB of temporaries. By default glibc serves
    blocks over 128 kB with fresh mmaps and trims its heap beyond 256 kB free, so every
    chunk page-faults its memory anew (measured: twice the arithmetic's cost). Freeing
    one mapped block raises both thresholds (glibc's documented dynamic adjustment, as
    any large numpy free would); settings are not touched, and elsewhere this is a no-op.
    """
    np.empty(3 << 20)  # 24 MB: below the 32 MB cap of the adjustment


def locate_rows(cage, points, absolute, convex):
    """Locations of a chunk of points: (k,) int8 (1 inside, 0 boundary, -1 outside)."""
    distance = plane_distances(cage, facet_determinants(cage, points))
    return locate(cage, points, distance, absolute, convex)[0]


@np.errstate(divide="ignore", invalid="ignore")  # boundary and undefined rows are replaced
def evaluate_rows(cage, terms, points, kind, convex, absolute, outside, normalise, out, gamma=None):
    """Coordinates (or weights) of one chunk of points, written into ``out``.

    Parameters
    ----------
    cage : gencoords.construction.general.PreparedCage
    terms : EvaluationTerms
        ``evaluation_terms(cage)``.
    points : (k, N) float
    kind : str
    convex : bool
        Whether the cage is convex (faster location, Floater's form).
    absolute : float
        Boundary tolerance, in the cage's units.
    outside : str
        ``"raise"`` (outside rows are left unwritten), ``"extrapolate"`` or ``"project"``.
    normalise : bool
        Coordinates (rows summing to 1) rather than homogeneous weights.
    out : (k, n) float32 or float64
        Receives the rows; for kind ``"green"`` (k, n + m): phi, then psi
        (:func:`gencoords.construction.green.green_rows`).
    gamma : float, optional
        The power family's parameter (kind "power").

    Returns
    -------
    locations : (k,) int8
    """
    if kind == GREEN:
        vertex_count = len(cage.vertices)
        return green_rows(cage, terms.green, points, convex, absolute, outside, out[:, :vertex_count],
                          out[:, vertex_count:])
    det = facet_determinants(cage, points)  # (k, m)
    distance = plane_distances(cage, det)
    where, limit = locate(cage, points, distance, absolute, convex)
    outside_rows = where == OUTSIDE
    if outside == "raise" and outside_rows.any():
        return where  # the caller raises; weights would be thrown away
    frame = point_frame(cage, points, det.T)
    # Floater's form, the weights grouped by ridge (Prop. 9), is the cheap one, and
    # Wachspress's closed form (2D, 3D) cheaper still.
    if kind == WACHSPRESS and terms.polar_dual is not None:
        values = wachspress_polar_weights(cage, terms.polar_dual, frame).T
    else:
        values = floater_form_weights(cage, terms.floater, points, frame.facet_det,
                                      named_scaled_ridge_scalars(kind, frame, gamma)).T
    # Mean value terms of facets whose hyperplane passes through x (off the facet) tend
    # to zero and their formula is 0/0: only the reciprocal-basis form (3x the cost) can
    # drop single facets, so the rows of such points, and only they, take it (a row does
    # not depend on the others in its chunk).
    near = np.flatnonzero((np.abs(distance) <= absolute).any(axis=1)) if kind == MEAN_VALUE else ()
    if len(near):
        near_frame = point_frame(cage, points[near], det[near].T)
        values[near] = construct_weights(cage, near_frame, named_ridge_scalars(kind, near_frame, gamma),
                                         np.abs(distance[near].T) <= absolute).T
    total = values.sum(axis=1, keepdims=True)
    if normalise:
        values /= total
    values[where == BOUNDARY] = limit
    # Where the formula has no value (a pole, a vanishing sum) the coordinates' limit is
    # taken: extrapolated outside points on a facet's hyperplane take their affine
    # coordinates in it; anything else (rounding at a tolerance below the data's
    # precision) the nearest boundary point's.
    undefined = ~np.isfinite(values).all(axis=1) | (np.abs(total[:, 0]) <= tolerances.TINY)
    on_plane = outside_rows & undefined if outside == "extrapolate" else np.zeros_like(undefined)
    if on_plane.any():
        values[on_plane] = plane_limit_coordinates(cage, points[on_plane], distance[on_plane])
    project = (undefined | (outside_rows if outside == "project" else False)) & ~on_plane
    if project.any():
        values[project] = nearest_boundary_coordinates(cage, points[project])[0]
    out[...] = values
    return where
