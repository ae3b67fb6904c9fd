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

Harmonic coordinates are solved once on a grid (``gencoords.harmonic_field``) and looked
up (:func:`_solve`); in sparse storage, their default, they are written in two levels
(:func:`_plan_two_level`: each vertex its 4 interpolating grid nodes, each node its own pairs over
the cage, ``tools.sparse.two_level_layout``). Sparse storage of any other kind keeps each
vertex's K largest coordinates (``tools.sparse``): Automatic chooses it, with the fewest K
whose deviations stay under ``AUTO_DEVIATION``, before compact storage (:func:`encode` and
:func:`reproduce` know each storage).
"""

import threading
from dataclasses import dataclass, replace
from typing import Callable, Optional

import numpy as np

from ..base.grid import fit_grid
from ..base.tolerances import LINEAR_PRECISION, ROUNDING_AMPLIFICATION, TRANSLATION_PRECISION
from ..construction.boundary import BOUNDARY, INSIDE, OUTSIDE
from ..construction.green import GREEN
from ..construction.validation import DEFAULT_TOLERANCE
from ..evaluation.cage import Cage
from ..evaluation.deformation import coordinate_summary, linear_precision
from ..harmonic import harmonic_field
from ..harmonic.memory import available_memory, field_bytes, fitting_resolution
from . import compact, sparse
from .report import coordinate_report

__all__ = ["BindRequest", "BindPlan", "GridMemoryError", "UndefinedCoordinatesError", "ImpreciseCoordinatesError", "plan_bind",
           "choose_storage", "plan_bytes", "probe_similarity", "similarity_deviation"]

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
HARMONIC = "harmonic"  # the core's name of harmonic coordinates (gencoords.harmonic_field)
# A Bind's grid for harmonic coordinates unless asked otherwise: on the character
# (bench_local.py, 43k vertices, 196-vertex cage) 48 cells bind in 2.9x Mesh Deform p5's
# time, play back in 1.1x its CPU time and bend a limb 1.7 / 16.2 degrees (mean / 99th
# percentile, against 2.5 / 14.1); 64 took 1.8x as long to bind and 32 played back in
# 1.6x (most of its vertices are in cells at the cage: nodes of their own).
BIND_RESOLUTION = 48
# The harmonic solve's relative residual in a Bind: the weights are written as float32 and
# sparse storage drops those below about 1e-4, so 1e-10 (the core's default) would buy
# nothing; this takes 7 conjugate-gradient iterations on the character against 12.
BIND_SOLVER_TOLERANCE = 1e-6
# While a long computation runs beside the caller, how often it hears of its progress.
POLL_SECONDS = 0.05
# A harmonic grid of fewer (grid node, cage vertex) pairs than this, and fewer nodes than
# INLINE_FIELD_NODES, is solved in the caller's thread, without progress (0.2 s for the
# character at 48 cells: 24,480 nodes, 4.8M pairs). A thread of its own would leave its
# arrays in an allocator arena of its own: 10 MB more resident at the character's Bind.
# Some of the field's work grows with the nodes alone (an 8-vertex box at 96 cells,
# 970,299 nodes: many seconds), hence both bounds.
INLINE_FIELD_PAIRS, INLINE_FIELD_NODES = 1 << 23, 1 << 16
SPARSE_SIZE = 16  # sparse storage's pairs per vertex when asked for


class GridMemoryError(ValueError):
    """The harmonic grid asked for would need more memory than is free: ``needed`` bytes
    (estimated: ``harmonic.memory.field_bytes``) against ``available``; ``resolution`` is
    the finest that fits (0: none)."""

    def __init__(self, needed, available, resolution, asked):
        fits = f"Resolution {resolution} fits" if resolution else "no Resolution fits"
        super().__init__(f"the harmonic grid of Resolution {asked} would need about {needed / 2**30:.1f} GiB of "
                         f"memory, {available / 2**30:.1f} GiB are free: {fits}")
        self.needed, self.available, self.resolution, self.asked = needed, available, resolution, asked


class UndefinedCoordinatesError(ValueError):
    """The coordinates came out NaN or infinite (tiny or overlapping cage faces)."""


class ImpreciseCoordinatesError(ValueError):
    """Huge coordinates lose their point to float32 rounding, so the mesh would stray as
    the cage moves. ``problem`` says how, with ``error`` its measure:

    - ``"placing"``: as stored they place the points only to ``error`` of the cage's size
      (over ``LINEAR_PRECISION``); ``min_coordinate`` is the smallest.
    - ``"sums"``: as stored they sum to 1 only to ``error`` (over ``TRANSLATION_PRECISION``:
      a translated cage leaves the points behind by that share of the move); ``largest``
      is the largest in size.
    - ``"rounding"``: their magnitudes sum to ``largest`` at a point, so the float32
      rounding of the cage's positions makes the points jitter by up to ``error`` of the
      cage's size as it moves (over ``TRANSLATION_PRECISION``, see
      ``ROUNDING_AMPLIFICATION``); ``distance`` is the cage's largest coordinate measured
      from the origins, of its size (far origins round more).
    """

    MESSAGES = {"placing": "the coordinates as stored place the points only to {:.2g} of the cage's size",
                "sums": "the coordinates as stored sum to 1 only to {:.2g}",
                "rounding": "the coordinates' magnitudes make the points jitter by up to {:.2g} of the cage's "
                            "size with the float32 rounding of its positions"}

    def __init__(self, problem, error, min_coordinate, largest=None, distance=None):
        super().__init__(self.MESSAGES[problem].format(error))
        self.problem, self.error, self.min_coordinate, self.largest = problem, error, min_coordinate, largest
        self.distance = distance


def _in_this_process(compute, workers):
    return compute(workers)


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

    thread = threading.Thread(target=run, name="gencoords-bind", daemon=True)
    thread.start()
    try:
        while thread.is_alive():
            thread.join(POLL_SECONDS)
            if thread.is_alive():
                yield share * state["fraction"]
    finally:
        if thread.is_alive():  # closed early: a cancel
            state["cancelled"] = True
            thread.join()
    if "error" in state:
        raise state["error"]
    return state["result"]


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
    storage: str = 'AUTO'  # 'AUTO', 'EXACT', 'COMPACT' or 'SPARSE'
    compact_size: int = 36  # compact storage's slots when asked for
    sparse_size: int = SPARSE_SIZE  # sparse storage's pairs per vertex (per grid node: two levels)
    resolution: int = BIND_RESOLUTION  # harmonic coordinates: cells along the cage's longest side
    workers: Optional[int] = None  # worker processes (None: the core's choice; 1: none)
    tolerance: float = DEFAULT_TOLERANCE  # relative to the cage's size
    # (o, 3) float: where the deformer's float32 positions are measured from (the objects'
    # origins), in the points' space; None: the points' own origin. Their rounding grows
    # with the cage's distance from these.
    origins: Optional[np.ndarray] = None
    # Bytes a harmonic solve may take (None: what the system says is free); a grid that
    # would need more is refused before it is solved (GridMemoryError).
    memory_budget: Optional[int] = None
    # ``run(compute, workers)`` calls ``compute(workers)``: a front end's hook to fall
    # back to its own process where workers fail (it then passes 1 on later calls).
    run: Callable = _in_this_process

    @property
    def green(self):
        return self.kind == GREEN

    @property
    def harmonic(self):
        return self.kind == HARMONIC


@dataclass(frozen=True, eq=False)
class StorageChoice:
    """A storage decision: ``storage`` ('EXACT', 'COMPACT', 'SPARSE', or 'AUTO': measure),
    for compact storage its ``basis`` ((rows, s) float64), for sparse storage its ``pairs``
    per vertex, ``reason`` (why, in the panel's words; None where there is nothing to
    say) and whether Automatic ``measured``."""

    storage: str
    basis: Optional[np.ndarray] = None
    reason: Optional[str] = None
    measured: bool = False
    pairs: Optional[int] = None

    @property
    def slot_count(self):
        return self.pairs if self.basis is None else self.basis.shape[1]

    @property
    def label(self):
        """``compact, 24 slots`` / ``sparse, 16 pairs``: the reasons' words for it."""
        return (f"sparse, {self.pairs} pairs" if self.storage == 'SPARSE' else
                f"{self.storage.lower()}, {self.slot_count} slots")


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

    storage: str  # 'EXACT', 'COMPACT' or 'SPARSE'
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
    negative_entries: int = 0  # coordinates below 0, of k x n
    # Sparse storage: each vertex's pairs are ``indices`` ((k, K) int32) with the weights in
    # ``slots``; in two levels the indices are grid nodes, whose own pairs over the cage
    # are ``node_indices`` and ``node_weights`` ((N, K') int32, float32).
    indices: Optional[np.ndarray] = None
    node_indices: Optional[np.ndarray] = None
    node_weights: Optional[np.ndarray] = None
    # How far the mesh as written follows a similarity of the cage (:func:`similarity_deviation`
    # under :func:`probe_similarity`), of the cage's size; None for Green coordinates
    # (similarity invariant by their face terms).
    similarity_deviation: Optional[float] = None

    @property
    def slot_count(self):
        return self.slots.shape[1]

    @property
    def node_count(self):
        return 0 if self.node_indices is None else len(self.node_indices)

    @property
    def node_slot_count(self):
        return 0 if self.node_indices is None else self.node_indices.shape[1]

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
                 "points_on_boundary", "negative_entries", "node_count", "node_slot_count", "similarity_deviation")
        return {name: getattr(self, name) for name in names}


