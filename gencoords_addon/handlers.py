"""The handlers (the deformation itself needs none): Auto Rebind, which binds again when
the artist leaves Edit Mode after adding or deleting vertices of a bound mesh, and the
housekeeping after the artist's Delete and Apply, also on opening a file (``load_post``).

In a window, Auto Rebind hands the rebind to the Bind operator's invoke path (progress
bar, Esc cancels), started by a timer just after the update that noticed it (a
depsgraph handler must not run operators, and would block the window); in background
mode (no timers run, nothing to show) it binds there and then, through the same Bind
service as the operator (``bind.service.bind``).

Blender's Delete of a bound cage (X, the outliner) either clears the references to it,
without re-evaluating the mesh (which keeps its last deformation), or, where it keeps
the object for its other users, unlinks it from every collection, and the modifier input
and the Cage setting would keep it alive and driving the mesh. Either way, as with Mesh
Deform, the binding lets go of it: the mesh is passed through unchanged, the panel says
which cage was deleted, and the orphaned cage is neither saved nor kept by a purge.
Ctrl+Z of the Delete brings back the state before it, references and all: Blender's undo
keeps in memory the data whose saved state is the same in both steps, which the letting
go changed after the Delete's step was saved, so ``on_undo_or_redo`` gives each binding
back the cage it let go of where the undo brought that cage back.
"""

import functools
import traceback

import bpy
from bpy.app.handlers import persistent

from .bake import bones
from .bind import bindings, service
from .errors import BindError

_was_editing = set()  # Object.session_uid of bound meshes seen in Edit Mode
_cage_names = {}  # Object.session_uid -> name, of the bound cages at the last housekeeping
_let_go = {}  # (mesh session_uid, binding key) -> session_uid of the deleted cage it let go of
_bound_cages = {}  # the same, of the cages bound at the last housekeeping
_rebind_pending = set()  # Object.session_uid of meshes the timer is to rebind in a window
REBIND_RETRY_SECONDS = 0.5  # how often the timer looks again while a modal Bind of the mesh runs


def _never_raise(handler):
    @functools.wraps(handler)
    def guarded(*args):
        try:
            handler(*args)
        except Exception:  # an exception here would be printed on every update
            traceback.print_exc()
    return persistent(guarded)


def _needs_rebind(obj):
    """Whether the bound mesh ``obj`` (out of Edit Mode) has another vertex count than
    at Bind."""
    found = bindings.binding(obj)
    return found is not None and len(obj.data.vertices) != found.data.mesh_vertex_count


def _in_window():
    """Whether Blender runs with windows that process events (and timers)."""
    return not bpy.app.background and bool(bpy.context.window_manager.windows)


def _rebind(obj):
    """Bind ``obj`` again to its bound cage; print why not when that fails."""
    found = bindings.binding(obj)
    if obj.gencoords.cage is None:
        obj.gencoords.cage = found.cage
    if _in_window():
        _rebind_pending.add(obj.session_uid)
        if not bpy.app.timers.is_registered(rebind_in_window):
            bpy.app.timers.register(rebind_in_window, first_interval=0.0)
        return
    try:
        service.bind(obj, bpy.context)
    except BindError as error:
        print(f"GenCoords: Auto Rebind of '{obj.name}' failed: {error}")


def _window_showing(obj):
    """A window whose view layer has ``obj``, and its largest 3D Viewport (else its
    largest area) with that area's main region; None where no window shows it."""
    for window in bpy.context.window_manager.windows:
        if window.view_layer.objects.get(obj.name) != obj:
            continue
        areas = sorted(window.screen.areas, key=lambda a: (a.type == 'VIEW_3D', a.width * a.height))
        if not areas:
            continue
        area = areas[-1]
        region = next((r for r in area.regions if r.type == 'WINDOW'), None)
        return window, area, region
    return None


