"""Binding: compute a mesh's bind data with the core, then commit it in one step.

``BindJob(obj, context)`` reads everything it needs from the scene and checks it;
``job.steps()`` computes (a generator yielding the fraction done, so the UI can show
progress and cancel between chunks); ``job.commit()`` then adds the node group, the
mesh's attributes and the modifier, and removes an earlier binding of the same mesh. Nothing in the file changes before ``commit``, and ``commit`` undoes its own
partial work if it fails, so a failed or cancelled Bind leaves the mesh, its modifier
stack and any earlier binding as they were.

A binding is found again from its modifier: a Geometry Nodes modifier whose node group
carries ``METADATA`` (see ``Binding``).
"""

import secrets
import time
from dataclasses import dataclass
from typing import Optional

import bpy
import numpy as np

from .. import core
from ..core.tools import compact
from . import compat, deformer, mesh_arrays, mesh_io, messages, preferences
from .bind_layout import (CAGE_FACE_COUNT, CAGE_NAME, CAGE_VERTEX_COUNT, DELETED_CAGE, FORMAT, FORMAT_KEY,
                          GAMMA, KEY, KIND, MESH_VERTEX_COUNT, METADATA, OUTSIDE, SLOT_COUNT, STORAGE,
                          basis_attribute_names, slot_attribute_names, triangle_attribute_name)
from .enums import core_name, is_green, kind_label, kind_parameter

# Blender stores positions as float32: a flat cage face after Apply Rotation, or a mesh
# vertex on the cage surface, is exact only to ~1e-7 of the cage's size, which the
# core's float64 default would call non-convex or outside.
FLOAT32_TOLERANCE = core.base.tolerances.FLOAT32
MODIFIER_NAME = "GenCoords"
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
REPORT_SAMPLES = 1000  # points inside the cage core.tools.coordinate_report examines at Bind


class BindError(Exception):
    """Binding is impossible; the message says why in Blender's terms."""


