"""Bind planning: a mesh's coordinates in a cage, the storage they are written in, and the
figures measured on what will be written. No Blender: the add-on reads the scene, runs
:func:`plan_bind` and writes the :class:`~gencoords.planning.request.BindPlan` it returns.

A plan is computed chunk by chunk: :func:`plan_bind` is a generator yielding the fraction
done (0 to 1), so a front end can show progress and cancel between chunks (closing the
generator stops the worker processes), and returning the plan. Every decision is a
return value of :mod:`.storage_choice`; the slots and figures come from :mod:`.figures`,
each storage's encoding and byte count from its module in ``gencoords.storage``.

Harmonic coordinates are solved once on a grid (``gencoords.harmonic_field``) and looked
up (``figures.solve_points``); in sparse storage, their default, they are written in two
levels (:func:`_plan_two_level`: each vertex its 8 interpolating grid nodes, each node its
own pairs over the cage, ``storage.two_level.two_level_layout``), or, where Automatic
estimates them faster to play back (:func:`_harmonic_sparse`), each vertex its own pairs.
Sparse storage of any other kind keeps each vertex's K largest coordinates
(``storage.sparse``): Automatic chooses it, with the fewest K whose deviations stay under
``AUTO_DEVIATION``, before compact storage.
"""

import threading
from dataclasses import replace

import numpy as np

from ..base.errors import OutsideCageError
from ..base.grid import fit_grid
from ..base.tolerances import LINEAR_PRECISION, ROUNDING_AMPLIFICATION, TRANSLATION_PRECISION
from ..construction.boundary import OUTSIDE
from ..construction.green import GreenOutsideError
from ..construction.quad_cage import validate_polygons
from ..evaluation.cage import Cage
from ..harmonic import harmonic_field, harmonic_quad_field
from ..harmonic.cage_features import AUTOMATIC_FLOOR, automatic_resolution
from ..harmonic.memory import available_memory, field_bytes, fitting_resolution, release_freed_memory
from ..storage import Storage, sparse, two_level
from ..storage.codecs import plan_codec
from . import figures
from .similarity import similarity_deviation
from .request import (BIND_SOLVER_TOLERANCE, BindPlan, GridMemoryError, ImpreciseCoordinatesError,
                      BindRequest, UndefinedCoordinatesError)  # noqa: F401  (the add-on's names for them)
from .storage_choice import (AUTO_DEVIATION, choose_by_estimate, choose_by_measuring, choose_by_playback,
                             confirm_compact, coordinate_rows, first_choice, short_number)

__all__ = ["plan_bind", "plan_bytes"]

DEVIATION_SAMPLES = 2000  # mesh vertices Automatic chooses compact storage's slots on
# Mesh vertices Automatic first estimates on: enough to see a cage where compact storage
# cannot save anything, and cheap next to the Bind (the coordinates of a few points and
# one deviation), so it does not measure slots it would throw away.
ESTIMATE_SAMPLES = 128
# While a long computation runs beside the caller, how often it hears of its progress.
POLL_SECONDS = 0.05
# A harmonic grid of fewer (grid node, cage vertex) pairs than this, and fewer nodes than
# INLINE_FIELD_NODES, is solved in the caller's thread, without progress (0.2 s for the
# character at 48 cells: 24,480 nodes, 4.8M pairs). A thread of its own would leave its
# arrays in an allocator arena of its own: 10 MB more resident at the character's Bind.
# Some of the field's work grows with the nodes alone (an 8-vertex box at 96 cells,
# 970,299 nodes: many seconds), hence both bounds.
INLINE_FIELD_PAIRS, INLINE_FIELD_NODES = 1 << 23, 1 << 16


class _Cancelled(Exception):
    """Raised in a computation's progress callback once its Bind was cancelled."""


