"""Bind planning: a mesh's coordinates in a cage, the storage they are written in, and the
figures measured on what will be written. No Blender: the add-on reads the scene, runs
:func:`plan_bind` and writes the :class:`BindPlan` it returns.

A plan is computed chunk by chunk: :func:`plan_bind` is a generator yielding the fraction
done (0 to 1), so a front end can show progress and cancel between chunks (closing the
generator stops the worker processes), and returning the plan. Every decision is a
return value: :func:`choose_storage` (from the sizes alone), :func:`choose_by_estimate`
(Automatic's cheap first look, on a few points), :func:`choose_by_measuring` (Automatic
beyond the cheap sizes: on a sample of the mesh) and :func:`confirm_compact` (after the
deviations were measured on every vertex), each a :class:`StorageChoice`.

Extension points, by name: a kind solved apart from ``Cage.coordinates`` (harmonic
coordinates on grid nodes) is one more case of :func:`_solve`, with its row count in
:func:`coordinate_rows`; a storage (sparse: per vertex K (cage vertex, weight) pairs) is
one more case of :func:`choose_storage` / :func:`choose_by_measuring` (the smallest K whose
measured deviation stays under ``AUTO_DEVIATION``), :func:`encode` and :func:`reproduce`.
"""

from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ..base.tolerances import LINEAR_PRECISION
from ..construction.boundary import BOUNDARY, OUTSIDE
from ..construction.green import GREEN
from ..construction.validation import DEFAULT_TOLERANCE
from ..evaluation.cage import Cage
from ..evaluation.deformation import coordinate_summary, linear_precision
from . import compact
from .report import coordinate_report

__all__ = ["BindRequest", "BindPlan", "UndefinedCoordinatesError", "ImpreciseCoordinatesError", "plan_bind",
           "choose_storage"]

# Automatic storage is exact without measuring while its per-evaluation cost and node
# group stay moderate: k x n multiply-adds (about 1.5 ns each on two cores) and a node
# per three cage vertices.
EXACT_MAX_PRODUCT = 8_000_000
EXACT_MAX_CAGE_VERTICES = 400
# Beyond, it measures: compact with the fewest slots that keep both standard deviations
# (core.tools.compact: smooth motion, worst single-vertex drag) under AUTO_DEVIATION of the
# cage's diagonal, else exact. Slots are chosen on a sample of the mesh with
# AUTO_SAMPLE_MARGIN to spare for the vertices it skipped; after Bind the deviations are
# measured on every vertex, and compact that still misses goes exact.
AUTO_DEVIATION = 1e-3
AUTO_SAMPLE_MARGIN = 0.8
# Exact storage Automatic still chooses when compact deviates more: attribute bytes (a
# million vertices x 642 cage vertices, 2.6 GB, stay compact and the panel says so).
AUTO_EXACT_MAX_BYTES = 2**31
# Coordinates computed per chunk of points: progress and cancel granularity, and the
# bound on the dense float64 block a chunk makes (points x cage vertices).
CHUNK_ENTRIES = 4_000_000  # per worker process
DEVIATION_SAMPLES = 2000  # mesh vertices Automatic chooses compact storage's slots on
# Mesh vertices Automatic first estimates on: enough to see a cage where compact storage
# cannot save anything, and cheap next to the Bind (the coordinates of a few points and
# one deviation), so it does not measure slots it would throw away.
ESTIMATE_SAMPLES = 128
REPORT_SAMPLES = 1000  # points inside the cage coordinate_report examines


class UndefinedCoordinatesError(ValueError):
    """The coordinates came out NaN or infinite (tiny or overlapping cage faces)."""


class ImpreciseCoordinatesError(ValueError):
    """The coordinates as stored place the points only to ``error`` of the cage's size
    (over ``LINEAR_PRECISION``: huge coordinates, down to ``min_coordinate``, lose it to
    float32 rounding), so the mesh would stray as the cage moves."""

    def __init__(self, error, min_coordinate):
        super().__init__(f"the coordinates as stored place the points only to {error:.2g} of the cage's size")
        self.error, self.min_coordinate = error, min_coordinate


