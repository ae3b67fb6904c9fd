"""Keeping bound meshes on their cages: the deformation writer and its handlers.

The deformed shape is written into the mesh datablock itself (one ``foreach_get`` of the
evaluated cage, one matrix product, one ``foreach_set``), so viewport, playback and
renders all show it, and a file opened without the extension keeps the last shape.
Handlers never raise: every problem becomes a status line in the panel (``faults``) and
leaves the mesh as it was.
"""

import functools
import traceback

import bpy
import numpy as np
from bpy.app.handlers import persistent

from .. import core
from . import mesh_io, storage

faults = {}  # Object.session_uid -> message shown in the panel until the next success
_writing = False  # guards against re-entry while this module writes meshes


class LiveFault(Exception):
    """The mesh cannot follow its cage right now; the message says why and what to do."""


def bound_objects(scene):
    """Mesh objects of ``scene`` that have bind data."""
    # Handlers run on every update of every file: without bind data (a few texts to
    # look at), skip the walk over a scene's objects, which can number thousands.
    if not storage.any_bind_data():
        return []
    return [obj for obj in scene.objects
            if obj.type == 'MESH' and obj.gencoords.bind_data is not None]


def check_mesh_topology(obj, bind):
    """Raise LiveFault when the mesh's vertex count no longer matches the bind."""
    count = len(obj.data.vertices)
    if count != bind.mesh_vertex_count:
        raise LiveFault(f"'{obj.name}' now has {count} vertices but was bound with "
                        f"{bind.mesh_vertex_count}: deformation stopped; Unbind or Bind again")


def deformed_positions(obj, bind, depsgraph):
    """The mesh's shape for the current cage, in the mesh's local space ((k, 3) float32)."""
    cage = obj.gencoords.bound_cage
    if cage is None:
        raise LiveFault("The cage was deleted or cleared: pick a cage and Bind again, "
                        "or Unbind to restore the rest shape")
    check_mesh_topology(obj, bind)
    # Only positions and a face fingerprint: triangulating on every update would cost
    # more than the deformation on small cages.
    with mesh_io.evaluated_mesh(cage, depsgraph) as cage_mesh:
        positions = mesh_io.read_positions(cage_mesh)
        faces_hash = mesh_io.faces_hash(cage_mesh)
    if len(positions) != bind.cage_vertex_count or faces_hash != bind.cage_faces_hash:
        raise LiveFault(f"The topology of cage '{cage.name}' changed since binding "
                        f"(now {len(positions)} vertices, was "
                        f"{bind.cage_vertex_count}): Bind again or Unbind")
    try:
        cage_to_mesh = mesh_io.cage_to_mesh_matrix(obj, cage, depsgraph)
    except ValueError:
        raise LiveFault(f"'{obj.name}' has zero scale: fix its transform") from None
    cage_positions = mesh_io.transform_points(cage_to_mesh, positions)
    deformed = core.deform(bind.coordinates, cage_positions.astype(np.float32))
    if not np.isfinite(deformed).all():
        raise LiveFault(f"Cage '{cage.name}' has undefined (NaN or infinite) positions: "
                        "the mesh keeps its last shape")
    return deformed


def _write_guarded(obj, positions):
    global _writing
    _writing = True
    try:
        mesh_io.write_positions(obj.data, positions)
    finally:
        _writing = False


def _run(obj, action):
    """Run ``action()`` for ``obj``, turning any failure into a panel fault, never raising."""
    try:
        action()
    except LiveFault as fault:
        faults[obj.session_uid] = str(fault)
        return False
    except Exception as error:  # a handler must never raise into Blender
        traceback.print_exc()
        faults[obj.session_uid] = f"GenCoords internal error (see the console): {error}"
        return False
    faults.pop(obj.session_uid, None)
    return True


def _bind_of(obj):
    bind = storage.load(obj)
    if bind is None:
        raise LiveFault(f"The bind data of '{obj.name}' is missing or from another version of "
                        "GenCoords: Bind again or Unbind")
    return bind