def _beside(compute, share):
    """``compute(progress)`` in a thread beside the caller: a generator yielding the
    fraction done (``share`` of it at the end) every POLL_SECONDS while it runs, and
    returning its result (or raising its error).

    One call that takes long (the harmonic solve: half a minute at a million vertices)
    thus lets a modal Bind show progress and take Esc between the yields: closing the
    generator makes the next progress call raise, and waits for the thread to end. The
    core is numpy only, whose large operations release the interpreter lock."""
    state = {"fraction": 0.0, "cancelled": False}

    def progress(fraction):
        if state["cancelled"]:
            raise _Cancelled
        state["fraction"] = fraction

    def run():
        try:
            state["result"] = compute(progress)
        except BaseException as error:  # re-raised in the caller
            state["error"] = error

    release_freed_memory()  # the caller's freed blocks, before the thread's own arena grows
    thread = threading.Thread(target=run, name="gencoords-bind", daemon=True)
    thread.start()
    try:
        while thread.is_alive():
            thread.join(POLL_SECONDS)
            if thread.is_alive():
                yield share * state["fraction"]
    finally:
        if thread.is_alive():  # closed early: a cancel, whose traceback would hold the solve's arrays
            state["cancelled"] = True
            thread.join()
            state.pop("error", None)
        release_freed_memory()  # the thread's, before the caller's arena grows again
    if "error" in state:
        raise state["error"]
    return state["result"]


def plan_bytes(plan):
    """Bytes of the attributes ``plan`` writes, as its storage counts them
    (``gencoords.storage.codecs.plan_codec``: exact, compact, sparse or two levels).

    Examples
    --------
    >>> from gencoords.planning.bind_plan import plan_bind, plan_bytes
    >>> from gencoords.planning.request import BindRequest
    >>> from gencoords.storage import Storage
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> steps = plan_bind(0.5 * vertices, vertices, faces, BindRequest("mean_value", storage=Storage.SPARSE,
    ...                                                                sparse_size=4, workers=1))
    >>> plan = list(steps) and None
    """
    return plan_codec(plan).plan_bytes(plan)


def plan_bind(points, cage_vertices, triangles, request):
    """Plan the Bind of ``points`` to a cage: a generator yielding the fraction done and
    returning the :class:`BindPlan` (``plan = yield from plan_bind(...)``).

    Parameters
    ----------
    points : (k, 3) float64
        The mesh's vertices, in the cage's space.
    cage_vertices : (n, 3) float64
    triangles : (m, 3) int
        The cage's triangles, outward.
    request : BindRequest

    Raises the core's errors (ValueError: ``CageError``, ``OutsideCageError``,
    ``UndefinedCoordinatesError``; ``ImpreciseCoordinatesError`` once the coordinates as
    stored fail ``LINEAR_PRECISION`` or ``TRANSLATION_PRECISION``) on the first step or
    where they arise. Closing the
    generator early (a cancel) stops the worker processes.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.planning.bind_plan import plan_bind
    >>> from gencoords.planning.request import BindRequest
    >>> from gencoords.storage import Storage
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(2)
    >>> points = 0.5 * vertices
    >>> steps = plan_bind(points, vertices, faces, BindRequest("mean_value", storage=Storage.COMPACT,
    ...                                                         compact_size=12, workers=1))
    >>> fraction = next(steps)  # the first chunk: the cage is checked, the storage chosen
    >>> steps.close()  # a cancel: nothing more is computed
    """
    if request.polygons is not None:  # a folded quad named as the cage's face, before its split is checked
        validate_polygons(cage_vertices, request.polygons, request.tolerance)
    cage = Cage(cage_vertices, triangles, tolerance=request.tolerance)
    try:
        if request.harmonic:
            request = with_grid(cage.vertices, cage.faces, request)
            plan = yield from _plan(points, cage, request)
            return replace(plan, resolution=request.resolution)
        return (yield from _plan(points, cage, request))
    finally:
        cage.close()


def with_grid(cage_vertices, triangles, request):
    """``request`` with its harmonic grid chosen: an automatic one (``resolution`` None)
    of the floor's cells where the memory allows them, and for either what the grid meets
    (``grid``, a ``GridChoice``: the narrowest gap and thinnest part in cells).

    Examples
    --------
    >>> from gencoords.planning.bind_plan import with_grid
    >>> from gencoords.planning.request import BindRequest
    >>> from gencoords.cages.shapes import icosphere
    >>> with_grid(*icosphere(1), BindRequest("harmonic")).resolution  # nothing narrow: the floor
    48
    >>> with_grid(*icosphere(1), BindRequest("harmonic", resolution=20)).grid.resolution
    20
    """
    if request.resolution is None:
        budget = available_memory() if request.memory_budget is None else request.memory_budget
        # A budget no grid fits leaves the floor, which check_grid_memory then refuses.
        ceiling = fitting_resolution(cage_vertices, triangles, AUTOMATIC_FLOOR, budget) or AUTOMATIC_FLOOR
        grid = automatic_resolution(cage_vertices, triangles, ceiling=ceiling)
    else:
        grid = automatic_resolution(cage_vertices, triangles, ceiling=request.resolution, floor=request.resolution)
    return replace(request, resolution=grid.resolution, grid=grid)