def rebind_in_window():
    """Timer (runs once): start the modal Bind of each mesh noted by ``_rebind``, in a
    window showing it, as if the artist had confirmed Replace Binding. The mesh may be
    gone (deleted, undone), back in Edit Mode (its next exit notes it again) or already
    rebound by then: it is then left alone. While a modal Bind of the mesh computes, it
    waits for it (looking again every REBIND_RETRY_SECONDS) rather than start a second."""
    pending = set(_rebind_pending)
    _rebind_pending.clear()
    for obj in [o for o in bpy.data.objects if o.session_uid in pending]:
        if obj.session_uid in service.MODAL_BINDS:
            _rebind_pending.add(obj.session_uid)
            continue
        try:
            if obj.type != 'MESH' or obj.mode == 'EDIT' or not _needs_rebind(obj):
                continue
            shown = _window_showing(obj)
            if shown is None:
                print(f"GenCoords: Auto Rebind of '{obj.name}': no window shows it, Bind it")
                continue
            window, area, region = shown
            with bpy.context.temp_override(window=window, area=area, region=region,
                                           active_object=obj, object=obj,
                                           selected_objects=[obj]):
                bpy.ops.object.gencoords_bind('INVOKE_DEFAULT', replace_confirmed=True)
        except Exception:  # the next mesh still gets its rebind
            traceback.print_exc()
    return REBIND_RETRY_SECONDS if _rebind_pending else None


def release_deleted_cages():
    """Let go of deleted cages (see the module's docstring and ``bindings.follow_cage``;
    baked rigs too, ``bones.let_go_of_deleted_cage``) and clear the Cage settings holding
    them. Returns the names of the cages bindings let go of."""
    released = set()
    _cage_names.clear()
    for obj in bpy.data.objects:
        if obj.library is not None:
            continue
        for found in bindings.bindings(obj):
            held = (obj.session_uid, found.key)
            if found.cage is not None and not bindings.is_deleted(found.cage):
                _bound_cages[held] = found.cage.session_uid
            name = bindings.follow_cage(obj, found)
            if name is not None:
                released.add(name)
                if held in _bound_cages:
                    _let_go[held] = _bound_cages.pop(held)
            cage = found.cage
            if cage is not None:
                _cage_names[cage.session_uid] = cage.name
        settings = getattr(obj, "gencoords", None)
        if settings is not None and bindings.is_deleted(settings.cage):
            settings.cage = None
        bones.let_go_of_deleted_cage(obj)
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
        bindings.remove_orphaned_groups()
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
        if _needs_rebind(obj):
            _rebind(obj)


@_never_raise
def on_undo_or_redo(*_):
    """Ctrl+Z (or Ctrl+Shift+Z) that brought back a deleted cage (in a scene again) gives
    the bindings that let go of it their cage back (see the module's docstring)."""
    objects = {obj.session_uid: obj for obj in bpy.data.objects}
    for (mesh_uid, key), cage_uid in list(_let_go.items()):
        obj, cage = objects.get(mesh_uid), objects.get(cage_uid)
        if obj is None or cage is None or bindings.is_deleted(cage):
            continue
        found = next((b for b in bindings.bindings(obj) if b.key == key and b.cage is None), None)
        del _let_go[mesh_uid, key]
        if found is None:
            continue
        bindings.hold_cage(obj, found, cage)
        if obj.gencoords.cage is None:
            obj.gencoords.cage = cage


@_never_raise
def on_load_post(*_):
    """A file opened: nothing of the previous one is pending, and a cage deleted while
    an older GenCoords kept it alive (saved with the file) is let go of now, not at the
    first update touching a scene."""
    _was_editing.clear()
    _rebind_pending.clear()
    _let_go.clear()
    _bound_cages.clear()
    release_deleted_cages()
    bindings.remove_orphaned_groups()


HANDLERS = ((bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
            (bpy.app.handlers.load_post, on_load_post),
            (bpy.app.handlers.undo_post, on_undo_or_redo),
            (bpy.app.handlers.redo_post, on_undo_or_redo))


def register():
    for handlers, handler in HANDLERS:
        if handler not in handlers:
            handlers.append(handler)


def unregister():
    for handlers, handler in HANDLERS:
        if handler in handlers:
            handlers.remove(handler)
    if bpy.app.timers.is_registered(rebind_in_window):
        bpy.app.timers.unregister(rebind_in_window)
    _was_editing.clear()
    _cage_names.clear()
    _rebind_pending.clear()
    _let_go.clear()
    _bound_cages.clear()
