"""A Bind's coordinates chunk by chunk, written in the chosen storage, and the figures
measured on them as written (float32): :func:`written_slots`; the points' coordinates
(:func:`solve_points`, harmonic ones looked up in their field), where the points are
(:func:`point_locations`), how far float32 rounds the cage (:func:`origin_distance`)
and how the kind behaves in the cage (:func:`kind_report`).
"""

import numpy as np

from ..construction.boundary import INSIDE, OUTSIDE
from ..construction.quad_cage import MEAN_VALUE_QUADS
from ..evaluation.quad_coordinates import mean_value_quad_coordinates
from ..reports.fields import coordinate_summary, linear_precision
from ..reports.report import coordinate_report
from ..storage import Storage
from ..storage.codecs import codec
from ..storage.deviations import residual_deviations
from .request import UndefinedCoordinatesError
from .similarity import similarity_deviation
from .storage_choice import coordinate_rows

__all__ = ["origin_distance"]

# Coordinates computed per chunk of points: progress and cancel granularity, and the
# bound on the dense float64 block a chunk makes (points x cage vertices).
CHUNK_ENTRIES = 4_000_000  # per worker process
# Harmonic coordinates are looked up in this process, whatever the workers: a chunk's
# (points x cage vertices) float64 blocks of 4 MB (the cup's three of 22 MB were its peak).
FIELD_CHUNK_ENTRIES = 1 << 19
REPORT_SAMPLES = 1000  # points inside the cage coordinate_report examines


def solve_points(request, cage, points, workers, locations=None, field=None):
    """The coordinates of ``points`` ((j, rows) float64) in ``cage``, in ``request.run``
    (harmonic coordinates: looked up in their solved ``field``)."""
    def compute(count):
        if field is not None:
            return field.coordinates(points, outside=request.outside)
        if request.kind == MEAN_VALUE_QUADS:  # the quads' own integrals
            return mean_value_quad_coordinates(points, cage.vertices, request.polygons, outside=request.outside,
                                               tolerance=request.tolerance, locations=locations, workers=count)
        if request.green:  # phi and psi side by side: the slots' n + m rows
            return np.hstack(cage.green_coordinates(points, outside=request.outside, locations=locations,
                                                    workers=count))
        return cage.coordinates(points, kind=request.kind, outside=request.outside, locations=locations,
                                workers=count, gamma=request.gamma)

    coordinates = request.run(compute, workers)
    if field is not None and locations is not None:
        locations[:] = point_locations(request, cage, points)
    if not np.isfinite(coordinates).all():
        raise UndefinedCoordinatesError("the coordinates are not finite: tiny or overlapping cage faces")
    return coordinates


def point_locations(request, cage, points):
    """Where the points are (INSIDE, BOUNDARY, OUTSIDE): harmonic coordinates refuse
    points outside (``outside="raise"``) or project them, so only then is it asked."""
    if request.outside == "raise":
        return np.full(len(points), INSIDE, dtype=np.int8)
    return cage.point_locations(points)