@dataclass
class Binding:
    """A committed binding, read back from its modifier."""

    modifier: bpy.types.Modifier
    group: bpy.types.NodeTree
    info: dict  # METADATA, as plain Python values

    @property
    def key(self):
        return self.info[KEY]

    @property
    def cage(self):
        """The cage object the modifier reads (None when it was deleted)."""
        return compat.get_modifier_input(self.modifier, deformer.CAGE)

    @property
    def deleted_cage(self):
        """Name of the cage deleted while bound (see ``follow_cage``), or None."""
        return self.info.get(DELETED_CAGE) if self.cage is None else None

    @property
    def slot_names(self):
        return slot_attribute_names(self.key, self.info[SLOT_COUNT])

    @property
    def basis_names(self):
        if self.info[STORAGE] != 'COMPACT':
            return None
        return basis_attribute_names(self.key, self.info[SLOT_COUNT])

    @property
    def rest_cage(self):
        """The cage at bind time ((n, 3) float32, the mesh's local space), as the deformer
        keeps it; None when the node group lost it."""
        return deformer.read_rest_cage(self.group, self.info[CAGE_VERTEX_COUNT])

    def coordinates(self, mesh):
        """The (k, rows) float32 coordinates the mesh deforms with (compact: as reproduced
        by its slots and basis), or None when the bind data is missing."""
        slots = mesh_arrays.read_triples(mesh, self.slot_names, self.info[SLOT_COUNT])
        if slots is None or self.basis_names is None:
            return slots
        basis = mesh_arrays.read_triples(mesh, self.basis_names, self.info[SLOT_COUNT])
        return None if basis is None else slots @ basis[:self.rows].T

    @property
    def rows(self):
        """Coordinates per mesh vertex: n, or n + m for Green coordinates ([phi, psi])."""
        return self.info[CAGE_VERTEX_COUNT] + self.info.get(CAGE_FACE_COUNT, 0)

    def coordinate_column(self, mesh, cage_vertex):
        """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
        slots = mesh_arrays.read_triples(mesh, self.slot_names, self.info[SLOT_COUNT])
        if slots is None:
            return None
        if self.basis_names is None:
            return slots[:, cage_vertex]
        basis = mesh_arrays.read_triples(mesh, self.basis_names, self.info[SLOT_COUNT])
        return None if basis is None else slots @ basis[cage_vertex]


def bindings(obj):
    """The bindings of ``obj``, in modifier stack order."""
    found = []
    for modifier in getattr(obj, "modifiers", ()):
        group = getattr(modifier, "node_group", None) if modifier.type == 'NODES' else None
        info = group.get(METADATA) if group is not None else None
        if info is not None:
            found.append(Binding(modifier, group, info.to_dict()))
    return found


def binding(obj, cage=None, *, missing_cage=False):
    """The first binding of ``obj`` (to ``cage`` when given; with ``missing_cage``, to
    no cage: it was deleted), or None."""
    if missing_cage:
        found = [b for b in bindings(obj) if b.cage is None]
    else:
        found = [b for b in bindings(obj) if cage is None or b.cage == cage]
    return found[0] if found else None


def is_deleted(obj):
    """Whether the local object ``obj`` was deleted by the artist yet lives on, held by a
    modifier input or a setting: it is in no collection of any scene."""
    return obj is not None and obj.library is None and not obj.users_collection


def follow_cage(obj, found):
    """Keep the binding ``found`` of ``obj`` in step with its cage object: let go of a
    cage the artist deleted (unlinked from every collection but still held: the deformer
    then passes the mesh through), note the cage's name while it lives and, once it is
    gone, which cage that was (``Binding.deleted_cage``, for the panel).

    Returns the name of a cage found gone just now, else None.
    """
    cage = found.cage
    if is_deleted(cage):
        compat.set_modifier_input(found.modifier, deformer.CAGE, None)
        cage = None
    metadata = found.group[METADATA]
    if cage is not None:
        if found.info.get(CAGE_NAME) != cage.name:  # renamed since Bind
            metadata[CAGE_NAME] = found.info[CAGE_NAME] = cage.name
        return None
    if DELETED_CAGE in found.info or CAGE_NAME not in found.info:
        return None
    metadata[DELETED_CAGE] = found.info[DELETED_CAGE] = found.info[CAGE_NAME]
    # Blender's Delete clears the input without re-evaluating the mesh, which then
    # shows the last deformation until something else changes.
    obj.update_tag()
    return found.info[CAGE_NAME]


def remove_orphaned_groups():
    """Delete binding node groups nothing uses any more (left by Apply of the modifier),
    then the helper groups only they used."""
    orphans = [group for group in bpy.data.node_groups
               if group.users == 0 and group.library is None and METADATA in group]
    for group in orphans:
        bpy.data.node_groups.remove(group)
    if orphans:
        deformer.remove_unused_helpers()


def meshes_driven_by(cage):
    """The objects with a binding to ``cage``, in ``bpy.data`` order."""
    return [obj for obj in bpy.data.objects
            if obj.type == 'MESH' and any(found.cage == cage for found in bindings(obj))]


def _drives(obj, cage):
    """Whether ``cage`` follows ``obj``, directly or through chains of bound cages."""
    seen, pending = set(), [cage]
    while pending:
        cage = pending.pop()
        if cage is None or cage.session_uid in seen:
            continue
        if cage == obj:
            return True
        seen.add(cage.session_uid)
        pending.extend(found.cage for found in bindings(cage))
    return False


def check_inputs(obj):
    """Raise BindError unless ``obj`` is a mesh with a usable cage chosen."""
    if obj is None or obj.type != 'MESH':
        raise BindError("Select a mesh object to bind")
    if obj.library is not None or obj.data.library is not None:
        raise BindError(f"'{obj.name}' is linked from the library "
                        f"'{(obj.library or obj.data.library).filepath}' and cannot be "
                        "changed: use Object > Library Override > Make, then Bind")
    if obj.override_library is not None and obj.data.override_library is None \
            and obj.data.library is not None:
        raise BindError(f"The mesh of '{obj.name}' is linked from a library: make it local "
                        "(Object > Relations > Make Local > Object and Data), then Bind")
    cage = obj.gencoords.cage
    if cage is None:
        raise BindError(f"Choose a cage for '{obj.name}' first (GenCoords panel > Cage)")
    if cage == obj:
        raise BindError(f"'{obj.name}' cannot be its own cage: choose another mesh object")
    if cage.type != 'MESH':
        raise BindError(f"The cage '{cage.name}' must be a mesh object")
    if is_deleted(cage):
        raise BindError(f"The cage '{cage.name}' was deleted: pick another cage for "
                        f"'{obj.name}' (GenCoords panel > Cage)")
    if _drives(obj, cage):
        raise BindError(f"'{cage.name}' is itself bound to '{obj.name}': a mesh and its cage "
                        "cannot drive each other")
    if len(obj.data.vertices) == 0:
        raise BindError(f"'{obj.name}' has no vertices to bind")


def zero_scale_axes(matrix):
    """The local axes ('X', 'Y', 'Z') an object matrix (4x4) scales to (nearly) nothing,
    which flattens the object: a list, empty for a usable matrix."""
    lengths = np.linalg.norm(np.array(matrix, dtype=np.float64)[:3, :3], axis=0)
    return [axis for axis, length in zip("XYZ", lengths)
            if not length > FLOAT32_TOLERANCE * lengths.max()]


def choose_storage(setting, mesh_vertices, cage_vertices, compact_size):
    """'EXACT', 'COMPACT' or 'AUTO' (measure at Bind) for the Storage setting ``setting``.

    Compact storage keeps its basis on the mesh's first n points and needs more cage
    vertices than slots to save anything, so small meshes and cages are always exact;
    Automatic is exact while exact storage is cheap, and measures beyond.
    """
    if mesh_vertices < cage_vertices or cage_vertices <= compact_size:
        return 'EXACT'
    if setting != 'AUTO':
        return setting
    small = (mesh_vertices * cage_vertices <= EXACT_MAX_PRODUCT
             and cage_vertices <= EXACT_MAX_CAGE_VERTICES)
    return 'EXACT' if small else 'AUTO'


def stored_bytes(mesh_vertices, slot_count, compact_storage):
    """Bytes of the bind data's attributes: three float32 slots per vector attribute (the
    last one padded), and compact storage's basis in as many attributes again."""
    stored = mesh_vertices * 3 * -(-slot_count // 3) * 4
    return stored * (2 if compact_storage else 1)


def short_number(value, digits=2):
    """``9.6e-4`` for 0.00096 (``digits`` significant): deviations in few characters."""
    return f"{value:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e")


