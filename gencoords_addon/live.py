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
# Object.session_uid -> the (k, 3) float32 positions this module last wrote into its mesh:
# a mesh that no longer holds them was edited by someone else.
_written = {}


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


def check_writable(obj, bind):
    """Raise LiveFault when writing positions into the mesh of ``obj`` would be wrong."""
    change = bind.vertex_count_change(obj)
    if change:
        raise LiveFault(f"{change}: deformation stopped; Unbind or Bind again")
    if obj.data.shape_keys is not None:
        # Blender shows the shape-key blocks, not the ``position`` attribute written here.
        raise LiveFault(f"'{obj.name}' has shape keys, which hide the cage's deformation: "
                        "deformation stopped; remove them (Object Data properties > Shape "
                        "Keys) or Unbind")
    if obj.gencoords.edited_while_bound:
        raise LiveFault(f"'{obj.name}' was edited while bound, so it no longer follows the "
                        "cage: Bind again to bind the edited shape, or Unbind to restore "
                        "the shape it was bound with")


def deformed_positions(obj, bind, depsgraph):
    """The mesh's shape for the current cage, in the mesh's local space ((k, 3) float32)."""
    cage = obj.gencoords.bound_cage
    if cage is None:
        raise LiveFault("The cage was deleted or cleared: pick a cage and Bind again, "
                        "or Unbind to restore the rest shape")
    check_writable(obj, bind)
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


def _write(obj, positions):
    """Write ``positions`` into the mesh of ``obj`` and remember them (see ``_written``)."""
    positions = np.asarray(positions, dtype=np.float32)
    mesh_io.write_positions(obj.data, positions)
    _written[obj.session_uid] = positions


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
        _write(obj, deformed_positions(obj, bind, depsgraph))
    return _run(obj, action)


def rest_shape_problem(obj):
    """Why the stored rest shape of ``obj`` cannot be written back, or None if it can."""
    bind = storage.load(obj)
    if bind is None:
        return "its bind data is missing or from another version of GenCoords"
    return bind.vertex_count_change(obj)


def restore_rest(obj):
    """Write the stored rest shape of ``obj`` (bitwise); False when it must not be written."""
    def action():
        bind = _bind_of(obj)
        check_writable(obj, bind)
        _write(obj, bind.rest_positions)
    return _run(obj, action)


def forget(obj):
    """Drop the fault and written positions remembered for ``obj`` (on Bind and Unbind)."""
    faults.pop(obj.session_uid, None)
    _written.pop(obj.session_uid, None)


def _note_mesh_update(obj):
    """After an update of the mesh of ``obj``: flag edits by others, report faults, never
    write (our own writes land here too: writing would loop forever)."""
    bind = storage.load(obj)
    if bind is None:
        return
    written = _written.get(obj.session_uid)
    # Edit Mode keeps its edits in a BMesh; leaving it writes them into the mesh.
    if (obj.mode != 'EDIT' and written is not None
            and not np.array_equal(mesh_io.read_positions(obj.data), written)):
        obj.gencoords.edited_while_bound = True
        del _written[obj.session_uid]  # nothing to compare with until the next write
    try:
        check_writable(obj, bind)
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
    """Follow cage edits (any kind) and moves of the bound object; notice its mesh edits."""
    updated = set()
    moved = set()
    for update in depsgraph.updates:
        uid = update.id.original.session_uid
        updated.add(uid)
        if update.is_updated_transform:
            moved.add(uid)
    for obj in bound_objects(scene):
        if obj.data.session_uid in updated:
            _note_mesh_update(obj)
        if not obj.gencoords.live:
            continue
        cage = obj.gencoords.bound_cage
        if (cage is None or obj.session_uid in moved or cage.session_uid in updated
                or cage.data.session_uid in updated):
            deform(obj, depsgraph)


@_never_raise
def on_frame_change(scene, depsgraph):
    """Playback, scrubbing, ``frame_set`` and every rendered frame (also on render threads)."""
    resync(scene, depsgraph)


def _forget_and_resync():
    """Forget cached state (datablocks may be gone or new) and re-sync with the cages."""
    faults.clear()
    _written.clear()  # the meshes now hold what the file or undo step stored
    storage.clear_cache()  # decoded again on demand
    context = bpy.context
    resync(context.scene, context.evaluated_depsgraph_get())


@_never_raise
def on_file_load(*_args):
    """After loading a file: drop bind data of deleted objects, then re-sync."""
    storage.remove_orphans()
    _forget_and_resync()


@_never_raise
def on_undo_or_redo(*_args):
    """After undo/redo: re-sync (no deleting here: the undo history still refers to it)."""
    _forget_and_resync()


@_never_raise
def on_save(*_args):
    """Before saving: bind data of deleted objects would otherwise be saved forever."""
    storage.remove_orphans()


HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.load_post, on_file_load),
    (bpy.app.handlers.undo_post, on_undo_or_redo),
    (bpy.app.handlers.redo_post, on_undo_or_redo),
    (bpy.app.handlers.save_pre, on_save),
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
    _written.clear()
    storage.clear_cache()
