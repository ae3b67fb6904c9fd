"""Which storage a Bind writes, each decision a return value with its reason
(:class:`StorageChoice`): :func:`choose_storage` (from the sizes alone),
:func:`first_choice` (with its basis), :func:`choose_by_estimate` (Automatic's cheap
first look, on a few points), :func:`choose_by_measuring` (Automatic beyond the cheap
sizes: on a sample of the mesh), :func:`choose_by_playback` (harmonic coordinates:
per-vertex pairs where they play back faster) and :func:`confirm_compact` (after the
deviations were measured on every vertex).
"""

from dataclasses import replace

from ..construction.green import GREEN
from ..storage import Storage, compact, sparse
from ..storage.exact import attribute_bytes
from .request import StorageChoice

__all__ = ["choose_storage", "choose_by_playback", "AUTO_DEVIATION"]

# Automatic storage is exact without measuring while its per-evaluation cost and node
# group stay moderate: k x n multiply-adds (about 1.5 ns each on two cores) and a node
# per three cage vertices.
EXACT_MAX_PRODUCT = 8_000_000
EXACT_MAX_CAGE_VERTICES = 400
# Beyond, it measures: compact with the fewest slots that keep both standard deviations
# (core.storage.compact: smooth motion, worst single-vertex drag) under AUTO_DEVIATION of the
# cage's diagonal, else exact. Slots are chosen on a sample of the mesh with
# AUTO_SAMPLE_MARGIN to spare for the vertices it skipped; after Bind the deviations are
# measured on every vertex, and compact that still misses goes exact.
AUTO_DEVIATION = 1e-3
AUTO_SAMPLE_MARGIN = 0.8
# Exact storage Automatic still chooses when compact deviates more: attribute bytes (a
# million vertices x 642 cage vertices, 2.6 GB, stay compact and the panel says so).
AUTO_EXACT_MAX_BYTES = 2**31
# Points of the sample :func:`choose_by_playback` first tries its most pairs on.
PLAYBACK_FEW_POINTS = 128


def short_number(value, digits=2):
    """``9.6e-4`` for 0.00096 (``digits`` significant): deviations in few characters."""
    return f"{value:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e")


def coordinate_rows(kind, cage_vertex_count, face_count):
    """Coordinates per point: n, or n + m for Green coordinates (``[phi, psi]``)."""
    return cage_vertex_count + (face_count if kind == GREEN else 0)