def check_grid_memory(cage_vertices, triangles, request):
    """Refuse a harmonic grid that would not fit in memory, before it is solved:
    GridMemoryError with the estimate and the finest resolution that fits.

    Examples
    --------
    >>> from gencoords.planning.bind_plan import check_grid_memory
    >>> from gencoords.planning.request import BindRequest, GridMemoryError
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(2)
    >>> check_grid_memory(vertices, faces, BindRequest("harmonic", resolution=16, memory_budget=1 << 30))
    >>> try:
    ...     check_grid_memory(vertices, faces, BindRequest("harmonic", resolution=512, memory_budget=1 << 30))
    ... except GridMemoryError as error:
    ...     error.resolution
    71
    """
    budget = available_memory() if request.memory_budget is None else request.memory_budget
    needed = field_bytes(cage_vertices, triangles, request.resolution)
    if needed > budget:
        raise GridMemoryError(needed, budget, fitting_resolution(cage_vertices, triangles, request.resolution, budget),
                              request.resolution)


def _solved_field(cage, request):
    """The cage's harmonic field (a generator, as :func:`_beside`): solved in the caller's
    thread when short, else beside it with progress."""
    check_grid_memory(cage.vertices, cage.faces, request)

    def solve(progress):
        # Given the cage's polygons, each quad is its bilinear patch (harmonic_quad_field).
        solver, faces = ((harmonic_field, cage.faces) if request.polygons is None
                         else (harmonic_quad_field, request.polygons))
        return request.run(lambda count: solver(
            cage.vertices, faces, resolution=request.resolution, tolerance=request.tolerance,
            progress=progress, workers=count, solver_tolerance=BIND_SOLVER_TOLERANCE), request.workers)

    nodes = int(np.prod(fit_grid(cage.vertices, request.resolution).shape))
    short = nodes < INLINE_FIELD_NODES and nodes * len(cage.vertices) < INLINE_FIELD_PAIRS
    return solve(None) if short else (yield from _beside(solve, 0.5))