CAPTURE_GROUP = ".GenCoords capture"


def capture_rest_cage(obj, cage, context):
    """The evaluated cage in the mesh's local space, exactly as Object Info gives it.

    The deformer subtracts this from what its Object Info node reads at every
    evaluation; reading it through the same node (a temporary modifier last in the
    stack) makes the difference exactly zero at rest, so the mesh is unchanged bitwise.
    """
    group = deformer.build_capture_group(CAPTURE_GROUP)
    modifier = None
    try:
        modifier = obj.modifiers.new("GenCoords capture", 'NODES')
        modifier.node_group = group
        modifier.show_in_editmode = True
        compat.set_modifier_input(modifier, deformer.CAGE, cage)
        with mesh_io.evaluated_mesh(obj, context.evaluated_depsgraph_get()) as captured:
            return mesh_io.read_positions(captured).copy()
    finally:
        if modifier is not None:
            compat.remove_nodes_modifier(obj, modifier)
        bpy.data.node_groups.remove(group)


@dataclass
class BindResult:
    """Everything ``commit`` writes: arrays for the mesh and the node group, and figures."""

    storage: str
    slots: np.ndarray  # (k, s) float32
    basis: np.ndarray  # (n, s) float64 ((n + m, s) for Green), or None for exact storage
    triangles: np.ndarray  # (m, 3) int: Green coordinates' cage triangles, else None
    rest_cage: np.ndarray  # (n, 3) float32, mesh-local, as Object Info gives it
    info: dict  # METADATA


@dataclass(frozen=True)
class BindSettings:
    """The settings one Bind uses, read once when it starts: editing the panel while a
    modal Bind computes changes nothing in it."""

    cage: bpy.types.Object
    kind: str  # the core's name, e.g. 'mean_value'
    gamma: Optional[float]  # the kind's parameter; None for kinds without one
    outside: str  # the core's name, e.g. 'raise'
    storage: str  # the Storage setting: 'AUTO', 'EXACT' or 'COMPACT'
    compact_size: int
    kind_label: str  # the kind's user-facing name, for messages

    @classmethod
    def of(cls, obj):
        """A snapshot of ``obj.gencoords``."""
        settings = obj.gencoords
        has_gamma = kind_parameter(settings.kind) == "gamma"
        return cls(cage=settings.cage, kind=core_name(settings.kind),
                   gamma=float(settings.gamma) if has_gamma else None,
                   outside=core_name(settings.outside), storage=settings.storage,
                   compact_size=int(settings.compact_size),
                   kind_label=kind_label(settings.kind))