def stored_bytes(mesh_vertices, slot_count, compact_storage):
    """Bytes of the bind data's attributes: three float32 slots per vector attribute (the
    last one padded), and compact storage's basis in as many attributes again."""
    stored = mesh_vertices * 3 * -(-slot_count // 3) * 4
    return stored * (2 if compact_storage else 1)


def plan_bytes(plan):
    """Bytes of the attributes ``plan`` writes: :func:`stored_bytes`, or for sparse storage
    an int32 and a float32 per pair, and in two levels the nodes' pairs three to a vector
    in columns as long as the mesh (``tools.sparse.stacked_columns``).

    Examples
    --------
    >>> from gencoords.tools.bind_plan import BindRequest, plan_bind, plan_bytes
    >>> from gencoords.tools.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> steps = plan_bind(0.5 * vertices, vertices, faces, BindRequest("mean_value", storage='SPARSE',
    ...                                                                sparse_size=4, workers=1))
    >>> plan = list(steps) and None
    """
    count = len(plan.slots)
    if plan.storage != 'SPARSE':
        return stored_bytes(count, plan.slot_count, plan.basis is not None)
    nodes = 0
    if plan.node_count:
        triples, per_column = -(-plan.node_slot_count // 3), count // plan.node_count
        nodes = 2 * -(-triples // per_column) * count * 12
    return count * plan.slot_count * 8 + nodes


def probe_similarity(rest):
    """The similarity Bind probes what it writes with: the cage ``rest`` ((n, 3)) turned
    40 degrees about a skew axis, scaled by 1.5 and moved by its diagonal.

    Returns
    -------
    rotation : (3, 3) float64
    scale : float
    shift : (3,) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.bind_plan import probe_similarity
    >>> rotation, scale, shift = probe_similarity(np.array([[0.0, 0, 0], [3, 4, 0]]))
    >>> bool(np.allclose(rotation @ rotation.T, np.eye(3))), scale, shift.round(6).tolist()
    (True, 1.5, [3.0, -4.0, 0.0])
    """
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    angle = np.radians(40.0)
    rotation = np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(rest, dtype=np.float64), axis=0)))
    return rotation, 1.5, diagonal * np.array([0.6, -0.8, 0.0])


