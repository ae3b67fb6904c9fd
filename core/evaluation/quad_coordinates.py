"""Mean value coordinates of cages of quads and triangles, each quad its bilinear patch
(docs/MATH.md, "Quad cages"), in this process or spread over worker processes."""

import numpy as np

from ..base.errors import OutsideCageError, WorkerError
from ..base.inputs import checked
from ..construction.quad_cage import (boundary_rows, fan_split, integrated_weights, restore_linear_precision,
                                      validate_polygons)
from ..construction.validation import DEFAULT_TOLERANCE
from ..surfaces.named import HARMONIC, MEAN_VALUE_QUADS, kind_parameter
from .interpreters import available_cores, python_executable
from .parallel import WorkerPool, dispatch_units
from .shared_memory import SharedArrays

__all__ = ["mean_value_quad_coordinates", "quad_kind_coordinates", "worker_count", "integrated_weights_task"]

# (point, quad) pairs worth a worker: about half a second of integrals.
_PAIRS_PER_WORKER = 1 << 18
_UNIT_POINTS = 256  # points a worker takes at a time


def worker_count(workers, pairs):
    """Processes for ``pairs`` (point, face) pairs: ``workers``, or for None one per
    ``_PAIRS_PER_WORKER`` up to the cores (1 where no Python can start)."""
    if workers is not None:
        return workers
    wanted = max(1, min(available_cores(), pairs // _PAIRS_PER_WORKER))
    if wanted > 1:
        try:
            python_executable()
        except WorkerError:
            return 1
    return wanted


def integrated_weights_task(arrays, job, start, stop):
    """A worker's share (:func:`gencoords.evaluation.parallel.serve`): the integrals of
    points ``start:stop`` into ``arrays["result"]`` and ``arrays["solid"]``."""
    arrays["result"][start:stop], arrays["solid"][start:stop] = integrated_weights(
        arrays["points"][start:stop], arrays["vertices"], arrays["polygons"])


def _integrated(points, vertices, polygons, workers, progress):
    """:func:`integrated_weights` of every point, in units of ``_UNIT_POINTS`` (the same
    rows whatever the number of processes): ((k, n), (k,))."""
    if workers <= 1:
        weights, solid = np.empty((len(points), len(vertices))), np.empty(len(points))
        for start in range(0, len(points), _UNIT_POINTS):
            rows = slice(start, start + _UNIT_POINTS)
            weights[rows], solid[rows] = integrated_weights(points[rows], vertices, polygons)
            if progress is not None:
                progress(min(1.0, (start + _UNIT_POINTS) / len(points)))
        return weights, solid
    specs = {"points": (points.shape, np.float64), "vertices": (vertices.shape, np.float64),
             "polygons": (polygons.shape, np.int64), "result": ((len(points), len(vertices)), np.float64),
             "solid": ((len(points),), np.float64), "locations": ((len(points),), np.int8)}
    shared = SharedArrays(specs)
    for name, value in (("points", points), ("vertices", vertices), ("polygons", polygons)):
        shared.arrays[name][...] = value
    pool = WorkerPool(vertices, fan_split(polygons)[0], workers)
    try:
        report = None if progress is None else (lambda done: progress(done / len(points)))
        pool.run(shared, dict(task="evaluation.quad_coordinates:integrated_weights_task"),
                 dispatch_units(len(points), _UNIT_POINTS, workers), report)
        return shared.arrays["result"].copy(), shared.arrays["solid"].copy()
    finally:
        pool.close()
        shared.remove()


@checked
def mean_value_quad_coordinates(points, vertices, polygons, outside="raise", tolerance=DEFAULT_TOLERANCE,
                                locations=None, workers=None, progress=None):
    """Mean value coordinates of a cage of quads and triangles, each quad a bilinear patch.

    Quad-native: a non-planar quad is not split, so the result does not depend on a
    diagonal or on which corner a quad lists first (docs/MATH.md, "Quad cages").

    Parameters
    ----------
    points : (k, 3) float
    vertices : (n, 3) float
    polygons : (m, 3) or (m, 4) int, or a list of 3- and 4-index lists (mixed)
        Counter-clockwise seen from outside; closed, consistently oriented.
    outside : str
        ``"raise"`` (OutsideCageError naming the points), ``"extrapolate"`` (the
        formula) or ``"project"`` (the weights of the nearest point of the surface).
    tolerance : float
        Relative to the cage's bounding-box diagonal: points this close to a face get its
        bilinear (quad) or linear (triangle) weights.
    locations : (k,) int8 ndarray, optional
        Filled with 1 inside, 0 on a face, -1 outside.
    workers : int or None
        Processes (as :func:`gencoords.coordinates`): None spreads a long call over the
        cores.
    progress : callable, optional
        ``progress(fraction)`` as the points' integrals are done.

    Returns
    -------
    coordinates : (k, n) float
        Rows sum to 1 and reproduce the points (projected points: their nearest surface
        point).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import block_cage
    >>> vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))   # a unit cube, six quads
    >>> b = gencoords.mean_value_quad_coordinates([[0.5, 0.5, 0.5]], vertices, quads)
    >>> print(np.round(b, 6))
    [[0.125 0.125 0.125 0.125 0.125 0.125 0.125 0.125]]
    """
    validate_polygons(vertices, polygons, tolerance)
    count = worker_count(workers, len(points) * len(polygons))
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    origin, size = 0.5 * (low + high), float(np.linalg.norm(high - low))
    local_vertices, local_points = (vertices - origin) / size, (points - origin) / size
    on_face, face_rows = boundary_rows(local_points, local_vertices, polygons, tolerance)
    rest = np.setdiff1d(np.arange(len(points)), on_face)
    weights, solid = _integrated(local_points[rest], local_vertices, polygons, count, progress)
    away = rest[solid < 2.0 * np.pi]  # the winding number under 1/2
    if outside == "raise" and len(away):
        raise OutsideCageError(away, len(points))
    result = np.empty((len(points), len(vertices)))
    result[rest], _ = restore_linear_precision(weights / weights.sum(axis=1, keepdims=True), local_vertices,
                                               local_points[rest])
    result[on_face] = face_rows
    if outside == "project" and len(away):
        nearest, rows = boundary_rows(local_points[away], local_vertices, polygons, np.inf)
        result[away[nearest]] = rows
    if locations is not None:
        locations[:] = 1
        locations[on_face], locations[away] = 0, -1
    return result


def quad_kind_coordinates(points, vertices, polygons, outside, tolerance, progress, locations, workers, gamma,
                          resolution):
    """:func:`gencoords.coordinates` of kind MEAN_VALUE_QUADS, arguments checked there ((k, n)
    float): :func:`mean_value_quad_coordinates`'s, which take neither parameter of a kind."""
    if resolution is not None:
        raise ValueError(f"resolution applies to kind={HARMONIC!r} only, not {MEAN_VALUE_QUADS!r}")
    kind_parameter(MEAN_VALUE_QUADS, gamma)  # refuses a gamma
    return mean_value_quad_coordinates(points, vertices, polygons, outside=outside, tolerance=tolerance,
                                       locations=locations, workers=workers, progress=progress)