def deform(obj, depsgraph):
    """Write the deformed shape of ``obj``; on any problem record a fault, write nothing."""
    def action():
        bind = _bind_of(obj)
        if obj.mode == 'EDIT':
            raise LiveFault(f"'{obj.name}' is in Edit Mode: deformation paused")
        _write_guarded(obj, deformed_positions(obj, bind, depsgraph))
    return _run(obj, action)


def rest_shape_problem(obj):
    """Why the stored rest shape of ``obj`` cannot be written back, or None if it can."""
    bind = storage.load(obj)
    if bind is None:
        return "its bind data is missing or from another version of GenCoords"
    if bind.mesh_vertex_count != len(obj.data.vertices):
        return (f"its vertex count changed since binding ({bind.mesh_vertex_count} then, "
                f"{len(obj.data.vertices)} now)")
    return None


def restore_rest(obj):
    """Write the stored rest shape of ``obj`` (bitwise); False when it no longer fits."""
    def action():
        bind = _bind_of(obj)
        check_mesh_topology(obj, bind)
        _write_guarded(obj, bind.rest_positions)
    return _run(obj, action)


def _note_topology_fault(obj):
    """Report a vertex count change without writing (and without clearing other faults)."""
    bind = storage.load(obj)
    try:
        if bind is not None:
            check_mesh_topology(obj, bind)
    except LiveFault as fault:
        faults[obj.session_uid] = str(fault)


def apply_live_setting(obj, depsgraph):
    """Show the deformed shape when Live is on, the rest shape when it is off."""
    if obj.gencoords.bind_data is None:
        return
    if obj.gencoords.live:
        deform(obj, depsgraph)
    else:
        restore_rest(obj)


def resync(scene, depsgraph):
    """Bring every live bound object of ``scene`` up to date with its cage."""
    for obj in bound_objects(scene):
        if obj.gencoords.live:
            deform(obj, depsgraph)


def _never_raise(handler):
    """Make ``handler`` persistent (kept across file loads) and unable to raise."""
    @functools.wraps(handler)
    def guarded(*args):
        try:
            handler(*args)
        except Exception:  # an exception here would be printed on every update
            traceback.print_exc()
    return persistent(guarded)


@_never_raise
def on_depsgraph_update(scene, depsgraph):
    """Follow cage edits (any kind) and moves of the bound object itself."""
    if _writing:
        return
    updated = set()
    moved = set()
    for update in depsgraph.updates:
        uid = update.id.original.session_uid
        updated.add(uid)
        if update.is_updated_transform:
            moved.add(uid)
    for obj in bound_objects(scene):
        if not obj.gencoords.live:
            continue
        cage = obj.gencoords.bound_cage
        if (cage is None or obj.session_uid in moved or cage.session_uid in updated
                or cage.data.session_uid in updated):
            deform(obj, depsgraph)
        elif obj.data.session_uid in updated:
            # Our own writes land here too, so only check; writing would loop forever.
            _note_topology_fault(obj)


@_never_raise
def on_frame_change(scene, depsgraph):
    """Playback, scrubbing, ``frame_set`` and every rendered frame (also on render threads)."""
    if not _writing:
        resync(scene, depsgraph)


@_never_raise
def on_file_or_undo(*_args):
    """After loading a file or undo/redo: forget cached state and re-sync with the cages."""
    faults.clear()
    storage.clear_cache()  # datablocks may be gone or new; decoded again on demand
    if not _writing:
        context = bpy.context
        resync(context.scene, context.evaluated_depsgraph_get())


HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.load_post, on_file_or_undo),
    (bpy.app.handlers.undo_post, on_file_or_undo),
    (bpy.app.handlers.redo_post, on_file_or_undo),
)


def register():
    for handlers, handler in HANDLERS:
        if handler not in handlers:
            handlers.append(handler)


def unregister():
    for handlers, handler in HANDLERS:
        if handler in handlers:
            handlers.remove(handler)
    faults.clear()
    storage.clear_cache()