def similarity_deviation(places, sums, points, rest):
    """How far points follow :func:`probe_similarity` of the cage, of its size after the
    move, where their coordinates as written place them at ``places`` ((k, 3):
    ``sum_j w_j R_j``) and sum to ``sums`` ((k,)): a vertex moves to ``sum_j w_j (s Q R_j
    + t) = s Q places + sums t`` and should be at ``s Q x + t``. A float.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.tools.bind_plan import similarity_deviation
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    >>> points = np.array([[0.5, 0.5, 0.5], [0.2, 0.3, 0.4]])
    >>> similarity_deviation(points, np.ones(2), points, cube)
    0.0
    >>> round(similarity_deviation(points + [1e-3, 0, 0], np.ones(2), points, cube), 6)  # 1e-3 of 1.73
    0.000577
    """
    rest = np.asarray(rest, dtype=np.float64)
    rotation, scale, shift = probe_similarity(rest)
    followed = scale * np.asarray(places, dtype=np.float64) @ rotation.T + np.asarray(sums)[:, None] * shift
    wanted = scale * np.asarray(points, dtype=np.float64) @ rotation.T + shift
    size = scale * float(np.linalg.norm(np.ptp(rest, axis=0)))
    return float(np.linalg.norm(followed - wanted, axis=1).max(initial=0.0) / size)


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
    if setting == 'SPARSE':
        return setting
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
    # Green coordinates' face terms have no sparse form: Automatic decides for them.
    setting = 'AUTO' if request.green and request.storage == 'SPARSE' else request.storage
    storage = choose_storage(setting, mesh_vertices, rows, size)
    if storage == 'SPARSE':
        pairs = min(request.sparse_size, rows)
        return StorageChoice('SPARSE', reason=f"Sparse: each vertex's {pairs} largest coordinates", pairs=pairs)
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
    ((j, rows) float64): sparse storage with its most pairs, then compact storage with
    the most slots that still save (half the rows), measured on them. Deviations are maxima over points, so these few bound the
    whole mesh's from below: where they already miss the target, compact would need more
    than half the rows whatever the rest of the mesh, and the choice is final (exact, or
    compact with that half where exact does not fit). Else None: measure
    (:func:`choose_by_measuring`)."""
    rows = coordinates.shape[1]
    # Sparse storage is tried first: where its most pairs keep the target on these few
    # points, measure (they bound the whole mesh's deviations from below only).
    if not request.green and sparse.fewest_slots(coordinates, cage_vertices, AUTO_DEVIATION * AUTO_SAMPLE_MARGIN,
                                                 sparse.SLOT_COUNTS[-1:])[0] is not None:
        return None
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
    if not request.green:  # local coordinates: a few pairs per vertex do
        pairs, _, _ = sparse.fewest_slots(coordinates, cage_vertices, AUTO_DEVIATION * AUTO_SAMPLE_MARGIN)
        if pairs is not None:
            return StorageChoice('SPARSE', measured=True, pairs=pairs)
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
    """Automatic's compact or sparse ``choice`` once its ``deviation`` (the worse of the
    two) was measured on every vertex: kept with its reason, or exact when the sample
    missed where it deviates most and exact storage fits AUTO_EXACT_MAX_BYTES (the slots
    are then computed again)."""
    label, target = choice.label, short_number(AUTO_DEVIATION, 1)
    exact_bytes = stored_bytes(mesh_vertices, rows, False)
    if deviation < AUTO_DEVIATION:
        reason = f"Automatic: {label} (deviation {short_number(deviation)} < {target})"
    elif exact_bytes <= AUTO_EXACT_MAX_BYTES:
        return StorageChoice('EXACT', reason=(f"Automatic: exact ({label} deviated "
                                              f"{short_number(deviation)} on the whole mesh)"), measured=True)
    else:
        reason = (f"Automatic: {label} (deviation {short_number(deviation)} > {target}; "
                  f"exact would take {exact_bytes / 1e9:.1f} GB: choose Exact for it)")
    return StorageChoice(choice.storage, choice.basis, reason, measured=True, pairs=choice.pairs)


def encode(choice, coordinates, rest):
    """The slots written for ``coordinates`` ((j, rows) float64) in ``choice``'s storage:
    (j, s) float32, and for sparse storage the pairs' columns ((j, s) int32; else None;
    ``sparse.placed_pairs``: placing each point where its coordinates do, in the cage
    ``rest`` (n, 3))."""
    if choice.storage == 'SPARSE':
        indices, weights = sparse.placed_pairs(coordinates, choice.pairs, rest)
        return weights.astype(np.float32), indices
    if choice.storage == 'COMPACT':
        return (coordinates @ choice.basis).astype(np.float32), None
    return coordinates.astype(np.float32), None


def reproduce(choice, slots, indices=None, rows=None):
    """The coordinates the deformer reproduces from ``slots`` ((j, s) float32, as
    written; compact storage's basis too, sparse storage's ``indices`` and ``rows``):
    (j, rows) float64."""
    if choice.storage == 'SPARSE':
        return sparse.dense_weights(indices, slots, rows)
    if choice.storage == 'COMPACT':
        return slots @ choice.basis.astype(np.float32).astype(np.float64).T
    return slots.astype(np.float64)


def _solve(request, cage, points, workers, locations=None, field=None):
    """The coordinates of ``points`` ((j, rows) float64) in ``cage``, in ``request.run``
    (harmonic coordinates: looked up in their solved ``field``)."""
    def compute(count):
        if field is not None:
            return field.coordinates(points, outside=request.outside)
        if request.green:  # phi and psi side by side: the slots' n + m rows
            return np.hstack(cage.green_coordinates(points, outside=request.outside, locations=locations,
                                                    workers=count))
        return cage.coordinates(points, kind=request.kind, outside=request.outside, locations=locations,
                                workers=count, gamma=request.gamma)

    coordinates = request.run(compute, workers)
    if field is not None and locations is not None:
        locations[:] = _locations(request, cage, points)
    if not np.isfinite(coordinates).all():
        raise UndefinedCoordinatesError("the coordinates are not finite: tiny or overlapping cage faces")
    return coordinates


def _locations(request, cage, points):
    """Where the points are (INSIDE, BOUNDARY, OUTSIDE): harmonic coordinates refuse
    points outside (``outside="raise"``) or project them, so only then is it asked."""
    if request.outside == "raise":
        return np.full(len(points), INSIDE, dtype=np.int8)
    return cage.point_locations(points)


def _slots(request, cage, points, choice, workers, field=None):
    """The slots of every point in ``choice``'s storage, chunk by chunk, yielding the
    fraction done; returns them with sparse storage's pairs' columns (else None), their
    locations and the figures measured on them as written (the deviations from the
    exact coordinates on every point)."""
    count, rows = len(points), coordinate_rows(request.kind, len(cage.vertices), len(cage.faces))
    slot_count = rows if choice.slot_count is None else choice.slot_count
    slots = np.empty((count, slot_count), dtype=np.float32)
    indices = np.empty((count, slot_count), dtype=np.int32) if choice.storage == 'SPARSE' else None
    locations = np.empty(count, dtype=np.int8)
    totals = {"min": np.inf, "negative_points": 0, "negative_entries": 0, "max_affine_error": 0.0,
              "weight_magnitude": 0.0}
    precision = similarity = 0.0
    smooth, drag = 0.0, np.zeros(len(cage.vertices))
    faces = cage.faces if request.green else None
    chunk = max(1, CHUNK_ENTRIES * workers // rows)
    for start in range(0, count, chunk):
        part = slice(start, min(start + chunk, count))
        coordinates = _solve(request, cage, points[part], workers, locations[part], field)
        # Green's phi (the first n) sum to 1 and weigh the vertices as the others do.
        summary = coordinate_summary(coordinates[:, :len(cage.vertices)])
        for name, combine in (("min", min), ("negative_points", int.__add__), ("negative_entries", int.__add__)):
            totals[name] = combine(totals[name], summary[name])
        slots[part], pairs = encode(choice, coordinates, cage.vertices)
        if indices is not None:
            indices[part] = pairs
        reproduced = reproduce(choice, slots[part], pairs, rows)
        # The sums as written: float32 rounding of huge coordinates breaks translations.
        weights = reproduced[:, :len(cage.vertices)]
        sums = weights.sum(axis=1)
        totals["max_affine_error"] = max(totals["max_affine_error"], float(np.abs(sums - 1.0).max(initial=0.0)))
        magnitudes = np.abs(weights).sum(axis=1)  # what multiplies the cage's rounding
        totals["weight_magnitude"] = max(totals["weight_magnitude"], float(magnitudes.max(initial=0.0)))
        precision = max(precision, _placed(request, reproduced, cage.vertices, points[part], locations[part]))
        similarity = max(similarity, similarity_deviation(weights @ cage.vertices, sums, points[part], cage.vertices))
        residual = np.subtract(coordinates, reproduced, out=reproduced)
        chunk_smooth, chunk_drag = compact.residual_deviations(residual, cage.vertices, faces=faces)
        smooth, drag = max(smooth, chunk_smooth), np.maximum(drag, chunk_drag)
        # With workers, shared memory: freed before the next chunk's.
        del coordinates, residual
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
    stored fail ``LINEAR_PRECISION`` or ``TRANSLATION_PRECISION``) on the first step or
    where they arise. Closing the
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


def check_grid_memory(cage_vertices, triangles, request):
    """Refuse a harmonic grid that would not fit in memory, before it is solved:
    GridMemoryError with the estimate and the finest resolution that fits.

    Examples
    --------
    >>> from gencoords.tools.bind_plan import BindRequest, GridMemoryError, check_grid_memory
    >>> from gencoords.tools.shapes import icosphere
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


