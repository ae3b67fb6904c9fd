"""A cage validated and prepared once, for any number of coordinate computations.

``gencoords.coordinates(points, vertices, faces, ...)`` and the other free functions build
a :class:`Cage` per call; a caller with several batches of points (the add-on's Bind,
an animation tool) keeps one, and with it everything that depends only on the cage:
the validation, the per-facet and per-ridge polynomials, and the worker processes.
"""

import warnings

import numpy as np

from ..base import tolerances
from ..construction.boundary import BOUNDARY, OUTSIDE, outside_points
from ..construction.general import point_frame
from ..base.errors import AccuracyWarning, CageError, OutsideCageError, WorkerError
from .rows import chunk_size, evaluate_rows, evaluation_terms, keep_freed_memory_for_reuse, locate_rows
from ..surfaces.named import CONVEX_ONLY_KINDS, HARMONIC, MEAN_VALUE, kind_parameter, named_ridge_scalars
from ..base.inputs import checked
from ..base.parameters import OUTSIDE_MODES
from .interpreters import available_cores, python_executable
from .parallel import WorkerPool, computed_here_instead, dispatch_units
from .shared_memory import SharedArrays
from ..construction.green import GREEN, GreenOutsideError, green_chunk_size
from ..construction.units import length_degree, to_world
from ..construction.validation import DEFAULT_TOLERANCE, convexity_violation, non_convex_error, validate_cage

__all__ = ["Cage", "OUTSIDE_MODES", "needs_convex"]

# With workers=None, processes start only for calls long enough to repay starting them
# (about 0.2 s each: a Python importing numpy): one worker per this many (point, facet)
# pairs, about half a second of work at the 75 ns a pair mean value takes with point
# location (the character, 43k points in 388 triangles: 1.7 s in one process, 1.2 s in two).
_PAIRS_PER_WORKER = 6 << 20


