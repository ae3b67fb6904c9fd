"""Errors raised by the core, each naming what is wrong and where.

Every error is a ``ValueError`` so plain ``except ValueError`` callers keep working; the
attributes let a front end (the Blender add-on) phrase its own message or select the
offending elements.
"""

__all__ = ["CageError", "OutsideCageError", "WorkerError", "AccuracyWarning", "WorkerWarning"]


class CageError(ValueError):
    """The cage cannot be used for the requested coordinates.

    Attributes
    ----------
    problem : str
        One of ``"non_finite"``, ``"too_few_vertices"``, ``"bad_faces"``,
        ``"loose_vertices"``, ``"duplicate_vertices"``, ``"degenerate_facet"``, ``"open"``,
        ``"non_manifold"``, ``"inconsistent_orientation"``, ``"inward"``,
        ``"non_convex"``, ``"scale"`` (a size float64 cannot compute with), ``"flat"``
        (every vertex in one hyperplane), ``"transposed"`` (vertices given as (N, n)).
    faces : tuple of int
        Indices of the facets concerned (may be empty).
    vertices : tuple of int
        Indices of the vertices concerned (may be empty).
    """

    def __init__(self, problem, message, faces=(), vertices=()):
        super().__init__(message)
        self.problem = problem
        self.faces = tuple(int(f) for f in faces)
        self.vertices = tuple(int(v) for v in vertices)


class AccuracyWarning(UserWarning):
    """Results were computed but rounding may have spoilt them (the message says how much).

    Raised as a warning, not an error: ``warnings.simplefilter("error", AccuracyWarning)``
    turns it into one.
    """


class OutsideCageError(ValueError):
    """Some query points lie outside the cage (beyond the boundary tolerance).

    Attributes
    ----------
    indices : (j,) int ndarray
        Indices of every outside point, ascending.
    """

    def __init__(self, indices, total):
        self.indices = indices
        count = len(indices)
        first = ", ".join(str(int(i)) for i in indices[:5])
        more = ", ..." if count > 5 else ""
        super().__init__(
            f"{count} of {total} points lie outside the cage (first: {first}{more}); "
            "pass outside='project' to use the nearest boundary point or "
            "outside='extrapolate' to evaluate the formula there"
        )


class WorkerError(RuntimeError):
    """A worker process could not start, failed or was killed (its message says which and
    what to do). Raised only for an explicit ``workers=N``; with ``workers=None`` the call
    is computed in the calling process instead, with a :class:`WorkerWarning`.

    The call that used it has stopped its other workers and removed its shared memory.
    """


class WorkerWarning(UserWarning):
    """Worker processes could not start or failed, so the call was computed in the
    calling process instead (the message says why). The result is the same; a
    :class:`gencoords.Cage` that warned computes its later automatic calls in-process too.
    ``warnings.simplefilter("ignore", WorkerWarning)`` silences it.
    """
