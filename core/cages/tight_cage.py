"""Tight (non-convex) cages around a mesh: pushing a cage out until it encloses every
point, and the checks such a cage must pass (the surface's measures are in
:mod:`gencoords.cages.surface`, its volume against the mesh's in
:mod:`gencoords.cages.volumes`).

A cage made by offsetting and simplifying a mesh's surface (the Blender add-on uses a
voxel remesh and a decimation) hugs the mesh but need not enclose it: simplification
cuts chords across convex parts. :func:`enclose` finds the points the cage leaves out
(winding numbers, so any closed cage, convex or not), moves the faces nearest to them
outward along the vertex normals by the distance they miss plus a clearance, and
checks again, a bounded number of times. :func:`fit_tight_cage` then requires what a
cage needs to bind: closed, manifold (at edges and at vertices: :func:`gencoords.cages.surface.pinched_vertices`),
outward, no self-intersection (:mod:`gencoords.cages.self_intersection`), every point
strictly inside.
"""

import numpy as np

from ..base.errors import CageError
from ..base.simplex import closest_points_on_simplices
from ..construction.boundary import INSIDE
from ..construction.validation import validate_cage
from ..evaluation.barycentric import point_locations
from .self_intersection import self_intersections
from .surface import cage_triangles, pinched_vertices, vertex_normals

__all__ = ["TightCageError", "outward_pushes", "enclose", "enclose_steps", "fit_tight_cage",
           "fit_tight_cage_steps"]

PUSH_ITERATIONS = 16  # push-outs before giving up
_PAIR_BLOCK = 1 << 18  # (point, triangle) pairs per block when finding nearest triangles
_SMALLEST_COSINE = 0.5  # a vertex moves at most twice what a face next to it needs
_NEIGHBOUR_SHARE = 0.5  # of a vertex's push, its neighbours move at least this
PUSHING = 0.8  # of a fit's progress, the push-outs' share; the checks take the rest


class TightCageError(ValueError):
    """The cage cannot be made tight: ``problem`` names why ("outside",
    "self_intersecting", ...), ``cause`` says what happened and ``advice`` what to change
    (the message: both)."""

    def __init__(self, problem, cause, advice):
        super().__init__(f"{cause}: {advice}")
        self.problem, self.cause, self.advice = problem, cause, advice