def _harmonic_sparse(points, cage, request, solved, inside):
    """Harmonic coordinates in sparse storage: the two-level plan, as a function making
    it (None where there would be more nodes than points), Automatic's per-vertex pairs
    where they play back faster than that plan, or than exact storage without one
    (``choose_by_playback``; else None), and the field where those pairs need it (else
    None). Where the pairs play back faster than two levels with their fewest pairs per
    node, the plan is made only if the pairs miss on the whole mesh (the cape: a third
    of its Bind saved).

    The field comes in the list ``solved`` (taken out of it), so that it is freed before
    the layout where no pairs are chosen: the rows hold what the layout needs (the hand's
    and the quadruped's Bind peaked 7 and 14 MB higher with the field kept)."""
    field, count = solved.pop(), len(points)
    automatic = request.storage == Storage.AUTO
    # Every point located once, by the rows: the field keeps them, for the sample (every
    # few of them) and the pairs' or exact storage's writing.
    rows = _two_level_rows(points, request, field, inside)
    sampled = (figures.solve_points(request, cage, points[::max(1, count // DEVIATION_SAMPLES)], None, field=field)
               if automatic else None)
    report = figures.kind_report(request, cage, field)
    pairs = counts = None
    if automatic:
        # What two levels cost with their most pairs per node, or exact storage (about a
        # gather's time per multiply-add: the cup) without them, bounds what pairs must beat.
        counts = None if rows is None else two_level.automatic_node_slot_counts(count, len(rows[2]), len(cage.vertices))
        budget = (sparse.playback_seconds(count * len(cage.vertices), 0) if rows is None
                  else two_level.playback_seconds(count, len(rows[2]), counts[-1]))
        pairs = choose_by_playback(sampled, cage.vertices, count, budget)
    if rows is None:  # the field gives every point's coordinates (pairs, or exact storage)
        return None, pairs, field
    if pairs is None:
        del field  # its grid's coordinates are copied into the rows: memory for the layout
        plan = _plan_two_level(points, cage, request, rows, report)
        return (lambda: plan), None, None
    pairs_seconds = sparse.playback_seconds(count * pairs.pairs, pairs.pairs)
    fewest = two_level.fewest_node_slots(rows[2], rows[0], rows[1], cage.vertices, AUTO_DEVIATION, counts)
    if pairs_seconds < two_level.playback_seconds(count, len(rows[2]), fewest):  # faster than the layout's
        return (lambda: _plan_two_level(points, cage, request, rows, report, fewest)), pairs, field
    plan = _plan_two_level(points, cage, request, rows, report, fewest)
    if pairs_seconds >= two_level.playback_seconds(count, *plan.node_indices.shape):
        return (lambda: plan), None, None
    return (lambda: plan), pairs, field


def _plan(points, cage, request):
    count, inside = len(points), None  # inside: the points the refusal found inside, not tested again
    if request.outside == "raise":  # refused before any coordinates, at a small part of their cost
        outside = cage.outside_points(points, inside := np.empty(count, dtype=bool))
        if len(outside):
            raise (GreenOutsideError if request.green else OutsideCageError)(outside, count)
    # Workers are chosen once for the whole plan; each call gives every one a chunk.
    workers = cage.suggested_workers(count) if request.workers is None else request.workers
    field = fallback = choice = None
    if request.harmonic:  # solved once, on the grid; the points look it up
        field = yield from _solved_field(cage, request)
        yield 0.5
        if request.storage in (Storage.AUTO, Storage.SPARSE):
            solved = [field]  # handed over, to be freed before the layout
            del field
            fallback, choice, field = _harmonic_sparse(points, cage, request, solved, inside)
            if choice is None and fallback is not None:
                return fallback()
    choice = choice or first_choice(request, count, cage.vertices, cage.faces)
    if field is not None and request.storage == Storage.AUTO and choice.storage == Storage.EXACT:
        choice = replace(choice, reason=f"Automatic: exact ({count} vertices, fewer than the grid nodes their "
                                        "cells use: two levels would save nothing)")
    if choice.storage == Storage.AUTO:  # estimate on a few points, measure on more only if that says nothing
        few = points[::max(1, count // ESTIMATE_SAMPLES)]
        choice = choose_by_estimate(request, figures.solve_points(request, cage, few, None, field=field), cage.vertices,
                                    cage.faces, count)
    if choice is None:
        sample = points[::max(1, count // DEVIATION_SAMPLES)]
        choice = choose_by_measuring(request, figures.solve_points(request, cage, sample, None, field=field), cage.vertices,
                                     cage.faces, count)
    slots, indices, locations, measured = yield from figures.written_slots(request, cage, points, choice, workers, field)
    if choice.measured and choice.storage in (Storage.COMPACT, Storage.SPARSE):
        choice = confirm_compact(choice, max(measured["deviation_smooth"], measured["deviation_drag"]), count,
                                 coordinate_rows(request.kind, len(cage.vertices), len(cage.faces)))
        if choice.storage == Storage.EXACT and fallback is not None:  # per-vertex pairs missed: two levels
            return fallback()
        if choice.storage == Storage.EXACT:
            slots, indices, locations, measured = yield from figures.written_slots(request, cage, points, choice, workers, field)
    # On what will be written; sparse storage and harmonic coordinates place points only
    # approximately by design (their deviations say how far), so only huge coordinates
    # losing their point to float32 rounding are refused.
    if measured["linear_precision"] > LINEAR_PRECISION and choice.storage != Storage.SPARSE and field is None:
        raise ImpreciseCoordinatesError("placing", measured["linear_precision"], measured["min_coordinate"])
    if measured["max_affine_error"] > TRANSLATION_PRECISION:  # sparse storage's placing is not checked above
        raise ImpreciseCoordinatesError("sums", measured["max_affine_error"], measured["min_coordinate"],
                                        largest=float(np.abs(slots).max()))
    # Each vertex moves by its weights times the float32 rounding of the cage's positions
    # (half an epsilon of their distance from the origins): the jitter, of the cage's size.
    magnitude = measured.pop("weight_magnitude")
    distance = figures.origin_distance(cage.vertices, request.origins)
    jitter = magnitude * 0.5 * float(np.finfo(np.float32).eps) * distance
    if magnitude > ROUNDING_AMPLIFICATION and jitter > TRANSLATION_PRECISION:
        raise ImpreciseCoordinatesError("rounding", jitter, measured["min_coordinate"], largest=magnitude,
                                        distance=distance)
    return BindPlan(str(choice.storage), slots, choice.basis, locations, choice.reason, figures.kind_report(request, cage, field),
                    indices=indices, **measured)


def _two_level_rows(points, request, field, inside):
    """The two levels' rows: each point's 8 interpolating grid nodes and their weights,
    and those nodes' coordinates; a point in a cell at the cage (``field.cut``) is a
    node of its own, its corners all that node (its pairs place it exactly, which the
    grid's nodes cannot). None where there would be more nodes than points (per point
    pairs do better). ``inside``: as ``field.sparse_rows``'.

    Returns
    -------
    corners : (k, 8) int32
    corner_weights : (k, 8) float
    node_rows : (N, n) float
    """
    corners, corner_weights, cut, columns, values = field.sparse_rows(points, outside=request.outside, inside=inside)
    used, local = two_level.used_nodes(corners[~cut])
    if len(used) + len(columns) > len(points):
        return None
    node_rows = np.empty((len(used) + len(columns), len(field.vertices)))
    field.node_rows(used, node_rows[:len(used)])
    node_rows[len(used):] = 0.0
    np.put_along_axis(node_rows[len(used):], columns, values, axis=1)
    corners = np.empty(corners.shape, dtype=np.int32)
    corners[~cut], corners[cut] = local, len(used) + np.arange(len(columns), dtype=np.int32)[:, None]
    corner_weights[cut] = np.eye(1, corners.shape[1])
    return corners, corner_weights, node_rows


def _plan_two_level(points, cage, request, rows, report, fewest=0):
    """Harmonic coordinates in sparse storage, two levels (:func:`_two_level_rows`): each
    node its fewest pairs over the cage, from ``fewest`` (a bound already found), that keep
    the deviations under AUTO_DEVIATION (Automatic; Sparse: ``request.sparse_size``)."""
    corners, corner_weights, node_rows = rows
    automatic = request.storage == Storage.AUTO
    # Automatic fills the stored columns (free accuracy); Sparse keeps the count asked for.
    counts = (tuple(slots for slots in two_level.automatic_node_slot_counts(len(points), len(node_rows), len(cage.vertices))
                    if slots >= fewest)
              if automatic else (request.sparse_size,))
    layout = two_level.two_level_layout(node_rows, corners, corner_weights, cage.vertices, AUTO_DEVIATION, counts)
    deviation = max(layout.deviation_smooth, layout.deviation_drag)
    reason = (f"{'Automatic: s' if automatic else 'S'}parse in two levels, each vertex its {corners.shape[1]} interpolating grid nodes "
              f"(its own node at the cage), each node its {layout.node_slot_count} largest coordinates (deviation "
              f"{short_number(deviation)} {'<' if deviation < AUTO_DEVIATION else '>'} "
              f"{short_number(AUTO_DEVIATION, 1)})")
    node_sums = layout.node_weights.astype(np.float64).sum(axis=1)
    point_sums = (layout.corner_weights.astype(np.float64) * node_sums[layout.corners]).sum(axis=1)
    every_column = layout.node_slot_count >= len(cage.vertices)
    locations = figures.point_locations(request, cage, points)
    places = layout.placed_points(cage.vertices)
    miss = np.linalg.norm(places - points, axis=1)
    placed = miss if request.outside != "project" else miss[locations != OUTSIDE]
    return BindPlan(
        Storage.SPARSE.value, layout.corner_weights, None, locations, reason, report,
        min_coordinate=float(layout.node_weights.min()) if every_column else 0.0, negative_points=0,
        max_affine_error=float(np.abs(point_sums - 1.0).max(initial=0.0)),
        linear_precision=float(placed.max(initial=0.0) / np.linalg.norm(np.ptp(cage.vertices, axis=0))),
        deviation_smooth=layout.deviation_smooth, deviation_drag=layout.deviation_drag,
        deviation_drag_vertex=layout.deviation_drag_vertex, indices=layout.corners,
        node_indices=layout.node_indices, node_weights=layout.node_weights,
        similarity_deviation=similarity_deviation(places, point_sums, points, cage.vertices))