def _plan(points, cage, request):
    count = len(points)
    # Workers are chosen once for the whole plan; each call gives every one a chunk.
    workers = cage.suggested_workers(count) if request.workers is None else request.workers
    field = None
    if request.harmonic:  # solved once, on the grid; the points look it up
        check_grid_memory(cage.vertices, cage.faces, request)
        def solve(progress):
            return request.run(lambda count: harmonic_field(
                cage.vertices, cage.faces, resolution=request.resolution, tolerance=request.tolerance,
                progress=progress, workers=count, solver_tolerance=BIND_SOLVER_TOLERANCE), request.workers)

        nodes = int(np.prod(fit_grid(cage.vertices, request.resolution).shape))
        short = nodes < INLINE_FIELD_NODES and nodes * len(cage.vertices) < INLINE_FIELD_PAIRS
        field = solve(None) if short else (yield from _beside(solve, 0.5))
        yield 0.5
        if request.storage in ('AUTO', 'SPARSE'):
            rows = _two_level_rows(points, request, field)
            if rows is not None:
                report = _report(request, cage, field)
                del field  # its grid's coordinates are copied into the rows: memory for the layout
                return _plan_two_level(points, cage, request, rows, report)
    choice = first_choice(request, count, cage.vertices, cage.faces)
    if field is not None and request.storage == 'AUTO' and choice.storage == 'EXACT':
        choice = replace(choice, reason=f"Automatic: exact ({count} vertices, fewer than the grid nodes their "
                                        "cells use: two levels would save nothing)")
    if choice.storage == 'AUTO':  # estimate on a few points, measure on more only if that says nothing
        few = points[::max(1, count // ESTIMATE_SAMPLES)]
        choice = choose_by_estimate(request, _solve(request, cage, few, None, field=field), cage.vertices,
                                    cage.faces, count)
    if choice is None:
        sample = points[::max(1, count // DEVIATION_SAMPLES)]
        choice = choose_by_measuring(request, _solve(request, cage, sample, None, field=field), cage.vertices,
                                     cage.faces, count)
    slots, indices, locations, figures = yield from _slots(request, cage, points, choice, workers, field)
    if choice.measured and choice.storage in ('COMPACT', 'SPARSE'):
        choice = confirm_compact(choice, max(figures["deviation_smooth"], figures["deviation_drag"]), count,
                                 coordinate_rows(request.kind, len(cage.vertices), len(cage.faces)))
        if choice.storage == 'EXACT':
            slots, indices, locations, figures = yield from _slots(request, cage, points, choice, workers, field)
    # On what will be written; sparse storage and harmonic coordinates place points only
    # approximately by design (their deviations say how far), so only huge coordinates
    # losing their point to float32 rounding are refused.
    if figures["linear_precision"] > LINEAR_PRECISION and choice.storage != 'SPARSE' and field is None:
        raise ImpreciseCoordinatesError("placing", figures["linear_precision"], figures["min_coordinate"])
    if figures["max_affine_error"] > TRANSLATION_PRECISION:  # sparse storage's placing is not checked above
        raise ImpreciseCoordinatesError("sums", figures["max_affine_error"], figures["min_coordinate"],
                                        largest=float(np.abs(slots).max()))
    # Each vertex moves by its weights times the float32 rounding of the cage's positions
    # (half an epsilon of their distance from the origins): the jitter, of the cage's size.
    magnitude = figures.pop("weight_magnitude")
    distance = origin_distance(cage.vertices, request.origins)
    jitter = magnitude * 0.5 * float(np.finfo(np.float32).eps) * distance
    if magnitude > ROUNDING_AMPLIFICATION and jitter > TRANSLATION_PRECISION:
        raise ImpreciseCoordinatesError("rounding", jitter, figures["min_coordinate"], largest=magnitude,
                                        distance=distance)
    return BindPlan(choice.storage, slots, choice.basis, locations, choice.reason, _report(request, cage, field),
                    indices=indices, **figures)


def origin_distance(cage_vertices, origins=None):
    """The cage's largest coordinate measured from ``origins`` ((o, 3), or (3,) for one;
    the frame's origin if None), of the cage's size (its bounding-box diagonal): how far
    float32 rounds its positions, in epsilons of its size.

    >>> import numpy as np
    >>> from gencoords.tools.bind_plan import origin_distance
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    >>> round(origin_distance(cube), 4), round(origin_distance(cube, [-99.0, 0.0, 0.0]), 4)
    (0.5774, 57.735)
    """
    cage_vertices = np.asarray(cage_vertices, dtype=np.float64)
    origins = np.zeros((1, cage_vertices.shape[1])) if origins is None else np.atleast_2d(origins).astype(np.float64)
    distance = max(float(np.abs(cage_vertices - origin).max(initial=0.0)) for origin in origins)
    return distance / float(np.linalg.norm(np.ptp(cage_vertices, axis=0)))


def _report(request, cage, field=None):
    """How this kind behaves in this cage, away from the mesh's own vertices (the figures
    cover those): positivity and well-definedness on a sample."""
    if request.green:
        return "Green: similarity invariant, shape-preserving; any closed cage"
    if field is not None:
        return (f"Harmonic: local, never negative; any closed cage (resolution {field.resolution}: "
                f"{len(field.node_coordinates)} grid nodes)")
    return coordinate_report(cage.vertices, cage.faces, request.kind, gamma=request.gamma,
                             samples=REPORT_SAMPLES, tolerance=request.tolerance).headline


def _two_level_rows(points, request, field):
    """The two levels' rows: each point's 4 interpolating grid nodes and their weights,
    and those nodes' coordinates; a point in a cell at the cage (``field.cut``) is a
    node of its own, its corners all that node (its pairs place it exactly, which the
    grid's nodes cannot). None where there would be more nodes than points (per point
    pairs do better).

    Returns
    -------
    corners : (k, 4) int32
    corner_weights : (k, 4) float
    node_rows : (N, n) float
    """
    corners, corner_weights, cut, columns, values = field.sparse_rows(points, outside=request.outside)
    used, local = sparse.used_nodes(corners[~cut])
    if len(used) + len(columns) > len(points):
        return None
    node_rows = np.empty((len(used) + len(columns), len(field.vertices)))
    node_rows[:len(used)] = field.node_coordinates[used]
    node_rows[len(used):] = 0.0
    np.put_along_axis(node_rows[len(used):], columns, values, axis=1)
    corners = np.empty(corners.shape, dtype=np.int32)
    corners[~cut], corners[cut] = local, len(used) + np.arange(len(columns), dtype=np.int32)[:, None]
    corner_weights[cut] = np.eye(1, corners.shape[1])
    return corners, corner_weights, node_rows


def _plan_two_level(points, cage, request, rows, report):
    """Harmonic coordinates in sparse storage, two levels (:func:`_two_level_rows`): each
    node its fewest pairs over the cage that keep the deviations under AUTO_DEVIATION
    (Automatic; Sparse: ``request.sparse_size``)."""
    corners, corner_weights, node_rows = rows
    automatic = request.storage == 'AUTO'
    # Automatic fills the stored columns (free accuracy); Sparse keeps the count asked for.
    counts = (sparse.automatic_node_slot_counts(len(points), len(node_rows), len(cage.vertices))
              if automatic else (request.sparse_size,))
    layout = sparse.two_level_layout(node_rows, corners, corner_weights, cage.vertices, AUTO_DEVIATION, counts)
    deviation = max(layout.deviation_smooth, layout.deviation_drag)
    reason = (f"{'Automatic: s' if automatic else 'S'}parse in two levels, each vertex its {corners.shape[1]} interpolating grid nodes "
              f"(its own node at the cage), each node its {layout.node_slot_count} largest coordinates (deviation "
              f"{short_number(deviation)} {'<' if deviation < AUTO_DEVIATION else '>'} "
              f"{short_number(AUTO_DEVIATION, 1)})")
    node_sums = layout.node_weights.astype(np.float64).sum(axis=1)
    point_sums = (layout.corner_weights.astype(np.float64) * node_sums[layout.corners]).sum(axis=1)
    every_column = layout.node_slot_count >= len(cage.vertices)
    locations = _locations(request, cage, points)
    # Where the stored weights place each point: the nodes' places, interpolated.
    node_places = np.einsum("nk,nkc->nc", layout.node_weights.astype(np.float64), cage.vertices[layout.node_indices])
    places = sparse.interpolated(node_places, layout.corners, layout.corner_weights)
    miss = np.linalg.norm(places - points, axis=1)
    placed = miss if request.outside != 'project' else miss[locations != OUTSIDE]
    return BindPlan(
        'SPARSE', layout.corner_weights, None, locations, reason, report,
        min_coordinate=float(layout.node_weights.min()) if every_column else 0.0, negative_points=0,
        max_affine_error=float(np.abs(point_sums - 1.0).max(initial=0.0)),
        linear_precision=float(placed.max(initial=0.0) / np.linalg.norm(np.ptp(cage.vertices, axis=0))),
        deviation_smooth=layout.deviation_smooth, deviation_drag=layout.deviation_drag,
        deviation_drag_vertex=layout.deviation_drag_vertex, indices=layout.corners,
        node_indices=layout.node_indices, node_weights=layout.node_weights,
        similarity_deviation=similarity_deviation(places, point_sums, points, cage.vertices))