def written_slots(request, cage, points, choice, workers, field=None):
    """The slots of every point in ``choice``'s storage, chunk by chunk, yielding the
    fraction done; returns them with sparse storage's pairs' columns (else None), their
    locations and the figures measured on them as written (the deviations from the
    exact coordinates on every point)."""
    count, rows = len(points), coordinate_rows(request.kind, len(cage.vertices), len(cage.faces))
    slot_count = rows if choice.slot_count is None else choice.slot_count
    slots = np.empty((count, slot_count), dtype=np.float32)
    indices = np.empty((count, slot_count), dtype=np.int32) if choice.storage == Storage.SPARSE else None
    locations = np.empty(count, dtype=np.int8)
    totals = {"min": np.inf, "negative_points": 0, "negative_entries": 0, "max_affine_error": 0.0,
              "weight_magnitude": 0.0}
    precision = similarity = 0.0
    smooth, drag = 0.0, np.zeros(len(cage.vertices))
    faces = cage.faces if request.green else None
    chunk = max(1, (CHUNK_ENTRIES * workers if field is None else FIELD_CHUNK_ENTRIES) // rows)
    for start in range(0, count, chunk):
        part = slice(start, min(start + chunk, count))
        coordinates = solve_points(request, cage, points[part], workers, locations[part], field)
        # Green's phi (the first n) sum to 1 and weigh the vertices as the others do.
        summary = coordinate_summary(coordinates[:, :len(cage.vertices)])
        for name, combine in (("min", min), ("negative_points", int.__add__), ("negative_entries", int.__add__)):
            totals[name] = combine(totals[name], summary[name])
        storage = codec(choice.storage)
        slots[part], pairs = storage.encode(choice, coordinates, cage.vertices)
        if indices is not None:
            indices[part] = pairs
        reproduced = storage.reproduce(choice, slots[part], pairs, rows)
        # The sums as written: float32 rounding of huge coordinates breaks translations.
        weights = reproduced[:, :len(cage.vertices)]
        sums = weights.sum(axis=1)
        totals["max_affine_error"] = max(totals["max_affine_error"], float(np.abs(sums - 1.0).max(initial=0.0)))
        precision = max(precision, _placed(request, reproduced, cage.vertices, points[part], locations[part]))
        similarity = max(similarity, similarity_deviation(weights @ cage.vertices, sums, points[part], cage.vertices))
        # The residual and the weights' sizes in the two (j, rows) arrays there are: a
        # third (the cup: 22 MB) was its Bind's peak.
        residual = np.subtract(coordinates, reproduced, out=coordinates)
        magnitudes = np.abs(weights, out=weights).sum(axis=1)  # what multiplies the cage's rounding
        totals["weight_magnitude"] = max(totals["weight_magnitude"], float(magnitudes.max(initial=0.0)))
        chunk_smooth, chunk_drag = residual_deviations(residual, cage.vertices, faces=faces)
        smooth, drag = max(smooth, chunk_smooth), np.maximum(drag, chunk_drag)
        # With workers, shared memory: freed before the next chunk's.
        del coordinates, residual, reproduced, weights
        yield part.stop / count
    return slots, indices, locations, {
        "min_coordinate": float(totals["min"]), "negative_points": totals["negative_points"],
        "negative_entries": totals["negative_entries"], "max_affine_error": float(totals["max_affine_error"]),
        "linear_precision": float(precision), "deviation_smooth": float(smooth),
        "deviation_drag": float(drag.max(initial=0.0)), "deviation_drag_vertex": int(np.argmax(drag)),
        "weight_magnitude": totals["weight_magnitude"], "similarity_deviation": None if request.green else similarity}


def _placed(request, stored, cage_vertices, points, locations):
    """``linear_precision`` of coordinates as stored ((j, rows)) for ``points`` (Green
    coordinates also weigh normals: 0; projected points are not placed where they are:
    left out)."""
    if request.green:
        return 0.0
    placed = slice(None) if request.outside != "project" else locations != OUTSIDE
    return linear_precision(stored[placed], cage_vertices, points[placed])


def origin_distance(cage_vertices, origins=None):
    """The cage's largest coordinate measured from ``origins`` ((o, 3), or (3,) for one;
    the frame's origin if None), of the cage's size (its bounding-box diagonal): how far
    float32 rounds its positions, in epsilons of its size.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.planning.figures import origin_distance
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    >>> round(origin_distance(cube), 4), round(origin_distance(cube, [-99.0, 0.0, 0.0]), 4)
    (0.5774, 57.735)
    """
    cage_vertices = np.asarray(cage_vertices, dtype=np.float64)
    origins = np.zeros((1, cage_vertices.shape[1])) if origins is None else np.atleast_2d(origins).astype(np.float64)
    distance = max(float(np.abs(cage_vertices - origin).max(initial=0.0)) for origin in origins)
    return distance / float(np.linalg.norm(np.ptp(cage_vertices, axis=0)))


def kind_report(request, cage, field=None):
    """How this kind behaves in this cage, away from the mesh's own vertices (the figures
    cover those): positivity and well-definedness on a sample."""
    if request.green:
        return "Green: similarity invariant, shape-preserving; any closed cage"
    if request.kind == MEAN_VALUE_QUADS:
        return "Mean value on quads: each quad its bilinear patch, whichever corner it starts from; any closed cage"
    if field is not None:
        patches = ", each quad its bilinear patch" if (field.faces.shape[1] == 4 and (field.faces[:, 3] >= 0).any()) else ""
        resolved = "" if request.grid is None else f"; {request.grid.words()}"
        return (f"Harmonic: local, never negative; any closed cage{patches} (resolution {field.resolution}: "
                f"{len(field.node_indices)} grid nodes solved{resolved})")
    return coordinate_report(cage.vertices, cage.faces, request.kind, gamma=request.gamma,
                             samples=REPORT_SAMPLES, tolerance=request.tolerance).headline