def _in_this_process(compute, workers):
    return compute(workers)


@dataclass(frozen=True)
class BindRequest:
    """What to compute: the settings of one Bind, in the core's names.

    Examples
    --------
    >>> from gencoords.tools.bind_plan import BindRequest
    >>> request = BindRequest("green", outside="project", storage='EXACT')
    >>> request.green, request.compact_size, request.workers
    (True, 36, None)
    """

    kind: str  # e.g. 'mean_value', 'green'
    outside: str = "raise"  # 'raise', 'project' or 'extrapolate'
    gamma: Optional[float] = None  # the kind's parameter, for the kinds that have one
    storage: str = 'AUTO'  # 'AUTO', 'EXACT' or 'COMPACT'
    compact_size: int = 36  # compact storage's slots when asked for
    workers: Optional[int] = None  # worker processes (None: the core's choice; 1: none)
    tolerance: float = DEFAULT_TOLERANCE  # relative to the cage's size
    # ``run(compute, workers)`` calls ``compute(workers)``: a front end's hook to fall
    # back to its own process where workers fail (it then passes 1 on later calls).
    run: Callable = _in_this_process

    @property
    def green(self):
        return self.kind == GREEN


@dataclass(frozen=True, eq=False)
class StorageChoice:
    """A storage decision: ``storage`` ('EXACT', 'COMPACT', or 'AUTO': measure), for
    compact storage its ``basis`` ((rows, s) float64), ``reason`` (why, in the panel's
    words; None where there is nothing to say) and whether Automatic ``measured``."""

    storage: str
    basis: Optional[np.ndarray] = None
    reason: Optional[str] = None
    measured: bool = False

    @property
    def slot_count(self):
        return None if self.basis is None else self.basis.shape[1]


@dataclass(frozen=True, eq=False)
class BindPlan:
    """What a Bind writes: the slots, compact storage's basis, and the figures measured
    on them as they will be written (float32).

    Examples
    --------
    >>> from gencoords.tools.bind_plan import BindRequest, plan_bind
    >>> from gencoords.tools.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> fractions = []  # the plan is the generator's return value
    >>> steps = plan_bind(0.5 * vertices[:30], vertices, faces, BindRequest("mean_value", workers=1))
    >>> while True:
    ...     try:
    ...         fractions.append(next(steps))
    ...     except StopIteration as done:
    ...         plan = done.value
    ...         break
    >>> fractions[-1], plan.storage, plan.slots.shape, plan.points_outside
    (1.0, 'EXACT', (30, 42), 0)
    >>> sorted(plan.figures())[:3]
    ['deviation_drag', 'deviation_drag_vertex', 'deviation_smooth']
    """

    storage: str  # 'EXACT' or 'COMPACT'
    slots: np.ndarray  # (k, s) float32
    basis: Optional[np.ndarray]  # (rows, s) float64 for compact storage, else None
    locations: np.ndarray  # (k,) int8: INSIDE, BOUNDARY or OUTSIDE per point
    storage_choice: Optional[str]  # why this storage, where there is a why
    report: str  # how the kind behaves in this cage (coordinate_report's headline)
    min_coordinate: float
    negative_points: int
    max_affine_error: float
    linear_precision: float  # how far the stored coordinates place the points, of the cage's size
    deviation_smooth: float  # of the cage's diagonal, against the exact coordinates
    deviation_drag: float
    deviation_drag_vertex: int

    @property
    def slot_count(self):
        return self.slots.shape[1]

    @property
    def points_outside(self):
        return int(np.count_nonzero(self.locations == OUTSIDE))

    @property
    def points_on_boundary(self):
        return int(np.count_nonzero(self.locations == BOUNDARY))

    def figures(self):
        """The measured figures by name (what a front end stores beside the slots)."""
        names = ("storage_choice", "report", "min_coordinate", "negative_points", "max_affine_error",
                 "linear_precision", "deviation_smooth", "deviation_drag", "deviation_drag_vertex", "points_outside",
                 "points_on_boundary")
        return {name: getattr(self, name) for name in names}