def _nearest_triangles(vertices, triangles, points):
    """Index of the nearest triangle (m,) and the distance to it, for each point (q, 3)."""
    corners = vertices[triangles]
    nearest = np.empty(len(points), dtype=np.int64)
    distance = np.empty(len(points))
    rows = max(1, _PAIR_BLOCK // len(triangles))
    for start in range(0, len(points), rows):
        block = points[start:start + rows]
        _, _, found = closest_points_on_simplices(np.repeat(block, len(triangles), axis=0),
                                                  np.tile(corners, (len(block), 1, 1)))
        found = found.reshape(len(block), len(triangles))
        nearest[start:start + rows] = found.argmin(axis=1)
        distance[start:start + rows] = found.min(axis=1)
    return nearest, distance


def outward_pushes(vertices, triangles, points, clearance):
    """How far each cage vertex moves along its normal for the cage to pass ``clearance``
    beyond each of ``points`` (those it left out).

    Each point's nearest triangle must move out by the point's distance to it plus the
    clearance; a vertex moves by the most its triangles need, divided by the cosine
    between its normal and theirs (at least 0.5), so the triangles' planes move that far.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward.
    points : (q, 3) float
    clearance : float
        Absolute.

    Returns
    -------
    pushes : (n,) float64
        Non-negative distances along :func:`gencoords.cages.surface.vertex_normals`.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.tight_cage import outward_pushes
    >>> vertices, faces = octahedron()
    >>> pushes = outward_pushes(vertices, faces, [[2.0, 0.0, 0.0]], 0.5)
    >>> # 1 + 0.5 along the nearest face's normal is sqrt(3) times that along (1, 0, 0)
    >>> round(float(pushes[0]), 6), bool(np.isclose(pushes[0], 1.5 * np.sqrt(3.0)))
    (2.598076, True)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    pushes = np.zeros(len(vertices))
    if not len(points):
        return pushes
    nearest, distance = _nearest_triangles(vertices, triangles, points)
    need = np.zeros(len(triangles))
    np.maximum.at(need, nearest, distance + clearance)
    corners = vertices[triangles]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), np.finfo(float).tiny)
    normals = vertex_normals(vertices, triangles)
    for corner in range(3):
        cosine = np.einsum("mi,mi->m", normals[triangles[:, corner]], face)
        np.maximum.at(pushes, triangles[:, corner], need / np.maximum(cosine, _SMALLEST_COSINE))
    # Neighbours go half as far: a patch moves out, not a spike that tilts its faces away
    # from the points beside (slow to converge, and spikes cross other faces).
    spread = pushes.copy()
    for first, second in ((0, 1), (1, 2), (2, 0)):
        np.maximum.at(spread, triangles[:, first], _NEIGHBOUR_SHARE * pushes[triangles[:, second]])
        np.maximum.at(spread, triangles[:, second], _NEIGHBOUR_SHARE * pushes[triangles[:, first]])
    return spread


def enclose(vertices, triangles, points, clearance, tolerance, iterations=PUSH_ITERATIONS,
            workers=None, stored_as=np.float64, quads=None):
    """Push the cage out until every point is strictly inside it.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        A closed, outward cage (convex or not).
    points : (k, 3) float
    clearance : float
        Absolute: how far beyond a left-out point its face moves.
    tolerance : float
        Relative to the cage's size: points this close to the cage count as outside.
    iterations : int
        Push-outs tried before giving up.
    workers : int or None
        Worker processes for the winding numbers (``gencoords.point_locations``).
    stored_as : numpy float type
        What the cage's positions will be stored as (``np.float32`` in Blender): pushed
        positions are rounded to it before they are checked, so the check holds for what
        is stored.
    quads : (q, 4) int or None
        Quads of the cage beside its triangles, checked as :func:`gencoords.cages.surface.cage_triangles` splits
        them.

    Returns
    -------
    vertices : (n, 3) float64
        The pushed cage (values of ``stored_as``).
    pushes : int
        How many push-outs it took (0: it enclosed the points already).

    Raises
    ------
    TightCageError
        ``problem`` "outside": some points stay outside after ``iterations`` push-outs.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import icosphere
    >>> from gencoords.cages.tight_cage import enclose
    >>> points = icosphere(3)[0]  # on the unit sphere: the coarse sphere's faces cut chords
    >>> vertices, faces = icosphere(1)
    >>> pushed, pushes = enclose(vertices, faces, points, clearance=0.02, tolerance=1e-6)
    >>> where = gencoords.point_locations(points, pushed, faces, 1e-6)
    >>> pushes > 0, bool((where == gencoords.INSIDE).all())
    (True, True)
    """
    return _to_end(enclose_steps(vertices, triangles, points, clearance, tolerance, iterations, workers,
                                 stored_as, quads))


def enclose_steps(vertices, triangles, points, clearance, tolerance, iterations=PUSH_ITERATIONS,
                  workers=None, stored_as=np.float64, quads=None):
    """:func:`enclose` in steps: a generator yielding the fraction done after each push
    out (of ``iterations``) and returning what :func:`enclose` returns (``vertices, pushes
    = yield from enclose_steps(...)``); closed early, it stops there.

    Examples
    --------
    >>> from gencoords.cages.shapes import icosphere
    >>> from gencoords.cages.tight_cage import enclose_steps
    >>> steps = enclose_steps(*icosphere(1), icosphere(3)[0], clearance=0.02, tolerance=1e-6)
    >>> fractions = []
    >>> while True:
    ...     try:
    ...         fractions.append(next(steps))
    ...     except StopIteration as done:
    ...         pushed, pushes = done.value
    ...         break
    >>> len(fractions) == pushes > 0, 0.0 < fractions[0] < 1.0
    (True, True)
    """
    vertices = np.asarray(vertices, dtype=stored_as).astype(np.float64)
    points = np.asarray(points, dtype=np.float64)
    split = cage_triangles(vertices, triangles, quads)
    where = point_locations(points, vertices, split, tolerance, workers)
    pushes, checked_all = 0, True
    while True:
        left_out = where != INSIDE
        if not left_out.any():
            if checked_all:
                return vertices, pushes
            # The swept boxes decide up to the tolerance, which scales with the cage.
            where, checked_all = point_locations(points, vertices, split, tolerance, workers), True
            continue
        if pushes == iterations:
            raise TightCageError("outside", f"{int(left_out.sum())} mesh vertices stay outside "
                                            f"the cage after pushing it out {iterations} times",
                                 "raise the offset or the vertex count")
        pushes, checked_all = pushes + 1, False
        yield pushes / (iterations + 1)
        # Each push out overshoots more: a vertex pushed alone tilts its faces away from
        # the points beside the one it was pushed for.
        moves = outward_pushes(vertices, split, points[left_out], clearance * pushes)
        moved = vertices + moves[:, None] * vertex_normals(vertices, split)
        moved = moved.astype(stored_as).astype(np.float64)
        moved_split = cage_triangles(moved, triangles, quads)
        faces = (np.asarray(triangles, dtype=np.int64).reshape(-1, 3),
                 np.asarray(quads if quads is not None else [], dtype=np.int64).reshape(-1, 4))
        swept = _swept(points, vertices, moved, faces, moves > 0, tolerance)
        vertices, split = moved, moved_split
        where[swept] = point_locations(points[swept], vertices, split, tolerance, workers)


def _swept(points, before, after, faces, moved, tolerance):
    """Points (indices) whose winding number a move of the cage can change: those in the
    bounding box of a moved face's corners before and after (a face moving linearly stays
    in the convex hull of both, whichever diagonal splits a quad), widened by the tolerance."""
    low, high = [], []
    for face in faces:  # triangles, quads
        touched = face[moved[face].any(axis=1)]
        corners = np.concatenate([before[touched], after[touched]], axis=1)
        low.append(corners.min(axis=1))
        high.append(corners.max(axis=1))
    pad = 2.0 * tolerance * float(np.linalg.norm(np.ptp(after, axis=0)))
    low, high = np.concatenate(low) - pad, np.concatenate(high) + pad
    inside = np.zeros(len(points), dtype=bool)
    for start in range(0, len(low), 64):  # bounded memory: points x 64 boxes
        inside |= ((points[:, None] >= low[None, start:start + 64])
                   & (points[:, None] <= high[None, start:start + 64])).all(axis=2).any(axis=1)
    return np.flatnonzero(inside)


def fit_tight_cage(vertices, triangles, points, clearance, tolerance, iterations=PUSH_ITERATIONS,
                   workers=None, stored_as=np.float64, quads=None):
    """A cage from ``vertices`` and ``triangles`` that binds around ``points``: pushed out
    until it encloses them (:func:`enclose`), then checked.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        A closed, outward cage, usually an offset and simplified copy of the mesh.
    points : (k, 3) float
        The mesh's vertices, in the cage's space.
    clearance, tolerance, iterations, workers, stored_as, quads
        As for :func:`enclose`.

    Returns
    -------
    vertices : (n, 3) float64
    pushes : int

    Raises
    ------
    TightCageError
        ``problem`` "simplified": the cage given is not closed, manifold, outward, or has
        coinciding vertices or degenerate faces (the simplification spoilt it); "pushed":
        so after pushing; "outside": points stay outside; "pinched", "self_intersecting":
        the cage touches or passes through itself.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import icosphere
    >>> from gencoords.cages.tight_cage import TightCageError, fit_tight_cage
    >>> vertices, faces = icosphere(1)
    >>> fitted, pushes = fit_tight_cage(vertices, faces, 0.5 * vertices, 0.01, 1e-6)
    >>> pushes, bool(np.array_equal(fitted, vertices))  # enclosing already
    (0, True)
    >>> twice = np.concatenate([vertices, vertices + [0.93, 0.11, 0.07]])
    >>> try:
    ...     fit_tight_cage(twice, np.concatenate([faces, faces + len(vertices)]), [[0.5, 0.0, 0.0]], 0.01, 1e-6)
    ... except TightCageError as error:
    ...     print(error.problem)
    self_intersecting
    """
    return _to_end(fit_tight_cage_steps(vertices, triangles, points, clearance, tolerance, iterations,
                                        workers, stored_as, quads))


def fit_tight_cage_steps(vertices, triangles, points, clearance, tolerance, iterations=PUSH_ITERATIONS,
                         workers=None, stored_as=np.float64, quads=None):
    """:func:`fit_tight_cage` in steps: a generator yielding the fraction done (pushes,
    then the checks) and returning what :func:`fit_tight_cage` returns; closed early, it
    stops there. A modal operator shows its progress and takes Esc between steps.

    Examples
    --------
    >>> from gencoords.cages.shapes import icosphere
    >>> from gencoords.cages.tight_cage import fit_tight_cage_steps
    >>> vertices, faces = icosphere(1)
    >>> steps = fit_tight_cage_steps(vertices, faces, 0.5 * vertices, 0.01, 1e-6)
    >>> next(steps), next(steps)  # started; the checks after no push-out
    (0.0, 0.8)
    >>> steps.close()  # cancelled: nothing more is computed
    """
    try:  # what the remesh and the decimation made, before any push
        validate_cage(vertices, cage_triangles(vertices, triangles, quads), convex=False, tolerance=tolerance)
    except CageError as error:
        raise TightCageError("simplified", f"simplifying the offset surface to {len(vertices)} vertices "
                                           f"spoiled it ({error.problem.replace('_', ' ')}, {_where(error)})",
                             "raise the vertex count, or change the offset a little") from None
    yield 0.0
    pushing = enclose_steps(vertices, triangles, points, clearance, tolerance, iterations, workers, stored_as,
                            quads)
    vertices, pushes = yield from _scaled(pushing, PUSHING)
    triangles = cage_triangles(vertices, triangles, quads)
    try:
        validate_cage(vertices, triangles, convex=False, tolerance=tolerance)
    except CageError as error:
        raise TightCageError("pushed", f"pushing the cage out to enclose the mesh spoiled it ({error})",
                             "raise the offset or the vertex count") from None
    yield PUSHING
    pinched = pinched_vertices(triangles)
    if len(pinched):
        raise TightCageError("pinched", f"the cage touches itself at {len(pinched)} vertices (first: "
                                        f"vertex {pinched[0]}), where parts of the mesh are closer "
                                        "than twice the offset", "lower the offset or raise the vertex count")
    yield PUSHING
    crossing = self_intersections(vertices, triangles, tolerance)
    if len(crossing):
        raise TightCageError("self_intersecting", f"the cage passes through itself ({len(crossing)} "
                                                  "pairs of faces cross, where parts of the mesh are "
                                                  "closer than twice the offset)",
                             "lower the offset or raise the vertex count")
    return vertices, pushes


def _where(error):
    """Where a ``CageError`` found its problem, in words."""
    if error.vertices:
        return f"at its vertices {', '.join(map(str, error.vertices[:4]))}"
    return f"at its faces {', '.join(map(str, error.faces[:4]))}" if error.faces else "somewhere"


def _to_end(steps):
    """The result of a generator of steps, run to its end."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def _scaled(steps, share):
    """``steps``' fractions times ``share``; returns its result."""
    while True:
        try:
            fraction = next(steps)
        except StopIteration as done:
            return done.value
        yield share * fraction
