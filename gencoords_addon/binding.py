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

import bpy
import numpy as np

from .. import core
from ..core import compact
from . import compat, deformer, mesh_io, messages, preferences
from .properties import KIND_ITEMS, core_name, enum_label

# Blender stores positions as float32: a flat cage face after Apply Rotation, or a mesh
# vertex on the cage surface, is exact only to ~1e-7 of the cage's size, which the
# core's float64 default would call non-convex or outside.
FLOAT32_TOLERANCE = core.tolerances.FLOAT32
METADATA = "gencoords"  # ID property of the binding's node group
FORMAT = 2  # bind data layout; data of another number read as "Bind again"
MODIFIER_NAME = "GenCoords"
# Exact storage while its per-evaluation cost and node group stay moderate: k x n
# multiply-adds (about 1.5 ns each on two cores) and a node per three cage vertices.
EXACT_MAX_PRODUCT = 8_000_000
EXACT_MAX_CAGE_VERTICES = 400
# Coordinates computed per chunk of points: progress and cancel granularity, and the
# bound on the dense float64 block a chunk makes (points x cage vertices).
CHUNK_ENTRIES = 4_000_000  # per worker process
DEVIATION_SAMPLES = 2000  # mesh vertices the compact form's deviation is measured on
REPORT_SAMPLES = 1000  # points inside the cage core.coordinate_report examines at Bind


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
        return self.info["key"]

    @property
    def cage(self):
        """The cage object the modifier reads (None when it was deleted)."""
        return compat.get_modifier_input(self.modifier, deformer.CAGE)

    @property
    def slot_names(self):
        return deformer.slot_attribute_names(self.key, self.info["slot_count"])

    @property
    def basis_names(self):
        if self.info["storage"] != 'COMPACT':
            return None
        return deformer.basis_attribute_names(self.key, self.info["slot_count"])

    def coordinates(self, mesh):
        """The (k, n) float32 coordinates the mesh deforms with (compact: as reproduced
        by its slots and basis), or None when the bind data is missing."""
        slots = deformer.read_triples(mesh, self.slot_names, self.info["slot_count"])
        if slots is None or self.basis_names is None:
            return slots
        basis = deformer.read_triples(mesh, self.basis_names, self.info["slot_count"])
        count = self.info["cage_vertex_count"]
        return None if basis is None else slots @ basis[:count].T

    def coordinate_column(self, mesh, cage_vertex):
        """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
        slots = deformer.read_triples(mesh, self.slot_names, self.info["slot_count"])
        if slots is None:
            return None
        if self.basis_names is None:
            return slots[:, cage_vertex]
        basis = deformer.read_triples(mesh, self.basis_names, self.info["slot_count"])
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


def binding(obj, cage=None):
    """The first binding of ``obj`` (to ``cage`` when given), or None."""
    found = [b for b in bindings(obj) if cage is None or b.cage == cage]
    return found[0] if found else None


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
    if _drives(obj, cage):
        raise BindError(f"'{cage.name}' is itself bound to '{obj.name}': a mesh and its cage "
                        "cannot drive each other")
    if len(obj.data.vertices) == 0:
        raise BindError(f"'{obj.name}' has no vertices to bind")


def choose_storage(setting, mesh_vertices, cage_vertices, compact_size):
    """'EXACT' or 'COMPACT' for the Storage setting ``setting`` ('AUTO' decides by cost).

    Compact storage keeps its basis on the mesh's first n points and needs more cage
    vertices than slots to save anything, so small meshes and cages are always exact.
    """
    if mesh_vertices < cage_vertices or cage_vertices <= compact_size:
        return 'EXACT'
    if setting != 'AUTO':
        return setting
    small = (mesh_vertices * cage_vertices <= EXACT_MAX_PRODUCT
             and cage_vertices <= EXACT_MAX_CAGE_VERTICES)
    return 'EXACT' if small else 'COMPACT'


CAPTURE_GROUP = ".GenCoords capture"


def capture_rest_cage(obj, cage, context):
    """The evaluated cage in the mesh's local space, exactly as Object Info gives it.

    The deformer subtracts this from what its Object Info node reads at every
    evaluation; reading it through the same node (a temporary modifier last in the
    stack) makes the difference exactly zero at rest, so the mesh is unchanged bitwise.
    """
    group = bpy.data.node_groups.new(CAPTURE_GROUP, 'GeometryNodeTree')
    modifier = None
    try:
        group.interface.new_socket(deformer.GEOMETRY, in_out='INPUT',
                                   socket_type='NodeSocketGeometry')
        group.interface.new_socket(deformer.CAGE, in_out='INPUT', socket_type='NodeSocketObject')
        group.interface.new_socket(deformer.GEOMETRY, in_out='OUTPUT',
                                   socket_type='NodeSocketGeometry')
        group_input = group.nodes.new('NodeGroupInput')
        info = group.nodes.new('GeometryNodeObjectInfo')
        info.transform_space = 'RELATIVE'
        group_output = group.nodes.new('NodeGroupOutput')
        group.links.new(group_input.outputs[deformer.CAGE], info.inputs["Object"])
        group.links.new(info.outputs["Geometry"], group_output.inputs[deformer.GEOMETRY])
        modifier = obj.modifiers.new("GenCoords capture", 'NODES')
        modifier.node_group = group
        modifier.show_in_editmode = True
        compat.set_modifier_input(modifier, deformer.CAGE, cage)
        with mesh_io.evaluated_mesh(obj, context.evaluated_depsgraph_get()) as captured:
            return mesh_io.read_positions(captured).copy()
    finally:
        if modifier is not None:
            obj.modifiers.remove(modifier)
        bpy.data.node_groups.remove(group)


@dataclass
class BindResult:
    """Everything ``commit`` writes: arrays for the mesh and the node group, and figures."""

    storage: str
    slots: np.ndarray  # (k, s) float32
    basis: np.ndarray  # (n, s) float64, or None for exact storage
    rest_cage: np.ndarray  # (n, 3) float32, mesh-local, as Object Info gives it
    info: dict  # METADATA


class BindJob:
    """One Bind of ``obj`` to its chosen cage: read and checked on creation (BindError),
    computed by ``steps()``, written by ``commit()``."""

    def __init__(self, obj, context):
        started = time.perf_counter()
        check_inputs(obj)
        self.obj = obj
        settings = obj.gencoords
        self.cage = settings.cage
        self.kind = core_name(settings.kind)
        self.gamma = float(settings.gamma) if core.KIND_TABLE[core.KINDS.index(self.kind)].parameter else None
        self.outside = core_name(settings.outside)
        self.kind_label = enum_label(KIND_ITEMS, settings.kind)
        # Worker processes (None: the core's choice for the whole job; 1: in Blender).
        self.workers = preferences.worker_count(context)
        # Set when the workers failed and Blender computed instead: what to tell the artist.
        self.worker_failure = None
        depsgraph = context.evaluated_depsgraph_get()
        rest = mesh_io.read_positions(obj.data).astype(np.float64)
        undefined = np.flatnonzero(~np.isfinite(rest).all(axis=1))
        if len(undefined):
            raise BindError(f"'{obj.name}' has {len(undefined)} vertices at undefined (NaN or "
                            f"infinite) positions (first: vertex {undefined[0]}): fix or "
                            "delete them, then Bind")
        geometry = mesh_io.read_evaluated_cage(self.cage, depsgraph)
        if len(geometry.triangles) == 0:
            raise BindError(f"The cage '{self.cage.name}' has no faces: it must be a closed "
                            "surface around the mesh (add faces, e.g. Mesh > Convex Hull)")
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
        count, cage_count = len(self.points), len(self.cage_vertices)
        self.storage = choose_storage(settings.storage, count, cage_count, settings.compact_size)
        self.basis = None
        if self.storage == 'COMPACT':
            self.basis = compact.motion_basis(self.cage_vertices, self.triangles,
                                              min(settings.compact_size, cage_count))
        self.info = {
            "format": FORMAT, "kind": self.kind, "outside": self.outside,
            "storage": self.storage, "cage_vertex_count": cage_count,
            "mesh_vertex_count": count, "cage_faces_hash": geometry.faces_hash,
            "cage_non_triangles": geometry.non_triangles,
        }
        if self.gamma is not None:  # ID properties hold no None
            self.info["gamma"] = self.gamma
        self.started = started
        self.result = None

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
        return messages.core_error(self.cage.name, error, self.kind_label, len(self.points),
                                   self.triangle_faces)

    def _compute(self, cage):
        count, cage_count = len(self.points), len(self.cage_vertices)
        slot_count = cage_count if self.basis is None else self.basis.shape[1]
        slots = np.empty((count, slot_count), dtype=np.float32)
        locations = np.empty(count, dtype=np.int8)
        stride = max(1, count // DEVIATION_SAMPLES)
        samples, sample_slots = [], []
        smallest, negative, affine_error = np.inf, 0, 0.0
        # Workers are chosen once for the whole job; each call gives every one a chunk.
        workers = cage.suggested_workers(count) if self.workers is None else self.workers
        start = 0
        while start < count:
            chunk = max(1, CHUNK_ENTRIES * workers // cage_count)
            rows = slice(start, min(start + chunk, count))
            try:
                coordinates, failure = preferences.in_workers_or_blender(
                    lambda workers: cage.coordinates(self.points[rows], kind=self.kind, outside=self.outside,
                                                     locations=locations[rows], workers=workers,
                                                     gamma=self.gamma), workers)
            except core.OutsideCageError:
                raise BindError(self._outside_message(cage)) from None
            except ValueError as error:  # every other core error is a ValueError
                raise BindError(self._core_message(error)) from None
            if failure is not None:  # the rest of the job in Blender too
                self.worker_failure, workers = failure, 1
            if not np.isfinite(coordinates).all():
                raise BindError(f"Binding to '{self.cage.name}' gave undefined coordinates: "
                                "check the cage for tiny or overlapping faces")
            summary = core.coordinate_summary(coordinates)
            smallest = min(smallest, summary["min"])
            negative += summary["negative_points"]
            affine_error = max(affine_error, summary["max_affine_error"])
            slots[rows] = coordinates if self.basis is None else coordinates @ self.basis
            picked = np.arange(-start % stride, rows.stop - start, stride)
            samples.append(coordinates[picked])
            sample_slots.append(slots[rows][picked])
            del coordinates  # with workers, shared memory: freed before the next chunk's
            start = rows.stop
            yield start / count

        deviation = {"deviation_smooth": 0.0, "deviation_drag": 0.0}
        if self.basis is not None:
            sample, sample_slot = np.concatenate(samples), np.concatenate(sample_slots)
            for name, moved in (("deviation_smooth", compact.smooth_test_motion(self.cage_vertices)),
                                ("deviation_drag", compact.vertex_drag_motion(self.cage_vertices))):
                deviation[name] = compact.deviation(sample, sample_slot, self.basis,
                                                    self.cage_vertices, moved)
        # How this kind behaves in this cage, away from the mesh's own vertices (the
        # summary above covers those): positivity and well-definedness on a sample.
        report = core.coordinate_report(self.cage_vertices, self.triangles, self.kind, gamma=self.gamma,
                                        samples=REPORT_SAMPLES, tolerance=FLOAT32_TOLERANCE)
        # What the mesh stores: three slots per vector attribute (the last one padded),
        # and compact storage's basis in as many attributes again.
        stored = count * 3 * -(-slot_count // 3) * 4
        nbytes = stored * (1 if self.basis is None else 2)
        self.info.update(
            slot_count=slot_count, key=secrets.token_hex(3), report=report.headline,
            points_outside=int(np.count_nonzero(locations == core.OUTSIDE)),
            points_on_boundary=int(np.count_nonzero(locations == core.BOUNDARY)),
            min_coordinate=float(smallest), negative_points=int(negative),
            max_affine_error=float(affine_error), nbytes=int(nbytes),
            bind_seconds=time.perf_counter() - self.started, **deviation)
        self.result = BindResult(self.storage, slots, self.basis, self.rest_cage, self.info)

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
        earlier = binding(obj, self.cage)
        others = bindings(obj)
        key = result.info["key"]
        names = deformer.slot_attribute_names(key, result.info["slot_count"])
        basis_names = None
        if result.basis is not None:
            basis_names = deformer.basis_attribute_names(key, result.info["slot_count"])
        group = modifier = None
        try:
            group = deformer.build_group(f"GenCoords: {obj.name} in {self.cage.name}", key,
                                         result.rest_cage, result.info["mesh_vertex_count"],
                                         result.info["slot_count"], basis_names)
            deformer.write_triples(obj.data, names, result.slots)
            if basis_names is not None:
                deformer.write_triples(obj.data, basis_names, result.basis)
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
                obj.modifiers.remove(modifier)
            if group is not None:
                bpy.data.node_groups.remove(group)
            deformer.remove_slots(obj.data, key)
            raise
        if earlier is not None:
            remove(obj, [earlier])
        return binding(obj, self.cage)


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
    try:
        for each in bindings:
            parked[each.key] = deformer.park_slots(obj.data, each.key)
        for name, each in zip(names, bindings):
            group = each.group
            obj.modifiers.remove(each.modifier)
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