def stored_bytes(mesh_vertices, slot_count, compact_storage):
    """Bytes of the bind data's attributes: three float32 slots per vector attribute (the
    last one padded), and compact storage's basis in as many attributes again."""
    stored = mesh_vertices * 3 * -(-slot_count // 3) * 4
    return stored * (2 if compact_storage else 1)


def short_number(value, digits=2):
    """``9.6e-4`` for 0.00096 (``digits`` significant): deviations in few characters."""
    return f"{value:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e")


def coordinate_rows(kind, cage_vertex_count, face_count):
    """Coordinates per point: n, or n + m for Green coordinates (``[phi, psi]``)."""
    return cage_vertex_count + (face_count if kind == GREEN else 0)


def choose_storage(setting, mesh_vertices, cage_vertices, compact_size):
    """'EXACT', 'COMPACT' or 'AUTO' (measure) for the Storage setting ``setting``.

    Compact storage keeps its basis on the mesh's first n points and needs more cage
    vertices than slots to save anything, so small meshes and cages are always exact;
    Automatic is exact while exact storage is cheap, and measures beyond.

    Examples
    --------
    >>> from gencoords.tools.bind_plan import choose_storage
    >>> choose_storage('AUTO', 31_658, 162, 36), choose_storage('AUTO', 1_000_000, 642, 36)
    ('EXACT', 'AUTO')
    >>> choose_storage('COMPACT', 5000, 12, 36)  # nothing to save
    'EXACT'
    """
    if mesh_vertices < cage_vertices or cage_vertices <= compact_size:
        return 'EXACT'
    if setting != 'AUTO':
        return setting
    small = (mesh_vertices * cage_vertices <= EXACT_MAX_PRODUCT
             and cage_vertices <= EXACT_MAX_CAGE_VERTICES)
    return 'EXACT' if small else 'AUTO'


def _basis(request, cage_vertices, triangles, size):
    """Compact storage's basis of cage motions, (rows, size) float64."""
    if request.green:
        return compact.green_motion_basis(cage_vertices, triangles, size)
    return compact.motion_basis(cage_vertices, triangles, size)


def first_choice(request, mesh_vertices, cage_vertices, triangles):
    """The storage decided from the sizes alone (:func:`choose_storage`), with its reason
    and, for compact storage, its basis."""
    rows = coordinate_rows(request.kind, len(cage_vertices), len(triangles))
    # Green's basis starts with the 8 columns that keep similarities exact.
    size = max(request.compact_size, 8) if request.green else request.compact_size
    storage = choose_storage(request.storage, mesh_vertices, rows, size)
    reason = None
    if request.storage != 'EXACT' and storage == 'EXACT':
        small = mesh_vertices < rows or rows <= request.compact_size
        why = ("compact saves nothing with this few vertices" if small else
               f"{mesh_vertices} x {rows} coordinates: cheap enough to store them all")
        label = "Automatic: exact" if request.storage == 'AUTO' else "Exact, not compact"
        reason = f"{label} ({why})"
    basis = _basis(request, cage_vertices, triangles, min(size, rows)) if storage == 'COMPACT' else None
    return StorageChoice(storage, basis, reason, measured=storage == 'AUTO')