class BindJob:
    """One Bind of ``obj`` to its chosen cage: read and checked on creation (BindError),
    computed by ``steps()``, written by ``commit()``. It reads the object's settings once,
    on creation (``self.settings``, a ``BindSettings``)."""

    def __init__(self, obj, context):
        started = time.perf_counter()
        check_inputs(obj)
        self.obj = obj
        self.settings = settings = BindSettings.of(obj)
        self.cage, self.kind, self.gamma = settings.cage, settings.kind, settings.gamma
        self.outside, self.kind_label = settings.outside, settings.kind_label
        self.green = is_green(self.kind)
        # Worker processes (None: the core's choice for the whole job; 1: in Blender).
        self.workers = preferences.worker_count(context)
        # Set when the workers failed and Blender computed instead: what to tell the artist.
        self.worker_failure = None
        geometry = self._read_scene(context)
        self._choose_storage()
        self.info = {
            FORMAT_KEY: FORMAT, KIND: self.kind, OUTSIDE: self.outside,
            STORAGE: self.storage, CAGE_VERTEX_COUNT: len(self.cage_vertices),
            MESH_VERTEX_COUNT: len(self.points), "cage_faces_hash": geometry.faces_hash,
            "cage_non_triangles": geometry.non_triangles, CAGE_NAME: self.cage.name,
        }
        if self.gamma is not None:  # ID properties hold no None
            self.info[GAMMA] = self.gamma
        if self.green:
            self.info[CAGE_FACE_COUNT] = len(self.triangles)
        self.started = started
        self.result = None

    def _read_scene(self, context):
        """Read the mesh and the cage (world space, checked): sets ``points``,
        ``cage_vertices``, ``triangles``, ``triangle_faces`` and ``rest_cage``; returns
        the cage's ``mesh_io`` geometry."""
        obj = self.obj
        depsgraph = context.evaluated_depsgraph_get()
        rest = mesh_io.read_positions(obj.data).astype(np.float64)
        undefined = np.flatnonzero(~np.isfinite(rest).all(axis=1))
        if len(undefined):
            raise BindError(f"'{obj.name}' has {len(undefined)} vertices at undefined (NaN or "
                            f"infinite) positions (first: vertex {undefined[0]}): fix or "
                            "delete them, then Bind")
        flat_axes = zero_scale_axes(obj.evaluated_get(depsgraph).matrix_world)
        if flat_axes:  # its vertices would be flat in world space, and huge in its own
            raise BindError(messages.zero_scale("mesh", obj.name, flat_axes, "Bind"))
        try:
            geometry = mesh_io.read_evaluated_cage(self.cage, depsgraph)
        except core.CageError as error:  # NaN or infinite vertices: caught before triangles
            raise BindError(messages.cage_error(self.cage.name, error, self.kind_label, ())) from None
        if len(geometry.triangles) == 0:
            raise BindError(f"The cage '{self.cage.name}' has no faces: it must be a closed "
                            "surface around the mesh (add faces, e.g. Mesh > Convex Hull)")
        flat_axes = zero_scale_axes(self.cage.evaluated_get(depsgraph).matrix_world)
        if flat_axes:
            raise BindError(messages.zero_scale("cage", self.cage.name, flat_axes, "Bind"))
        self.triangle_faces = geometry.triangle_faces
        self.rest_cage = capture_rest_cage(obj, self.cage, context)
        if len(self.rest_cage) != len(geometry.positions):
            raise BindError(f"The cage '{self.cage.name}' changed while binding: try again")
        # Coordinates are computed where the artist sees the shapes, in world space
        # (they are affine combinations, so they hold in the mesh's local space too).
        world = np.array(obj.evaluated_get(depsgraph).matrix_world, dtype=np.float64)
        self.points = rest @ world[:3, :3].T + world[:3, 3]
        self.cage_vertices = self.rest_cage.astype(np.float64) @ world[:3, :3].T + world[:3, 3]
        if not np.isfinite(self.cage_vertices).all():
            raise BindError(f"The cage '{self.cage.name}' has vertices at undefined (NaN or "
                            "infinite) positions, or an object has zero scale: fix them, "
                            "then Bind")
        self.triangles = geometry.triangles
        if self.green:
            self._green_frame(rest, world)
        return geometry

    def _green_frame(self, rest, world):
        """Green coordinates are similarity invariant, not affine: they are computed where
        the deformer evaluates them, in the mesh's local space (a mirroring object
        transform turns the cage's triangles inside out there: they are flipped)."""
        if self.outside == 'extrapolate':
            raise BindError("Green coordinates do not extrapolate outside the cage: set Outside "
                            "to Report Error or Project, then Bind")
        self.points, self.cage_vertices = rest, self.rest_cage.astype(np.float64)
        if np.linalg.det(world[:3, :3]) < 0.0:
            self.triangles = self.triangles[:, ::-1].copy()
        if len(self.points) < len(self.triangles):
            raise BindError(f"Green coordinates keep the cage's {len(self.triangles)} triangles on the "
                            f"mesh's vertices, and '{self.obj.name}' has only {len(self.points)}: "
                            "subdivide the mesh, use a cage with fewer faces or another type")

    @property
    def rows(self):
        """Coordinates per mesh vertex: n, or n + m for Green coordinates ([phi, psi])."""
        return len(self.cage_vertices) + (len(self.triangles) if self.green else 0)

    def _basis(self, size):
        """Compact storage's basis of cage motions, (rows, size) float64."""
        if self.green:
            return compact.green_motion_basis(self.cage_vertices, self.triangles, size)
        return compact.motion_basis(self.cage_vertices, self.triangles, size)

    def _choose_storage(self):
        """Set ``storage`` (AUTO: measure in ``steps``), ``storage_choice``, ``measured``
        and, for compact storage, ``basis``."""
        settings = self.settings
        count, cage_count = len(self.points), self.rows
        # Green's basis starts with the 8 columns that keep similarities exact.
        compact_size = max(settings.compact_size, 8) if self.green else settings.compact_size
        self.storage = choose_storage(settings.storage, count, cage_count, compact_size)
        self.storage_choice = None  # why, in the panel's words (set where there is a why)
        self.measured = self.storage == 'AUTO'
        if settings.storage != 'EXACT' and self.storage == 'EXACT':
            small = count < cage_count or cage_count <= settings.compact_size
            why = ("compact saves nothing with this few vertices" if small else
                   f"{count} x {cage_count} coordinates: cheap enough to store them all")
            label = "Automatic: exact" if settings.storage == 'AUTO' else "Exact, not compact"
            self.storage_choice = f"{label} ({why})"
        self.basis = None
        if self.storage == 'COMPACT':
            self.basis = self._basis(min(compact_size, cage_count))

    def steps(self):
        """Compute the bind data chunk by chunk, yielding the fraction done (0 to 1).

        Raises BindError for a bad cage or vertices outside it. Closing the generator
        early (a cancel) stops the core's worker processes and leaves nothing behind.
        """
        try:
            cage = core.Cage(self.cage_vertices, self.triangles, tolerance=FLOAT32_TOLERANCE)
        except ValueError as error:  # every core error about the input is a ValueError
            raise BindError(self._core_message(error)) from None
        try:
            yield from self._compute(cage)
        finally:
            cage.close()

    def _core_message(self, error):
        dented = None
        if isinstance(error, core.CageError) and error.problem == "non_convex":
            dented = np.unique(self.triangle_faces[core.advanced.concave_facets(
                self.cage_vertices, self.triangles, FLOAT32_TOLERANCE)])
        return messages.core_error(self.cage.name, error, self.kind_label, len(self.points),
                                   self.triangle_faces, dented)

    def _coordinates(self, cage, points, workers, locations=None):
        """The core's coordinates of ``points`` ((k, n) float64), its errors as BindError."""
        if self.worker_failure is not None:  # they failed once: the rest in Blender too
            workers = 1

        def compute(count):
            if self.green:  # phi and psi side by side: the slots' n + m rows
                return np.hstack(cage.green_coordinates(points, outside=self.outside, locations=locations,
                                                        workers=count))
            return cage.coordinates(points, kind=self.kind, outside=self.outside, locations=locations,
                                    workers=count, gamma=self.gamma)

        try:
            coordinates, failure = preferences.in_workers_or_blender(compute, workers)
        except core.OutsideCageError:
            raise BindError(self._outside_message(cage)) from None
        except ValueError as error:  # every other core error is a ValueError
            raise BindError(self._core_message(error)) from None
        if failure is not None:
            self.worker_failure = failure
        if not np.isfinite(coordinates).all():
            raise BindError(f"Binding to '{self.cage.name}' gave undefined coordinates: "
                            "check the cage for tiny or overlapping faces")
        return coordinates

    def _choose_by_measuring(self, cage):
        """Automatic storage beyond the cheap sizes: compact with the fewest slots (a
        multiple of three: an attribute holds three) that keep both deviations under the
        target on a sample of the mesh, or exact when compact needs more than half the
        cage's vertices (its slots and basis then take as much as exact storage) and
        exact storage fits AUTO_EXACT_MAX_BYTES; when it does not, compact with that half."""
        count, cage_count = len(self.points), self.rows
        sample = self.points[::max(1, count // DEVIATION_SAMPLES)]
        coordinates = self._coordinates(cage, sample, None)
        basis = self._basis(cage_count)
        smallest = 8 if self.green else self.cage_vertices.shape[1] + 1
        sizes = [size for size in range(3, cage_count, 3) if size >= smallest]
        size, _, _ = compact.smallest_size(coordinates, basis, self.cage_vertices,
                                           AUTO_DEVIATION * AUTO_SAMPLE_MARGIN, sizes, self._green_faces)
        saving = [each for each in sizes if each <= cage_count // 2]
        if size is None or size > cage_count // 2:
            exact_bytes = stored_bytes(count, cage_count, False)
            if exact_bytes <= AUTO_EXACT_MAX_BYTES or not saving:
                needed = f"all {cage_count}" if size is None else f"{size} of the {cage_count}"
                self.storage = 'EXACT'
                self.storage_choice = (f"Automatic: exact (compact would need {needed} slots "
                                       f"for {short_number(AUTO_DEVIATION, 1)})")
                return
            size = saving[-1]
        # Compact: its line waits for the deviations measured on every vertex.
        self.storage, self.basis = 'COMPACT', basis[:, :size]

    @property
    def _green_faces(self):
        """The triangles the deviations are measured with for Green coordinates, else None."""
        return self.triangles if self.green else None

    def _compute(self, cage):
        count, cage_count = len(self.points), self.rows
        # Workers are chosen once for the whole job; each call gives every one a chunk.
        workers = cage.suggested_workers(count) if self.workers is None else self.workers
        if self.storage == 'AUTO':
            self._choose_by_measuring(cage)
        written = yield from self._compute_slots(cage, workers)
        if self.measured and self.storage == 'COMPACT':
            slot_count, target = self.basis.shape[1], short_number(AUTO_DEVIATION, 1)
            worst = max(written["deviation_smooth"], written["deviation_drag"])
            exact_bytes = stored_bytes(count, cage_count, False)
            if worst < AUTO_DEVIATION:
                self.storage_choice = (f"Automatic: compact, {slot_count} slots "
                                       f"(deviation {short_number(worst)} < {target})")
            elif exact_bytes <= AUTO_EXACT_MAX_BYTES:
                # The sample missed where compact deviates most: exact after all.
                self.storage_choice = (f"Automatic: exact (compact with {slot_count} "
                                       f"slots deviated {short_number(worst)} on the whole "
                                       "mesh)")
                self.storage, self.basis = 'EXACT', None
                written = yield from self._compute_slots(cage, workers)
            else:
                self.storage_choice = (
                    f"Automatic: compact, {slot_count} slots (deviation {short_number(worst)} "
                    f"> {target}; exact would take {exact_bytes / 1e9:.1f} GB: choose Exact "
                    "for it)")
        self._check_linear_precision(written)  # on what will be written
        # How this kind behaves in this cage, away from the mesh's own vertices (the
        # summary covers those): positivity and well-definedness on a sample.
        report = None if self.green else core.tools.coordinate_report(
            self.cage_vertices, self.triangles, self.kind, gamma=self.gamma, samples=REPORT_SAMPLES,
            tolerance=FLOAT32_TOLERANCE)
        slot_count = written.pop("slot_count")
        slots, locations = written.pop("slots"), written.pop("locations")
        self.info.update({STORAGE: self.storage, SLOT_COUNT: slot_count,
                          KEY: secrets.token_hex(3)})
        self.info.update(
            report=("Green: similarity invariant, shape-preserving; any closed cage" if report is None
                    else report.headline),
            points_outside=int(np.count_nonzero(locations == core.OUTSIDE)),
            points_on_boundary=int(np.count_nonzero(locations == core.BOUNDARY)),
            nbytes=int(stored_bytes(count, slot_count, self.basis is not None)),
            bind_seconds=time.perf_counter() - self.started, **written)
        if self.storage_choice is not None:
            self.info["storage_choice"] = self.storage_choice
        self.result = BindResult(self.storage, slots, self.basis, self.triangles if self.green else None,
                                 self.rest_cage, self.info)

    def _compute_slots(self, cage, workers):
        """Compute the slots in ``self.storage`` chunk by chunk, yielding the fraction done;
        returns them with the figures measured on them, as they will be written: the
        deviations from the exact coordinates (slots and basis in float32) on every vertex."""
        count, cage_count = len(self.points), self.rows
        slot_count = cage_count if self.basis is None else self.basis.shape[1]
        slots = np.empty((count, slot_count), dtype=np.float32)
        locations = np.empty(count, dtype=np.int8)
        stored_basis = (None if self.basis is None else  # as written: float32
                        self.basis.astype(np.float32).astype(np.float64))
        smallest, negative, affine_error, precision = np.inf, 0, 0.0, 0.0
        smooth, drag = 0.0, np.zeros(len(self.cage_vertices))
        chunk = max(1, CHUNK_ENTRIES * workers // cage_count)
        for start in range(0, count, chunk):
            rows = slice(start, min(start + chunk, count))
            coordinates = self._coordinates(cage, self.points[rows], workers, locations[rows])
            # Green's phi (the first n) sum to 1 and weigh the vertices as the others do.
            summary = core.tools.coordinate_summary(coordinates[:, :len(self.cage_vertices)])
            smallest = min(smallest, summary["min"])
            negative += summary["negative_points"]
            affine_error = max(affine_error, summary["max_affine_error"])
            slots[rows] = coordinates if self.basis is None else coordinates @ self.basis
            reproduced = (slots[rows].astype(np.float64) if stored_basis is None else
                          slots[rows] @ stored_basis.T)
            precision = max(precision, self._linear_precision(reproduced, rows, locations[rows]))
            residual = np.subtract(coordinates, reproduced, out=reproduced)
            chunk_smooth, chunk_drag = compact.residual_deviations(residual, self.cage_vertices,
                                                                   faces=self._green_faces)
            smooth, drag = max(smooth, chunk_smooth), np.maximum(drag, chunk_drag)
            # With workers, shared memory: freed before the next chunk's.
            del coordinates, reproduced, residual
            yield rows.stop / count
        return {"slot_count": slot_count, "slots": slots, "locations": locations,
                "min_coordinate": float(smallest), "negative_points": int(negative),
                "max_affine_error": float(affine_error), "linear_precision": float(precision),
                "deviation_smooth": float(smooth),
                "deviation_drag": float(drag.max(initial=0.0)),
                "deviation_drag_vertex": int(np.argmax(drag))}

    def _linear_precision(self, stored, rows, locations):
        """``core.tools.linear_precision`` of coordinates as stored, for ``self.points[rows]``
        (Green coordinates also weigh normals: 0; projected points are not placed where
        they are: left out)."""
        if self.green:
            return 0.0
        placed = slice(None) if self.outside != 'project' else locations != core.OUTSIDE
        return core.tools.linear_precision(stored[placed], self.cage_vertices, self.points[rows][placed])

    def _check_linear_precision(self, written):
        """BindError when the coordinates as stored do not place the mesh's vertices."""
        error = written["linear_precision"]
        if error <= core.base.tolerances.LINEAR_PRECISION:
            return
        raise BindError(
            f"{self.kind_label} coordinates{messages.gamma_words(self.gamma)} in the cage "
            f"'{self.cage.name}' are too large to store (smallest {written['min_coordinate']:.3g}): as "
            f"stored they place the vertices of '{self.obj.name}' only to {short_number(error)} of the "
            "cage's size, and the mesh would stray as the cage moves. Choose a Gamma between -1 and "
            "-0.5, or another Type")

    def _outside_message(self, cage):
        where = cage.point_locations(self.points)
        return messages.outside_error(self.cage.name, int(np.count_nonzero(where == core.OUTSIDE)),
                                      len(self.points))

    def run(self, report=None):
        """Compute to the end (scripts, background mode); ``report(fraction)`` on the way."""
        for fraction in self.steps():
            if report is not None:
                report(fraction)
        return self.result

    def commit(self):
        """Write the computed binding into the file; returns the new ``Binding``.

        An earlier binding of the mesh to the same cage is replaced (its place in the
        stack is kept); a binding to another cage is added after the mesh's other
        bindings (each changes nothing at rest, so they compose). On any failure
        everything this call added is removed again and the error raised.
        """
        obj, result = self.obj, self.result
        # The binding to this cage, else one whose cage is gone: Bind after picking
        # another cage replaces it.
        earlier = binding(obj, self.cage) or binding(obj, missing_cage=True)
        others = bindings(obj)
        key = result.info[KEY]
        names = slot_attribute_names(key, result.info[SLOT_COUNT])
        basis_names = None
        if result.basis is not None:
            basis_names = basis_attribute_names(key, result.info[SLOT_COUNT])
        triangle_name = None if result.triangles is None else triangle_attribute_name(key)
        group = modifier = None
        try:
            group = deformer.build_group(f"GenCoords: {obj.name} in {self.cage.name}", key,
                                         result.rest_cage, result.info[MESH_VERTEX_COUNT],
                                         result.info[SLOT_COUNT], basis_names, triangle_name,
                                         0 if result.triangles is None else len(result.triangles))
            mesh_arrays.write_triples(obj.data, names, result.slots)
            if basis_names is not None:
                mesh_arrays.write_triples(obj.data, basis_names, result.basis)
            if triangle_name is not None:  # vertex indices, exact in float32 below 2^24
                mesh_arrays.write_triples(obj.data, [triangle_name], result.triangles.astype(np.float32))
            modifier = obj.modifiers.new(MODIFIER_NAME, 'NODES')
            modifier.node_group = group
            modifier.show_in_editmode = True
            compat.set_modifier_input(modifier, deformer.CAGE, self.cage)
            stack = list(obj.modifiers)
            if earlier is not None:
                position = stack.index(earlier.modifier)
            else:
                position = stack.index(others[-1].modifier) + 1 if others else 0
            compat.move_modifier(obj, modifier, position)
            group[METADATA] = result.info
        except Exception:
            if modifier is not None:
                compat.remove_nodes_modifier(obj, modifier)
            if group is not None:
                bpy.data.node_groups.remove(group)
            deformer.remove_slots(obj.data, key)
            raise
        if earlier is not None:
            name = earlier.modifier.name
            remove(obj, [earlier])
            modifier.name = name  # the new one was "GenCoords.001" beside it: Rebind keeps the name
        return binding(obj, self.cage)


def keys_used_elsewhere(obj):
    """Keys of the bindings that other objects sharing the mesh of ``obj`` (linked
    duplicates, Alt+D) deform with: their bind data on the shared mesh must stay."""
    return {found.key for other in bpy.data.objects
            if other != obj and other.type == 'MESH' and other.data == obj.data
            for found in bindings(other)}


def remove(obj, bindings):
    """Delete ``bindings`` of ``obj`` (their modifiers, node groups and attributes), all
    or, as far as Blender lets anything fail, none.

    The attributes are parked first (renamed, no copy: :func:`deformer.park_slots`) and
    put back if anything fails before a modifier is gone; then the modifiers go (the step
    after which the mesh no longer follows the cage), then the parked attributes and the
    node groups nobody uses any more. The mesh data is left exactly as it was before
    those Binds.

    Returns
    -------
    removed : list of str
        Names of the modifiers removed: all of them, or on an exception (re-raised with
        this list as its ``gencoords_removed`` attribute) the ones already gone.
    """
    names = [each.modifier.name for each in bindings]  # a removed modifier's RNA is gone
    parked, removed = {}, []
    shared = keys_used_elsewhere(obj)
    try:
        for each in bindings:  # bind data a linked duplicate deforms with stays
            parked[each.key] = {} if each.key in shared else deformer.park_slots(obj.data, each.key)
        for name, each in zip(names, bindings):
            group = each.group
            compat.remove_nodes_modifier(obj, each.modifier)
            removed.append(name)
            deformer.drop_parked_slots(obj.data, parked[each.key])
            if group.users == 0:
                bpy.data.node_groups.remove(group)
        deformer.remove_unused_helpers()
    except Exception as error:
        for name, each in zip(names, bindings):
            if name not in removed:  # still bound: its data back
                deformer.put_back_slots(obj.data, parked.get(each.key, {}))
        error.gencoords_removed = removed
        raise
    return removed
