"""What a Bind asks for and what it writes, in the core's names: :class:`BindRequest`
(the settings), :class:`StorageChoice` (a storage decision with its reason),
:class:`BindPlan` (the slots and the figures measured on them), and the errors a plan
refuses with.
"""

from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ..construction.boundary import BOUNDARY, OUTSIDE
from ..construction.green import GREEN
from ..construction.validation import DEFAULT_TOLERANCE
from ..storage import Storage
from ..surfaces.named import HARMONIC

__all__ = ["BindRequest", "BindPlan", "GridMemoryError", "UndefinedCoordinatesError", "ImpreciseCoordinatesError", "BIND_RESOLUTION", "SPARSE_SIZE"]

# A Bind's grid for harmonic coordinates unless asked otherwise: on the character
# (bench_local.py, 43k vertices, 196-vertex cage; docs/bench_local.md) 48 cells bind in
# 1.15x Mesh Deform p5's time, play back in 0.80x to 1.06x its CPU time and bend a limb
# 1.81 / 15.5 degrees (mean / 99th percentile, against 2.50 / 14.1); 64 took 1.8x as long
# to bind and 32 played back in 1.6x (most of its vertices are in cells at the cage:
# nodes of their own).
BIND_RESOLUTION = 48
# The harmonic solve's relative residual in a Bind: the weights are written as float32 and
# sparse storage drops those below about 1e-4, so 1e-10 (the core's default) would buy
# nothing; this takes 7 conjugate-gradient iterations on the character against 12.
BIND_SOLVER_TOLERANCE = 1e-6
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


@dataclass(frozen=True)
class BindRequest:
    """What to compute: the settings of one Bind, in the core's names.

    Examples
    --------
    >>> from gencoords.planning.request import BindRequest
    >>> from gencoords.storage import Storage
    >>> request = BindRequest("green", outside="project", storage=Storage.EXACT)
    >>> request.green, request.compact_size, request.workers
    (True, 36, None)
    """

    kind: str  # e.g. 'mean_value', 'green'
    outside: str = "raise"  # 'raise', 'project' or 'extrapolate'
    gamma: Optional[float] = None  # the kind's parameter, for the kinds that have one
    storage: Storage = Storage.AUTO  # a Storage (or its value: 'AUTO', 'EXACT', 'COMPACT', 'SPARSE')
    compact_size: int = 36  # compact storage's slots when asked for
    sparse_size: int = SPARSE_SIZE  # sparse storage's pairs per vertex (per grid node: two levels)
    # Harmonic coordinates: cells along the cage's longest side; None: automatic, enough
    # for the cage's narrowest gap (``harmonic.cage_features.automatic_resolution``).
    resolution: Optional[int] = None
    workers: Optional[int] = None  # worker processes (None: the core's choice; 1: none)
    tolerance: float = DEFAULT_TOLERANCE  # relative to the cage's size
    # (o, 3) float: where the deformer's float32 positions are measured from (the objects'
    # origins), in the points' space; None: the points' own origin. Their rounding grows
    # with the cage's distance from these.
    origins: Optional[np.ndarray] = None
    # ``run(compute, workers)`` calls ``compute(workers)``: a front end's hook to fall
    # back to its own process where workers fail (it then passes 1 on later calls).
    # Bytes a harmonic solve may take (None: what the system says is free); a grid that
    # would need more is refused before it is solved (GridMemoryError).
    memory_budget: Optional[int] = None
    run: Callable = _in_this_process
    # (m, 4) int: the cage's faces, a triangle's fourth index -1: mean value on quads
    # (MEAN_VALUE_QUADS) and, given them, harmonic coordinates read them, not the triangles.
    polygons: Optional[np.ndarray] = None

    # What the harmonic grid resolves (a ``harmonic.cage_features.GridChoice``): set by
    # the planner, with ``resolution``, before the solve.
    grid: Optional[object] = None

    @property
    def green(self):
        return self.kind == GREEN

    @property
    def harmonic(self):
        return self.kind == HARMONIC


@dataclass(frozen=True, eq=False)
class StorageChoice:
    """A storage decision: ``storage`` (a :class:`Storage`; ``AUTO``: measure),
    for compact storage its ``basis`` ((rows, s) float64), for sparse storage its ``pairs``
    per vertex, ``reason`` (why, in the panel's words; None where there is nothing to
    say), whether Automatic ``measured``, and whether sparse pairs ``span`` their points
    (harmonic coordinates: ``gencoords.storage.sparse.placed_pairs``)."""

    storage: Storage
    basis: Optional[np.ndarray] = None
    reason: Optional[str] = None
    measured: bool = False
    pairs: Optional[int] = None
    span: bool = False

    @property
    def slot_count(self):
        return self.pairs if self.basis is None else self.basis.shape[1]

    @property
    def label(self):
        """``compact, 24 slots`` / ``sparse, 16 pairs``: the reasons' words for it."""
        return (f"sparse, {self.pairs} pairs" if self.storage == Storage.SPARSE else
                f"{self.storage.lower()}, {self.slot_count} slots")


@dataclass(frozen=True, eq=False)
class BindPlan:
    """What a Bind writes: the slots, compact storage's basis, and the figures measured
    on them as they will be written (float32).

    Examples
    --------
    >>> from gencoords.planning.bind_plan import plan_bind
    >>> from gencoords.planning.request import BindRequest
    >>> from gencoords.cages.shapes import icosphere
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

    storage: str  # a Storage's value as the file stores it: 'EXACT', 'COMPACT' or 'SPARSE'
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
    # How far the mesh as written follows a similarity of the cage (``similarity``), of the
    # cage's size; None for Green coordinates (similarity invariant by their face terms).
    similarity_deviation: Optional[float] = None
    resolution: Optional[int] = None  # harmonic coordinates: the grid's cells along the longest side

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
                 "points_on_boundary", "negative_entries", "node_count", "node_slot_count", "similarity_deviation",
                 "resolution")
        return {name: getattr(self, name) for name in names}