@checked
def needs_convex(kind):
    """Whether coordinates of ``kind`` require a convex cage (all but mean value).

    Examples
    --------
    >>> import gencoords
    >>> gencoords.needs_convex("wachspress"), gencoords.needs_convex("mean_value")
    (True, False)
    """
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
    next call; ``close()`` (or ``with gencoords.Cage(...) as cage:``) stops them, as does
    garbage collection and interpreter exit. Where automatic workers (``workers=None``)
    cannot start or fail, the call is computed in this process with a
    :class:`gencoords.WorkerWarning`, and so are this cage's later automatic calls.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> with gencoords.Cage(square, edges) as cage:  # validated once, workers kept
    ...     b = cage.coordinates([[0.5, 0.5]], kind="mean_value")
    >>> print(b.round(3))
    [[0.25 0.25 0.25 0.25]]
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
        self._workers_failed = False  # automatic counts then stay in this process
        self._fields = {}  # harmonic coordinates' solved grids, by resolution

    @property
    def dimension(self):
        """N: int."""
        return self.vertices.shape[1]

    @property
    def size(self):
        """The bounding-box diagonal that tolerances are relative to: float."""
        return self._prepared.size * self._prepared.scale

    @property
    def topology_ridges(self):
        """The ridges' vertex indices, as :func:`gencoords.advanced.ridges`: (r, N-1) int."""
        return self._prepared.topology.ridges

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

    @checked
    def suggested_workers(self, point_count):
        """Worker processes that ``workers=None`` would use for this many points: int.

        For callers splitting a long computation into calls of their own (to show
        progress, or to turn each batch into something smaller at once), who should
        choose once, for the whole job.
        """
        return self._worker_count(None, point_count, len(self.faces))

    # -- the public computations -------------------------------------------------------

    @checked
    def coordinates(self, points, kind=MEAN_VALUE, outside="raise", progress=None,
                    dtype=np.float64, locations=None, workers=None, gamma=None, resolution=None):
        """Generalized barycentric coordinates of points (see :func:`gencoords.coordinates`).

        Parameters
        ----------
        points : (k, N) float
        kind, outside, progress, dtype, locations, gamma, resolution
            As :func:`gencoords.coordinates` (harmonic coordinates' grid is solved on the
            first call at a resolution and kept for the next).
        workers : int or None
            Processes to compute in. ``1``: this process only. ``None``: as many as
            the cores this process may use, for calls long enough to repay starting
            them (about half a second of work per worker), else this process; where
            they cannot start or fail, this process (a :class:`gencoords.WorkerWarning`;
            an explicit count raises :class:`gencoords.WorkerError` instead). The result
            is bitwise the same whatever the number.

        Returns
        -------
        coordinates : (k, n) dtype
        """
        if kind == HARMONIC or resolution is not None:
            return self._harmonic(points, kind, outside, progress, dtype, locations, workers, gamma, resolution)
        result, where = self._evaluate(points, kind, outside, True, progress, dtype, workers, gamma)
        if kind == MEAN_VALUE and outside == "extrapolate":
            self._warn_if_flat_extrapolation(points, result, where)
        if locations is not None:
            locations[...] = where
        return result

    @checked
    def green_coordinates(self, points, outside="raise", progress=None, dtype=np.float64, locations=None,
                          workers=None):
        """Green coordinates of points (see :func:`gencoords.green_coordinates`): 3D cages.

        Parameters
        ----------
        points : (k, 3) float
        outside, progress, dtype, locations, workers
            As :meth:`coordinates`; ``outside`` is ``"raise"`` or ``"project"``.

        Returns
        -------
        phi : (k, n) dtype
        psi : (k, m) dtype
            Views of one (k, n + m) array.
        """
        if self.dimension != 3:
            raise CageError("bad_faces", f"Green coordinates need a 3D triangle cage, got a "
                                         f"{self.dimension}D one")
        if outside == "extrapolate":
            raise ValueError("Green coordinates do not extrapolate outside the cage (their identity "
                             "holds only inside); use outside='raise' or outside='project'")
        result, where = self._evaluate(points, GREEN, outside, True, progress, dtype, workers)
        if locations is not None:
            locations[...] = where
        return result[:, :len(self.vertices)], result[:, len(self.vertices):]

    @checked
    def weights(self, points, kind=MEAN_VALUE, workers=None, gamma=None, resolution=None):
        """Homogeneous weights of a named kind (see :func:`gencoords.weights`): (k, n) float."""
        if kind == HARMONIC or resolution is not None:  # their coordinates: no formula outside
            return self._harmonic(points, kind, "raise", None, np.float64, None, workers, gamma, resolution)
        gamma = kind_parameter(kind, gamma)
        values, where = self._evaluate(points, kind, "extrapolate", False, None, np.dtype(np.float64),
                                       workers, gamma)
        # The frame's weights in world units (boundary rows, limit coordinates, have none).
        formula = where != BOUNDARY
        values[formula] = to_world(values[formula], self._prepared.scale,
                                   length_degree(kind, self.dimension, gamma) - 1, "weights")
        return values

    @checked
    def ridge_scalars(self, points, kind, gamma=None):
        """Ridge scalars d of a named generating surface (see :func:`gencoords.advanced.ridge_scalars`):
        (k, r) float."""
        gamma = kind_parameter(kind, gamma)
        d = named_ridge_scalars(kind, point_frame(self._prepared, points), gamma).T
        return to_world(d, self._prepared.scale, length_degree(kind, self.dimension, gamma),
                        "ridge scalars")

    @checked
    def point_locations(self, points, workers=None):
        """1 inside, 0 on the boundary (within the tolerance), -1 outside: (k,) int8."""
        locations = np.empty(len(points), dtype=np.int8)
        absolute = self.tolerance * self._prepared.size  # in the frame, as the distances
        chunk = chunk_size(self._prepared, locate_only=True, convex=self.convex)
        # Locating costs a few times less per pair than coordinates.
        count = self._worker_count(workers, len(points), len(self.faces) // 4 + 1)
        if count > 1:
            job = dict(chunk=chunk, absolute=absolute, convex=self.convex, outside="extrapolate")
            try:
                self._run_in_workers(points, job, chunk, None, count, locations, None)
                return locations
            except WorkerError as error:
                self._fall_back_or_raise(workers, error)
        for start in range(0, len(points), chunk):
            rows = slice(start, start + chunk)
            locations[rows] = locate_rows(self._prepared, points[rows], absolute, self.convex)
        return locations

    def outside_points(self, points, inside=None):
        """The points ``outside="raise"`` refuses (outside beyond the tolerance), found
        without their coordinates or those of the others, at a small part of their cost:
        (o,) int indices, ascending; ``inside`` ((k,) bool) filled as ``boundary.outside_points``'."""
        return outside_points(self._prepared, np.asarray(points, dtype=np.float64),
                              self.tolerance * self._prepared.size, self.convex, inside)

    # -- shared machinery ----------------------------------------------------------------

    def _harmonic(self, points, kind, outside, progress, dtype, locations, workers, gamma, resolution):
        """Harmonic coordinates of ``points`` ((k, n) dtype), looked up in this cage's
        grid at ``resolution`` (solved on first use: ``gencoords.harmonic_field``)."""
        from ..harmonic.field import DEFAULT_RESOLUTION
        from ..harmonic.grid_field import harmonic_field
        if kind != HARMONIC:
            raise ValueError(f"resolution applies to kind={HARMONIC!r} only, not {kind!r}")
        kind_parameter(kind, gamma)  # refuses a gamma
        if outside == "extrapolate":
            raise ValueError("harmonic coordinates do not extrapolate outside the cage (they are solved "
                             "inside it); use outside='raise' or outside='project'")
        resolution = DEFAULT_RESOLUTION if resolution is None else resolution
        if resolution not in self._fields:
            self._fields[resolution] = harmonic_field(self.vertices, self.faces, resolution, self.tolerance,
                                                      progress, workers)
        result = self._fields[resolution].coordinates(points, outside, dtype)
        if locations is not None:
            locations[...] = self.point_locations(points, workers)
        return result

    def _check_kind(self, kind):
        if needs_convex(kind) and not self.convex:
            raise non_convex_error(self._violation)
        if not self.convex and self.dimension > 3:
            raise CageError("non_convex", "mean value coordinates on non-convex cages are "
                                          "implemented for 2D and 3D cages only")

    def _worker_count(self, workers, count, pairs_per_point):
        if workers is not None:
            return workers
        if self._workers_failed:
            return 1
        if self._pool is not None and not self._pool.closed:
            return self._pool.size
        wanted = max(1, min(available_cores(), count * pairs_per_point // _PAIRS_PER_WORKER))
        if wanted > 1:
            try:
                python_executable()
            except WorkerError:  # an embedding without a Python to start: compute here
                return 1
        return wanted

    def _evaluate(self, points, kind, outside, normalise, progress, dtype, workers, gamma=None):
        """(k, columns) results and (k,) locations: coordinates (n columns) or Green's
        phi and psi (kind GREEN, n + m columns), here or in workers."""
        green = kind == GREEN
        if not green:
            self._check_kind(kind)
            gamma = kind_parameter(kind, gamma)
        cage = self._prepared
        if self._terms is None:
            self._terms = evaluation_terms(cage)
        count = len(points)
        chunk = green_chunk_size(cage) if green else chunk_size(cage)
        columns = len(cage.vertices) + (len(cage.topology.faces) if green else 0)
        job = dict(kind=kind, gamma=gamma, outside=outside, normalise=normalise, convex=self.convex,
                   absolute=self.tolerance * cage.size, chunk=chunk)
        chosen = self._worker_count(workers, count, len(cage.topology.faces))
        in_workers = chosen > 1
        if in_workers:
            try:
                result, location = self._run_in_workers(points, job, chunk, progress, chosen, None, dtype,
                                                        columns)
            except WorkerError as error:
                self._fall_back_or_raise(workers, error)
                in_workers = False
        if not in_workers:  # progress starts again from 0 after a fall-back
            result = np.empty((count, columns), dtype=dtype)
            location = np.empty(count, dtype=np.int8)
            keep_freed_memory_for_reuse()
            raising = False
            for start in range(0, count, chunk):
                rows = slice(start, min(start + chunk, count))
                if raising:  # only counting the outside points for the error
                    location[rows] = locate_rows(cage, points[rows], job["absolute"], self.convex)
                else:
                    location[rows] = evaluate_rows(cage, self._terms, points[rows], kind, self.convex,
                                                   job["absolute"], outside, normalise, result[rows],
                                                   gamma)
                    raising = outside == "raise" and (location[rows] == OUTSIDE).any()
                if progress is not None:
                    progress(rows.stop / count)
        if outside == "raise" and (location == OUTSIDE).any():
            raise (GreenOutsideError if green else OutsideCageError)(np.flatnonzero(location == OUTSIDE), count)
        return result, location

    def _fall_back_or_raise(self, workers, error):
        """After a WorkerError: raise it for an explicit count; for an automatic one warn,
        and compute this call and the later automatic ones in this process."""
        if workers is not None:
            raise error
        self.close()
        self._workers_failed = True
        computed_here_instead(error)

    def _warn_if_flat_extrapolation(self, points, result, where):
        """AccuracyWarning when mean value extrapolation outside a near-flat cage lost accuracy.

        The solid angles of a thin cage seen from outside nearly cancel. Coordinates are
        invariant under scaling both the cage and the points, so evaluating the outside
        points again on a copy scaled by a non-dyadic factor changes only the rounding:
        the gap estimates the error (1:1:1e-6 icosphere: estimate 5e4, error 9e4).
        """
        outside_rows = np.flatnonzero(where == OUTSIDE)
        centred = self._prepared.vertices - self._prepared.vertices.mean(axis=0)
        extent = np.linalg.svd(centred, compute_uv=False)
        if not len(outside_rows) or extent[-1] > tolerances.FLAT * extent[0]:
            return
        factor = 1.0 + 1.0 / 3.0
        twin = Cage(self.vertices * factor, self.faces, self.tolerance)
        again, _ = twin._evaluate(points[outside_rows] * factor, MEAN_VALUE, "extrapolate", True,
                                  None, np.dtype(np.float64), 1)
        error = float(np.abs(again - result[outside_rows]).max())
        if error > tolerances.ACCURACY:
            warnings.warn(f"mean value coordinates extrapolated outside this thin cage (thickness "
                          f"{extent[-1] / extent[0]:.1e} of its extent) are accurate only to about "
                          f"{error:.1e} (estimated; {len(outside_rows)} outside points); use "
                          "outside='project', or a thicker cage", AccuracyWarning, stacklevel=4)

    def _run_in_workers(self, points, job, chunk, progress, workers, locations, dtype, columns=None):
        """Compute ``job`` in worker processes: (result or None, locations); the result
        has ``columns`` columns (default n)."""
        count = len(points)
        if self._pool is not None and (self._pool.closed or self._pool.size != workers):
            self.close()
        if self._pool is None:
            self._pool = WorkerPool(self.vertices, self.faces, workers)
        specs = {"points": (points.shape, np.float64), "locations": ((count,), np.int8)}
        if dtype is not None:
            specs["result"] = ((count, columns or len(self.vertices)), dtype)
        shared = SharedArrays(specs, reserved_by_writers=("result",) if dtype is not None else ())
        shared.arrays["points"][...] = points
        # Units of whole chunks (the same chunks as one process: bitwise the same rows).
        units = dispatch_units(count, chunk, workers)
        report = None if progress is None else (lambda done: progress(done / count))
        self._pool.run(shared, job, units, report,
                       stop_early=lambda reply: job["outside"] == "raise" and reply[3] > 0)
        if locations is not None:
            locations[...] = shared.arrays["locations"]
        return shared.arrays.get("result"), shared.arrays["locations"]