def choose_storage(setting, mesh_vertices, cage_vertices, compact_size):
    """``EXACT``, ``COMPACT`` or ``AUTO`` (measure): the :class:`Storage` for the setting ``setting``.

    Compact storage keeps its basis on the mesh's first n points and needs more cage
    vertices than slots to save anything, so small meshes and cages are always exact;
    Automatic is exact while exact storage is cheap, and measures beyond.

    Examples
    --------
    >>> from gencoords.planning.storage_choice import choose_storage
    >>> choose_storage('AUTO', 31_658, 162, 36), choose_storage('AUTO', 1_000_000, 642, 36)
    ('EXACT', 'AUTO')
    >>> choose_storage('COMPACT', 5000, 12, 36)  # nothing to save
    'EXACT'
    """
    if setting == Storage.SPARSE:
        return Storage.SPARSE
    if mesh_vertices < cage_vertices or cage_vertices <= compact_size:
        return Storage.EXACT
    if setting != Storage.AUTO:
        return Storage(setting)
    small = (mesh_vertices * cage_vertices <= EXACT_MAX_PRODUCT
             and cage_vertices <= EXACT_MAX_CAGE_VERTICES)
    return Storage.EXACT if small else Storage.AUTO


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
    setting = Storage.AUTO if request.green and request.storage == Storage.SPARSE else request.storage
    storage = choose_storage(setting, mesh_vertices, rows, size)
    if storage == Storage.SPARSE:
        pairs = min(request.sparse_size, rows)
        return StorageChoice(Storage.SPARSE, reason=f"Sparse: each vertex's {pairs} largest coordinates", pairs=pairs,
                             span=request.harmonic)
    reason = None
    if request.storage != Storage.EXACT and storage == Storage.EXACT:
        small = mesh_vertices < rows or rows <= request.compact_size
        why = ("compact saves nothing with this few vertices" if small else
               f"{mesh_vertices} x {rows} coordinates: cheap enough to store them all")
        label = "Automatic: exact" if request.storage == Storage.AUTO else "Exact, not compact"
        reason = f"{label} ({why})"
    basis = _basis(request, cage_vertices, triangles, min(size, rows)) if storage == Storage.COMPACT else None
    return StorageChoice(storage, basis, reason, measured=storage == Storage.AUTO)


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
    if attribute_bytes(mesh_vertices, rows) <= AUTO_EXACT_MAX_BYTES or not saving:
        return StorageChoice(Storage.EXACT, reason=(f"Automatic: exact (compact would need more than {rows // 2} of the "
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
    return StorageChoice(Storage.COMPACT, _basis(request, cage_vertices, triangles, saving[-1]), measured=True)


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
            return StorageChoice(Storage.SPARSE, measured=True, pairs=pairs)
    saving = _saving_sizes(request, cage_vertices, rows)
    basis = _basis(request, cage_vertices, triangles, saving[-1]) if saving else None
    size = _fewest_slots(request, coordinates, basis, cage_vertices, triangles, saving) if saving else None
    if size is None:
        exact = _exact_beyond_half(rows, mesh_vertices, saving)
        if exact is not None:
            return exact
        size = saving[-1]
    return StorageChoice(Storage.COMPACT, basis[:, :size], measured=True)


def choose_by_playback(coordinates, cage_vertices, mesh_vertices, budget):
    """Automatic's per-vertex pairs for harmonic coordinates where they play back faster
    than ``budget`` (seconds per evaluation: two levels', or exact storage's): the fewest
    of ``sparse.SLOT_COUNTS`` whose estimate (``sparse.playback_seconds``: k K gathers in
    K iterations) is under it and whose deviations keep the target on the sample
    ``coordinates`` ((j, n) float64), spanning each point (placed to the float32 rounding,
    so similarities stay exact); None where none does. Its reason waits for the
    deviations on every vertex (:func:`confirm_compact`).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.planning.storage_choice import choose_by_playback
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> rows = np.eye(6)[[0, 1, 2]]  # each point on a cage vertex: one pair does
    >>> choose_by_playback(rows, vertices, 1000, 1e-3).pairs, choose_by_playback(rows, vertices, 1000, 1e-5)
    (4, None)
    """
    cheaper = [pairs for pairs in sparse.SLOT_COUNTS
               if sparse.playback_seconds(mesh_vertices * pairs, pairs) < budget]
    target = AUTO_DEVIATION * AUTO_SAMPLE_MARGIN
    # Deviations are maxima over points and fall as pairs are added: where the most pairs
    # miss on a few points, none pass (most two-level Binds: 0.05 s, not 0.3 s).
    few = coordinates[::max(1, len(coordinates) // PLAYBACK_FEW_POINTS)]
    if not cheaper or sparse.fewest_slots(few, cage_vertices, target, cheaper[-1:])[0] is None:
        return None
    pairs, _, _ = sparse.fewest_slots(coordinates, cage_vertices, target, cheaper)
    return None if pairs is None else StorageChoice(Storage.SPARSE, measured=True, pairs=pairs, span=True)


def confirm_compact(choice, deviation, mesh_vertices, rows):
    """Automatic's compact or sparse ``choice`` once its ``deviation`` (the worse of the
    two) was measured on every vertex: kept with its reason, or exact when the sample
    missed where it deviates most and exact storage fits AUTO_EXACT_MAX_BYTES (the slots
    are then computed again)."""
    label, target = choice.label, short_number(AUTO_DEVIATION, 1)
    exact_bytes = attribute_bytes(mesh_vertices, rows)
    if deviation < AUTO_DEVIATION:
        reason = f"Automatic: {label} (deviation {short_number(deviation)} < {target})"
    elif exact_bytes <= AUTO_EXACT_MAX_BYTES:
        return StorageChoice(Storage.EXACT, reason=(f"Automatic: exact ({label} deviated "
                                              f"{short_number(deviation)} on the whole mesh)"), measured=True)
    else:
        reason = (f"Automatic: {label} (deviation {short_number(deviation)} > {target}; "
                  f"exact would take {exact_bytes / 1e9:.1f} GB: choose Exact for it)")
    return replace(choice, reason=reason, measured=True)

