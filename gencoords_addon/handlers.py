"""Auto Rebind: bind again when the artist leaves Edit Mode after adding or deleting
vertices of a bound mesh. The only handler: the deformation itself needs none."""

import functools
import traceback

import bpy
from bpy.app.handlers import persistent

from . import binding

_was_editing = set()  # Object.session_uid of bound meshes seen in Edit Mode


def _never_raise(handler):
    @functools.wraps(handler)
    def guarded(*args):
        try:
            handler(*args)
        except Exception:  # an exception here would be printed on every update
            traceback.print_exc()
    return persistent(guarded)


def _rebind(obj):
    """Bind ``obj`` again to its bound cage; print why not when that fails."""
    found = binding.binding(obj)
    if obj.gencoords.cage is None:
        obj.gencoords.cage = found.cage
    try:
        job = binding.BindJob(obj, bpy.context)
        job.run()
        job.commit()
    except binding.BindError as error:
        print(f"GenCoords: Auto Rebind of '{obj.name}' failed: {error}")


@_never_raise
def on_depsgraph_update(scene, depsgraph):
    for obj in scene.objects:
        if obj.type != 'MESH' or not obj.gencoords.auto_rebind:
            continue
        uid = obj.session_uid
        if obj.mode == 'EDIT':
            _was_editing.add(uid)
            continue
        if uid not in _was_editing:
            continue
        _was_editing.discard(uid)
        found = binding.binding(obj)
        if found is not None and len(obj.data.vertices) != found.info.get("mesh_vertex_count"):
            _rebind(obj)


def register():
    if on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(on_depsgraph_update)


def unregister():
    if on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(on_depsgraph_update)
    _was_editing.clear()