def _saving_sizes(request, cage_vertices, rows):
    """Compact sizes worth measuring: multiples of three (an attribute holds three), enough
    for the motions kept exact, and at most half the rows (beyond, slots and basis take as
    much as exact storage)."""
    smallest = 8 if request.green else cage_vertices.shape[1] + 1
    return [size for size in range(3, rows // 2 + 1, 3) if size >= smallest]


def _passes(request, coordinates, basis, cage_vertices, triangles, size):
    """Whether compact storage with ``size`` slots keeps both deviations under Automatic's
    target on the points of ``coordinates``."""
    found, _, _ = compact.smallest_size(coordinates, basis, cage_vertices, AUTO_DEVIATION * AUTO_SAMPLE_MARGIN,
                                        [size], triangles if request.green else None)
    return found is not None


def _exact_beyond_half(rows, mesh_vertices, saving):
    """Automatic's exact choice when compact storage would need more than half the rows,
    or None where exact does not fit AUTO_EXACT_MAX_BYTES (compact with the most slots that
    save is then the choice)."""
    if stored_bytes(mesh_vertices, rows, False) <= AUTO_EXACT_MAX_BYTES or not saving:
        return StorageChoice('EXACT', reason=(f"Automatic: exact (compact would need more than {rows // 2} of the "
                                              f"{rows} slots for {short_number(AUTO_DEVIATION, 1)})"), measured=True)
    return None


def choose_by_estimate(request, coordinates, cage_vertices, triangles, mesh_vertices):
    """Automatic's cheap first look, from the coordinates of a few points of the mesh
    ((j, rows) float64): compact storage with the most slots that still save (half the
    rows) measured on them. Deviations are maxima over points, so these few bound the
    whole mesh's from below: where they already miss the target, compact would need more
    than half the rows whatever the rest of the mesh, and the choice is final (exact, or
    compact with that half where exact does not fit). Else None: measure
    (:func:`choose_by_measuring`)."""
    rows = coordinates.shape[1]
    saving = _saving_sizes(request, cage_vertices, rows)
    if saving and _passes(request, coordinates, _basis(request, cage_vertices, triangles, saving[-1]),
                          cage_vertices, triangles, saving[-1]):
        return None
    exact = _exact_beyond_half(rows, mesh_vertices, saving)
    if exact is not None:
        return exact
    return StorageChoice('COMPACT', _basis(request, cage_vertices, triangles, saving[-1]), measured=True)


def _fewest_slots(request, coordinates, basis, cage_vertices, triangles, sizes):
    """The fewest of ``sizes`` that pass on ``coordinates`` (None if the largest does not),
    by bisection: deviations fall as slots are added (the basis is in order of use), so
    a few measurements find it where trying every size took most of a Bind."""
    if not _passes(request, coordinates, basis, cage_vertices, triangles, sizes[-1]):
        return None
    low, high = -1, len(sizes) - 1  # sizes[low] fails (or is none), sizes[high] passes
    while high - low > 1:
        middle = (low + high) // 2
        if _passes(request, coordinates, basis, cage_vertices, triangles, sizes[middle]):
            high = middle
        else:
            low = middle
    return sizes[high]


def choose_by_measuring(request, coordinates, cage_vertices, triangles, mesh_vertices):
    """Automatic storage beyond the cheap sizes, from the coordinates of a sample of the
    mesh ((j, rows) float64): compact with the fewest slots (a multiple of three: an
    attribute holds three) that keep both deviations under the target, or exact when
    compact needs more than half the rows (its slots and basis then take as much as exact
    storage) and exact storage fits AUTO_EXACT_MAX_BYTES; when it does not, compact with
    that half. A compact choice's reason waits for the deviations on every vertex."""
    rows = coordinates.shape[1]
    saving = _saving_sizes(request, cage_vertices, rows)
    basis = _basis(request, cage_vertices, triangles, saving[-1]) if saving else None
    size = _fewest_slots(request, coordinates, basis, cage_vertices, triangles, saving) if saving else None
    if size is None:
        exact = _exact_beyond_half(rows, mesh_vertices, saving)
        if exact is not None:
            return exact
        size = saving[-1]
    return StorageChoice('COMPACT', basis[:, :size], measured=True)


def confirm_compact(choice, deviation, mesh_vertices, rows):
    """Automatic's compact ``choice`` once its ``deviation`` (the worse of the two) was
    measured on every vertex: kept with its reason, or exact when the sample missed where
    compact deviates most and exact storage fits AUTO_EXACT_MAX_BYTES (the slots are then
    computed again)."""
    slot_count, target = choice.slot_count, short_number(AUTO_DEVIATION, 1)
    exact_bytes = stored_bytes(mesh_vertices, rows, False)
    if deviation < AUTO_DEVIATION:
        reason = f"Automatic: compact, {slot_count} slots (deviation {short_number(deviation)} < {target})"
    elif exact_bytes <= AUTO_EXACT_MAX_BYTES:
        return StorageChoice('EXACT', reason=(f"Automatic: exact (compact with {slot_count} slots deviated "
                                              f"{short_number(deviation)} on the whole mesh)"), measured=True)
    else:
        reason = (f"Automatic: compact, {slot_count} slots (deviation {short_number(deviation)} > {target}; "
                  f"exact would take {exact_bytes / 1e9:.1f} GB: choose Exact for it)")
    return StorageChoice('COMPACT', choice.basis, reason, measured=True)


def encode(choice, coordinates):
    """The slots written for ``coordinates`` ((j, rows) float64) in ``choice``'s storage:
    (j, s) float32."""
    if choice.storage == 'COMPACT':
        return (coordinates @ choice.basis).astype(np.float32)
    return coordinates.astype(np.float32)


def reproduce(choice, slots):
    """The coordinates the deformer reproduces from ``slots`` ((j, s) float32, as
    written; compact storage's basis too): (j, rows) float64."""
    if choice.storage == 'COMPACT':
        return slots @ choice.basis.astype(np.float32).astype(np.float64).T
    return slots.astype(np.float64)


def _solve(request, cage, points, workers, locations=None):
    """The coordinates of ``points`` ((j, rows) float64) in ``cage``, in ``request.run``."""
    def compute(count):
        if request.green:  # phi and psi side by side: the slots' n + m rows
            return np.hstack(cage.green_coordinates(points, outside=request.outside, locations=locations,
                                                    workers=count))
        return cage.coordinates(points, kind=request.kind, outside=request.outside, locations=locations,
                                workers=count, gamma=request.gamma)

    coordinates = request.run(compute, workers)
    if not np.isfinite(coordinates).all():
        raise UndefinedCoordinatesError("the coordinates are not finite: tiny or overlapping cage faces")
    return coordinates


def _slots(request, cage, points, choice, workers):
    """The slots of every point in ``choice``'s storage, chunk by chunk, yielding the
    fraction done; returns them with their locations and the figures measured on them
    as written (the deviations from the exact coordinates on every point)."""
    count, rows = len(points), coordinate_rows(request.kind, len(cage.vertices), len(cage.faces))
    slot_count = rows if choice.basis is None else choice.slot_count
    slots = np.empty((count, slot_count), dtype=np.float32)
    locations = np.empty(count, dtype=np.int8)
    smallest, negative, affine_error, precision = np.inf, 0, 0.0, 0.0
    smooth, drag = 0.0, np.zeros(len(cage.vertices))
    faces = cage.faces if request.green else None
    chunk = max(1, CHUNK_ENTRIES * workers // rows)
    for start in range(0, count, chunk):
        part = slice(start, min(start + chunk, count))
        coordinates = _solve(request, cage, points[part], workers, locations[part])
        # Green's phi (the first n) sum to 1 and weigh the vertices as the others do.
        summary = coordinate_summary(coordinates[:, :len(cage.vertices)])
        smallest = min(smallest, summary["min"])
        negative += summary["negative_points"]
        affine_error = max(affine_error, summary["max_affine_error"])
        slots[part] = encode(choice, coordinates)
        reproduced = reproduce(choice, slots[part])
        precision = max(precision, _placed(request, reproduced, cage.vertices, points[part], locations[part]))
        residual = np.subtract(coordinates, reproduced, out=reproduced)
        chunk_smooth, chunk_drag = compact.residual_deviations(residual, cage.vertices, faces=faces)
        smooth, drag = max(smooth, chunk_smooth), np.maximum(drag, chunk_drag)
        # With workers, shared memory: freed before the next chunk's.
        del coordinates, residual
        yield part.stop / count
    return slots, locations, {
        "min_coordinate": float(smallest), "negative_points": int(negative),
        "max_affine_error": float(affine_error), "linear_precision": float(precision),
        "deviation_smooth": float(smooth),
        "deviation_drag": float(drag.max(initial=0.0)), "deviation_drag_vertex": int(np.argmax(drag))}


def _placed(request, stored, cage_vertices, points, locations):
    """``linear_precision`` of coordinates as stored ((j, rows)) for ``points`` (Green
    coordinates also weigh normals: 0; projected points are not placed where they are:
    left out)."""
    if request.green:
        return 0.0
    placed = slice(None) if request.outside != 'project' else locations != OUTSIDE
    return linear_precision(stored[placed], cage_vertices, points[placed])


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
    stored fail ``LINEAR_PRECISION``) on the first step or where they arise. Closing the
    generator early (a cancel) stops the worker processes.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.bind_plan import BindRequest, plan_bind
    >>> from gencoords.tools.shapes import icosphere
    >>> vertices, faces = icosphere(2)
    >>> points = 0.5 * vertices
    >>> steps = plan_bind(points, vertices, faces, BindRequest("mean_value", storage='COMPACT',
    ...                                                         compact_size=12, workers=1))
    >>> fraction = next(steps)  # the first chunk: the cage is checked, the storage chosen
    >>> steps.close()  # a cancel: nothing more is computed
    """
    cage = Cage(cage_vertices, triangles, tolerance=request.tolerance)
    try:
        return (yield from _plan(points, cage, request))
    finally:
        cage.close()


def _plan(points, cage, request):
    count = len(points)
    # Workers are chosen once for the whole plan; each call gives every one a chunk.
    workers = cage.suggested_workers(count) if request.workers is None else request.workers
    choice = first_choice(request, count, cage.vertices, cage.faces)
    if choice.storage == 'AUTO':  # estimate on a few points, measure on more only if that says nothing
        few = points[::max(1, count // ESTIMATE_SAMPLES)]
        choice = choose_by_estimate(request, _solve(request, cage, few, None), cage.vertices, cage.faces, count)
    if choice is None:
        sample = points[::max(1, count // DEVIATION_SAMPLES)]
        choice = choose_by_measuring(request, _solve(request, cage, sample, None), cage.vertices,
                                     cage.faces, count)
    slots, locations, figures = yield from _slots(request, cage, points, choice, workers)
    if choice.measured and choice.storage == 'COMPACT':
        choice = confirm_compact(choice, max(figures["deviation_smooth"], figures["deviation_drag"]), count,
                                 coordinate_rows(request.kind, len(cage.vertices), len(cage.faces)))
        if choice.storage == 'EXACT':
            slots, locations, figures = yield from _slots(request, cage, points, choice, workers)
    if figures["linear_precision"] > LINEAR_PRECISION:  # on what will be written
        raise ImpreciseCoordinatesError(figures["linear_precision"], figures["min_coordinate"])
    # How this kind behaves in this cage, away from the mesh's own vertices (the figures
    # cover those): positivity and well-definedness on a sample.
    report = ("Green: similarity invariant, shape-preserving; any closed cage" if request.green else
              coordinate_report(cage.vertices, cage.faces, request.kind, gamma=request.gamma,
                                samples=REPORT_SAMPLES, tolerance=request.tolerance).headline)
    return BindPlan(choice.storage, slots, choice.basis, locations, choice.reason, report, **figures)
