"""A cage validated and prepared once, for any number of coordinate computations.

``core.coordinates(points, vertices, faces, ...)`` and the other free functions build
a :class:`Cage` per call; a caller with several batches of points (the add-on's Bind,
an animation tool) keeps one, and with it everything that depends only on the cage:
the validation, the per-facet and per-ridge polynomials, and the worker processes.
"""

import numpy as np

from .boundary import OUTSIDE
from .construction import point_frame
from .errors import CageError, OutsideCageError, WorkerError
from .evaluation import chunk_size, evaluate_rows, evaluation_terms, keep_freed_memory_for_reuse, locate_rows
from .generating_surfaces import CONVEX_ONLY_KINDS, KINDS, named_ridge_scalars
from .parallel import SharedArrays, WorkerPool, available_cores, python_executable
from .validation import DEFAULT_TOLERANCE, convexity_violation, non_convex_error, validate_cage

__all__ = ["Cage", "OUTSIDE_MODES", "needs_convex"]

OUTSIDE_MODES = ("raise", "extrapolate", "project")
# With workers=None, processes start only for calls long enough to repay starting them
# (about 0.2 s each: a Python importing numpy): one worker per this many (point, facet)
# pairs, about half a second of work at 30 ns a pair.
_PAIRS_PER_WORKER = 16 << 20
_RESULT_DTYPES = (np.dtype(np.float64), np.dtype(np.float32))


def needs_convex(kind):
    """Whether coordinates of ``kind`` require a convex cage (all but mean value)."""
    if kind not in KINDS:
        raise ValueError(f"unknown kind {kind!r}; expected one of {', '.join(KINDS)}")
    return kind in CONVEX_ONLY_KINDS


