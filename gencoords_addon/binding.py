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
from dataclasses import dataclass, replace
from typing import Optional

import bpy
import numpy as np

from .. import core
from ..core.tools import bind_plan
from . import compat, deformer, mesh_arrays, mesh_io, messages, preferences
from .bind_layout import FORMAT, METADATA, BindData
from .enums import core_name, is_green, kind_label, kind_parameter

# Blender stores positions as float32: a flat cage face after Apply Rotation, or a mesh
# vertex on the cage surface, is exact only to ~1e-7 of the cage's size, which the
# core's float64 default would call non-convex or outside.
FLOAT32_TOLERANCE = core.base.tolerances.FLOAT32
MODIFIER_NAME = "GenCoords"


class BindError(Exception):
    """Binding is impossible; the message says why in Blender's terms."""


@dataclass
class Binding:
    """A committed binding, read back from its modifier."""

    modifier: bpy.types.Modifier
    group: bpy.types.NodeTree
    data: BindData  # its METADATA

    @property
    def key(self):
        return self.data.key

    @property
    def cage(self):
        """The cage object the modifier reads (None when it was deleted)."""
        return compat.get_modifier_input(self.modifier, deformer.CAGE)

    @property
    def deleted_cage(self):
        """Name of the cage deleted while bound (see ``follow_cage``), or None."""
        return self.data.deleted_cage if self.cage is None else None

    @property
    def rest_cage(self):
        """The cage at bind time ((n, 3) float32, the mesh's local space), as the deformer
        keeps it; None when the node group lost it."""
        return deformer.read_rest_cage(self.group, self.data.cage_vertex_count)

    def coordinates(self, mesh):
        """The (k, rows) float32 coordinates the mesh deforms with (compact: as reproduced
        by its slots and basis), or None when the bind data is missing."""
        data = self.data
        slots = mesh_arrays.read_triples(mesh, data.slot_names, data.slot_count)
        if slots is None or data.basis_names is None:
            return slots
        basis = mesh_arrays.read_triples(mesh, data.basis_names, data.slot_count)
        return None if basis is None else slots @ basis[:data.rows].T

    def coordinate_column(self, mesh, cage_vertex):
        """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
        data = self.data
        slots = mesh_arrays.read_triples(mesh, data.slot_names, data.slot_count)
        if slots is None:
            return None
        if data.basis_names is None:
            return slots[:, cage_vertex]
        basis = mesh_arrays.read_triples(mesh, data.basis_names, data.slot_count)
        return None if basis is None else slots @ basis[cage_vertex]


def bindings(obj):
    """The bindings of ``obj``, in modifier stack order."""
    found = []
    for modifier in getattr(obj, "modifiers", ()):
        group = getattr(modifier, "node_group", None) if modifier.type == 'NODES' else None
        stored = group.get(METADATA) if group is not None else None
        if stored is not None:
            found.append(Binding(modifier, group, BindData.from_properties(stored.to_dict())))
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
    data = found.data
    if cage is not None:
        if data.cage_name != cage.name:  # renamed since Bind
            _store(found, replace(data, cage_name=cage.name))
        return None
    if data.deleted_cage is not None or data.cage_name is None:
        return None
    _store(found, replace(data, deleted_cage=data.cage_name))
    # Blender's Delete clears the input without re-evaluating the mesh, which then
    # shows the last deformation until something else changes.
    obj.update_tag()
    return data.cage_name


def _store(found, data):
    """Write ``data`` as the binding ``found``'s metadata."""
    found.group[METADATA] = data.to_properties()
    found.data = data


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
    data: BindData  # METADATA


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
        self.cage, self.kind_label = settings.cage, settings.kind_label
        self.green = is_green(settings.kind)
        # Set when the workers failed and Blender computed instead: what to tell the artist.
        self.worker_failure = None
        geometry = self._read_scene(context)
        self.request = self._request(context)
        # Bind data as far as the scene tells; the plan adds the storage and the figures.
        self.data = BindData(
            format=FORMAT, kind=settings.kind, gamma=settings.gamma, outside=settings.outside,
            cage_vertex_count=len(self.cage_vertices), mesh_vertex_count=len(self.points),
            cage_faces_hash=geometry.faces_hash, cage_non_triangles=geometry.non_triangles,
            cage_name=self.cage.name, cage_face_count=len(self.triangles) if self.green else None)
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
        geometry = mesh_io.read_evaluated_cage(self.cage, depsgraph)
        if len(geometry.triangles) == 0:
            raise BindError(f"The cage '{self.cage.name}' has no faces: it must be a closed "
                            "surface around the mesh (add faces, e.g. Mesh > Convex Hull)")
        flat_axes = zero_scale_axes(self.cage.evaluated_get(depsgraph).matrix_world)
        if flat_axes:
            raise BindError(f"The cage object '{self.cage.name}' is scaled to zero on its "
                            f"{' and '.join(flat_axes)} {'axes' if len(flat_axes) > 1 else 'axis'} "
                            "(or its parent is): give it a "
                            "non-zero Scale (Object Properties > Transform), then Bind")
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
        if self.settings.outside == 'extrapolate':
            raise BindError("Green coordinates do not extrapolate outside the cage: set Outside "
                            "to Report Error or Project, then Bind")
        self.points, self.cage_vertices = rest, self.rest_cage.astype(np.float64)
        if np.linalg.det(world[:3, :3]) < 0.0:
            self.triangles = self.triangles[:, ::-1].copy()
        if len(self.points) < len(self.triangles):
            raise BindError(f"Green coordinates keep the cage's {len(self.triangles)} triangles on the "
                            f"mesh's vertices, and '{self.obj.name}' has only {len(self.points)}: "
                            "subdivide the mesh, use a cage with fewer faces or another type")

    def _request(self, context):
        """What the core plans: the settings in its terms, the workers the preferences ask
        for, and the fallback to Blender's process where they fail."""
        settings = self.settings

        def run(compute, workers):
            if self.worker_failure is not None:  # they failed once: the rest in Blender too
                workers = 1
            result, failure = preferences.in_workers_or_blender(compute, workers)
            if failure is not None:
                self.worker_failure = failure
            return result

        return bind_plan.BindRequest(
            kind=settings.kind, outside=settings.outside, gamma=settings.gamma, storage=settings.storage,
            compact_size=settings.compact_size, workers=preferences.worker_count(context),
            tolerance=FLOAT32_TOLERANCE, run=run)

    def steps(self):
        """Compute the bind data chunk by chunk, yielding the fraction done (0 to 1).

        Raises BindError for a bad cage or vertices outside it. Closing the generator
        early (a cancel) stops the core's worker processes and leaves nothing behind.
        """
        try:
            plan = yield from bind_plan.plan_bind(self.points, self.cage_vertices, self.triangles,
                                                  self.request)
        except core.OutsideCageError:
            raise BindError(self._outside_message()) from None
        except bind_plan.UndefinedCoordinatesError:
            raise BindError(f"Binding to '{self.cage.name}' gave undefined coordinates: "
                            "check the cage for tiny or overlapping faces") from None
        except ValueError as error:  # every other core error is a ValueError
            raise BindError(messages.core_error(self.cage.name, error, self.kind_label, len(self.points),
                                                self.triangle_faces)) from None
        data = replace(self.data, storage=plan.storage, slot_count=plan.slot_count, key=secrets.token_hex(3),
                       nbytes=int(bind_plan.stored_bytes(len(self.points), plan.slot_count, plan.basis is not None)),
                       bind_seconds=time.perf_counter() - self.started, **plan.figures())
        self.result = BindResult(plan.storage, plan.slots, plan.basis, self.triangles if self.green else None,
                                 self.rest_cage, data)

    def _outside_message(self):
        where = core.point_locations(self.points, self.cage_vertices, self.triangles,
                                     tolerance=FLOAT32_TOLERANCE)
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
        data = result.data
        key, names, basis_names, triangle_name = data.key, data.slot_names, data.basis_names, data.triangle_name
        group = modifier = None
        try:
            group = deformer.build_group(f"GenCoords: {obj.name} in {self.cage.name}", key,
                                         result.rest_cage, data.mesh_vertex_count,
                                         data.slot_count, basis_names, triangle_name,
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
            group[METADATA] = data.to_properties()
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
