"""The one depsgraph handler (the deformation itself needs none): Auto Rebind, which
binds again when the artist leaves Edit Mode after adding or deleting vertices of a
bound mesh, and the housekeeping after the artist's Delete and Apply.

Blender's Delete of a bound cage (X, the outliner) either clears the references to it,
without re-evaluating the mesh (which keeps its last deformation), or, where it keeps
the object for its other users, unlinks it from every collection, and the modifier input
and the Cage setting would keep it alive and driving the mesh. Either way, as with Mesh
Deform, the binding lets go of it: the mesh is passed through unchanged, the panel says
which cage was deleted, and the orphaned cage is neither saved nor kept by a purge.
Ctrl+Z of the Delete brings back the state before it, references and all.
"""

import functools
import traceback

import bpy
from bpy.app.handlers import persistent

from . import binding

_was_editing = set()  # Object.session_uid of bound meshes seen in Edit Mode
_cage_names = {}  # Object.session_uid -> name, of the bound cages at the last housekeeping


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


def release_deleted_cages():
    """Let go of deleted cages (see the module's docstring and ``binding.follow_cage``)
    and clear the Cage settings holding them. Returns the names of the cages let go of."""
    released = set()
    _cage_names.clear()
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        for found in binding.bindings(obj):
            name = binding.follow_cage(obj, found)
            if name is not None:
                released.add(name)
            cage = found.cage
            if cage is not None:
                _cage_names[cage.session_uid] = cage.name
        settings = getattr(obj, "gencoords", None)
        if settings is not None and binding.is_deleted(settings.cage):
            settings.cage = None
    return released


def _housekeeping_needed(depsgraph):
    """Whether this update may have deleted or unlinked objects, applied or added a
    binding's modifier (Blender then updates a scene, collection or node group too, which
    a drag does not) or renamed a cage: the housekeeping scans every object (35 ms for
    10,000), too much for every drag."""
    for update in depsgraph.updates:
        changed = update.id.original
        if isinstance(changed, (bpy.types.Collection, bpy.types.Scene, bpy.types.NodeTree)):
            return True
        if isinstance(changed, bpy.types.Object) \
                and _cage_names.get(changed.session_uid, changed.name) != changed.name:
            return True
    return False


@_never_raise
def on_depsgraph_update(scene, depsgraph):
    if _housekeeping_needed(depsgraph):
        release_deleted_cages()
        binding.remove_orphaned_groups()
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
    _cage_names.clear()