class Cage:
    """A closed cage, validated once; coordinates of any points with respect to it.

    Parameters
    ----------
    vertices : (n, N) float
        Cage vertices, N >= 2.
    faces : (m, N) int
        Simplicial facets, outward oriented (2D: counter-clockwise polygon edges; 3D:
        triangles counter-clockwise seen from outside).
    tolerance : float
        Relative to the cage's bounding-box diagonal: coincident vertices, flat facets,
        convexity and "on the boundary" are judged to this precision.

    Raises
    ------
    CageError
        The cage is unusable (open, non-manifold, inverted...). Convexity is checked
        when a kind that needs it is asked for.

    Notes
    -----
    A cage that has computed with ``workers > 1`` keeps its worker processes for the
    next call; ``close()`` (or ``with core.Cage(...) as cage:``) stops them, as does
    garbage collection and interpreter exit.
    """

    def __init__(self, vertices, faces, tolerance=DEFAULT_TOLERANCE):
        self._prepared = validate_cage(vertices, faces, convex=False, tolerance=tolerance)
        self.tolerance = float(tolerance)
        self.vertices = np.array(vertices, dtype=np.float64)
        self.faces = np.array(faces, dtype=np.int64)
        self.vertices.flags.writeable = self.faces.flags.writeable = False
        self._violation = convexity_violation(self._prepared, tolerance)
        self._terms = None
        self._pool = None

    @property
    def dimension(self):
        """N: int."""
        return self.vertices.shape[1]

    @property
    def size(self):
        """The bounding-box diagonal that tolerances are relative to: float."""
        return self._prepared.size

    @property
    def convex(self):
        """Whether the cage is convex (within the tolerance): bool."""
        return self._violation is None

    def __repr__(self):
        return (f"Cage({len(self.vertices)} vertices, {len(self.faces)} facets, {self.dimension}D, "
                f"{'convex' if self.convex else 'not convex'})")

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def close(self):
        """Stop this cage's worker processes, if any (it stays usable)."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None

    def suggested_workers(self, point_count):
        """Worker processes that ``workers=None`` would use for this many points: int.

        For callers splitting a long computation into calls of their own (to show
        progress, or to turn each batch into something smaller at once), who should
        choose once, for the whole job.
        """
        return self._worker_count(None, point_count, len(self.faces))

    # -- the public computations -------------------------------------------------------

    def coordinates(self, points, kind="mean_value", outside="raise", progress=None,
                    dtype=np.float64, locations=None, workers=None):
        """Generalized barycentric coordinates of points (see :func:`core.coordinates`).

        Parameters
        ----------
        points : (k, N) float
        kind, outside, progress, dtype, locations
            As :func:`core.coordinates`.
        workers : int or None
            Processes to compute in. ``1``: this process only. ``None``: as many as
            the cores this process may use, for calls long enough to repay starting
            them (about half a second of work per worker), else this process. The
            result is bitwise the same whatever the number.

        Returns
        -------
        coordinates : (k, n) dtype
        """
        if outside not in OUTSIDE_MODES:
            raise ValueError(f"outside must be one of {', '.join(OUTSIDE_MODES)}, got {outside!r}")
        if np.dtype(dtype) not in _RESULT_DTYPES:
            raise ValueError(f"dtype must be float64 or float32, got {np.dtype(dtype)}")
        result, where = self._evaluate(points, kind, outside, True, progress, np.dtype(dtype), workers)
        if locations is not None:
            locations[...] = where
        return result

    def weights(self, points, kind="mean_value", workers=None):
        """Homogeneous weights of a named kind (see :func:`core.weights`): (k, n) float."""
        return self._evaluate(points, kind, "extrapolate", False, None, np.dtype(np.float64), workers)[0]

    def ridge_scalars(self, points, kind):
        """Ridge scalars d of a named generating surface (see :func:`core.ridge_scalars`):
        (k, r) float."""
        needs_convex(kind)
        points = self._points(points)
        return named_ridge_scalars(kind, point_frame(self._prepared, points)).T

    def point_locations(self, points, workers=None):
        """1 inside, 0 on the boundary (within the tolerance), -1 outside: (k,) int8."""
        points = self._points(points)
        locations = np.empty(len(points), dtype=np.int8)
        absolute = self.tolerance * self.size
        chunk = chunk_size(self._prepared, locate_only=True, convex=self.convex)
        # Locating costs a few times less per pair than coordinates.
        count = self._worker_count(workers, len(points), len(self.faces) // 4 + 1)
        if count > 1:
            job = dict(chunk=chunk, absolute=absolute, convex=self.convex, outside="extrapolate")
            self._run_in_workers(points, job, chunk, None, count, locations, None)
            return locations
        for start in range(0, len(points), chunk):
            rows = slice(start, start + chunk)
            locations[rows] = locate_rows(self._prepared, points[rows], absolute, self.convex)
        return locations

    # -- shared machinery ----------------------------------------------------------------

    def _points(self, points):
        dim = self.dimension
        points = np.asarray(points, dtype=np.float64)
        if points.size == 0:
            return points.reshape(0, dim)
        if points.ndim == 1:
            points = points[None, :]
        if points.ndim != 2 or points.shape[1] != dim:
            raise ValueError(f"points must have shape (k, {dim}) for a {dim}D cage, got {points.shape}")
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            raise ValueError(f"{np.count_nonzero(bad)} points have non-finite coordinates "
                             f"(first: {int(np.flatnonzero(bad)[0])})")
        return points

    def _check_kind(self, kind):
        if needs_convex(kind) and not self.convex:
            raise non_convex_error(self._violation)
        if not self.convex and self.dimension > 3:
            raise CageError("non_convex", "mean value coordinates on non-convex cages are "
                                          "implemented for 2D and 3D cages only")

    def _worker_count(self, workers, count, pairs_per_point):
        if workers is not None:
            if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
                raise ValueError(f"workers must be a positive integer or None, got {workers!r}")
            return int(workers)
        if self._pool is not None and not self._pool.closed:
            return self._pool.size
        wanted = max(1, min(available_cores(), count * pairs_per_point // _PAIRS_PER_WORKER))
        if wanted > 1:
            try:
                python_executable()
            except WorkerError:  # an embedding without a Python to start: compute here
                return 1
        return wanted

    def _evaluate(self, points, kind, outside, normalise, progress, dtype, workers):
        self._check_kind(kind)
        points = self._points(points)
        cage = self._prepared
        if self._terms is None:
            self._terms = evaluation_terms(cage)
        count = len(points)
        chunk = chunk_size(cage)
        job = dict(kind=kind, outside=outside, normalise=normalise, convex=self.convex,
                   absolute=self.tolerance * self.size, chunk=chunk)
        workers = self._worker_count(workers, count, len(cage.topology.faces))
        if workers > 1:
            result, location = self._run_in_workers(points, job, chunk, progress, workers, None, dtype)
        else:
            result = np.empty((count, len(cage.vertices)), dtype=dtype)
            location = np.empty(count, dtype=np.int8)
            keep_freed_memory_for_reuse()
            raising = False
            for start in range(0, count, chunk):
                rows = slice(start, min(start + chunk, count))
                if raising:  # only counting the outside points for the error
                    location[rows] = locate_rows(cage, points[rows], job["absolute"], self.convex)
                else:
                    location[rows] = evaluate_rows(cage, self._terms, points[rows], kind, self.convex,
                                                   job["absolute"], outside, normalise, result[rows])
                    raising = outside == "raise" and (location[rows] == OUTSIDE).any()
                if progress is not None:
                    progress(rows.stop / count)
        if outside == "raise" and (location == OUTSIDE).any():
            raise OutsideCageError(np.flatnonzero(location == OUTSIDE), count)
        return result, location

    def _run_in_workers(self, points, job, chunk, progress, workers, locations, dtype):
        """Compute ``job`` in worker processes: (result or None, locations)."""
        count = len(points)
        if self._pool is not None and (self._pool.closed or self._pool.size != workers):
            self.close()
        if self._pool is None:
            self._pool = WorkerPool(self.vertices, self.faces, workers)
        specs = {"points": (points.shape, np.float64), "locations": ((count,), np.int8)}
        if dtype is not None:
            specs["result"] = ((count, len(self.vertices)), dtype)
        shared = SharedArrays(specs)
        shared.arrays["points"][...] = points
        # Units of whole chunks (the same chunks as one process: bitwise the same rows).
        per_unit = chunk * max(1, -(-count // (chunk * workers * 8)))
        units = [(start, min(start + per_unit, count)) for start in range(0, count, per_unit)]
        report = None if progress is None else (lambda done: progress(done / count))
        self._pool.run(shared, job, units, report,
                       stop_early=lambda reply: job["outside"] == "raise" and reply[3] > 0)
        if locations is not None:
            locations[...] = shared.arrays["locations"]
        return shared.arrays.get("result"), shared.arrays["locations"]
