"""Operators: Bind, Unbind, Show and Clear Coordinate, Make Cage, Bake to Bones (undoable).

Every operator either finishes or leaves the file as it found it: errors become a
report saying what to do (in scripts, ``bpy.ops`` raises RuntimeError with it).
"""

import traceback

import bpy

from ..bind import bindings, cage_maker, service
from ..bind.service import object_mode
from ..errors import BindError, CageError
from .modal import TIMER_HANDLED, SlicedSteps


class MeshOperator:
    """Shared poll: these operators act on the active mesh object."""

    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != 'MESH':
            cls.poll_message_set("The active object must be a mesh")
            return False
        return True


def interactive(context):
    """Whether an operator runs in a window that processes events (progress, Esc)."""
    return not bpy.app.background and context.window is not None


def internal_error(operator, error, changed="nothing was changed"):
    traceback.print_exc()
    operator.report({'ERROR'}, f"GenCoords internal error, {changed} (details in the "
                               f"system console): {error}")
    return {'CANCELLED'}


class OBJECT_OT_gencoords_bind(MeshOperator, bpy.types.Operator):
    """Bind the active mesh to its cage: compute the coordinates of every vertex and add
    the GenCoords modifier that moves the mesh with the cage"""

    bl_idname = "object.gencoords_bind"
    bl_label = "Bind"

    # The Replace Binding question's OK calls execute(), which would block the window:
    # it hands over to a second, modal Bind, told not to ask again.
    replace_asked: bpy.props.BoolProperty(
        name="Replace Asked", options={'HIDDEN', 'SKIP_SAVE'},
        description="Set while the Replace Binding question is shown")
    replace_confirmed: bpy.props.BoolProperty(
        name="Replace Confirmed", options={'HIDDEN', 'SKIP_SAVE'},
        description="The artist already confirmed replacing the binding: do not ask again")

    def _start(self, context):
        try:
            self._job = service.begin(context.active_object, context)
        except BindError as error:
            self.report({'ERROR'}, str(error))
            return False
        return True

    def _finish(self, context):
        report = service.finish(self._job, context)
        self.report({report.level}, report.message)
        return {'FINISHED'}

    def execute(self, context):
        """Run to the end: scripts and background mode (progress printed there)."""
        if self.replace_asked and not self.replace_confirmed and interactive(context):
            # OK in the Replace Binding question: bind as invoke does, with progress and
            # Esc. This call ends here (nothing changed, no undo step of its own).
            bpy.ops.object.gencoords_bind('INVOKE_DEFAULT', replace_confirmed=True)
            return {'CANCELLED'}
        try:
            report = service.bind(context.active_object, context)
        except BindError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:  # the file is unchanged: commit cleans up after itself
            return internal_error(self, error)
        self.report({report.level}, report.message)
        return {'FINISHED'}

    def invoke(self, context, event):
        """In the UI: compute between events, with a progress bar; Esc cancels. Binding a
        cage the mesh is already bound to asks before replacing that binding."""
        if not interactive(context):
            return self.execute(context)
        obj = context.active_object
        if obj.session_uid in service.MODAL_BINDS:
            self.report({'WARNING'}, f"'{obj.name}' is being bound already: wait for it, or Esc")
            return {'CANCELLED'}
        if not self.replace_confirmed and bindings.binding(obj, obj.gencoords.cage) is not None:
            self.replace_asked = True  # OK runs execute(), which comes back here, confirmed
            return context.window_manager.invoke_confirm(
                self, event, title="Replace Binding",
                message=f"'{obj.name}' is already bound to '{obj.gencoords.cage.name}': "
                        "bind again, replacing that binding?")
        try:
            if not self._start(context):
                return {'CANCELLED'}
        except Exception as error:
            return internal_error(self, error)
        self._steps, self._timer = SlicedSteps(service.steps(self._job, context)), None
        self._mesh_uid = self._job.obj.session_uid
        service.MODAL_BINDS.add(self._mesh_uid)
        # A first Bind from the button runs its first slice here, before the window redraws
        # (a short one ends here). A confirmed one (Rebind's question, Auto Rebind) is
        # called from another call, which pushes no undo step: it ends in the event loop.
        fraction = 0.0 if self.replace_confirmed else self._slice(context, first=True)
        if isinstance(fraction, set):  # a short Bind: done before the window redrew
            return fraction
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(0.01, window=context.window)
        window_manager.progress_begin(0.0, 1.0)
        window_manager.modal_handler_add(self)
        self._show(context, fraction)
        return {'RUNNING_MODAL'}

    def _stop(self, context, text=None):
        service.MODAL_BINDS.discard(self._mesh_uid)
        if self._timer is not None:  # the window's progress shown: taken down
            window_manager = context.window_manager
            window_manager.event_timer_remove(self._timer)
            window_manager.progress_end()
            context.workspace.status_text_set(text)
        self._steps.close()

    def _slice(self, context, first=False):
        """A slice of the Bind's steps (``first``: invoke's): its last fraction, or the
        operator's result once they end or fail (the window as it was)."""
        try:
            return self._steps.first() if first else self._steps.advance()
        except StopIteration:
            self._stop(context)
            return self._finish(context)
        except BindError as error:
            self._stop(context)
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:
            self._stop(context)
            return internal_error(self, error)

    def modal(self, context, event):
        if event.type == 'ESC':
            self._stop(context)
            self.report({'WARNING'}, "Bind cancelled: nothing was changed")
            return {'CANCELLED'}
        if event.type != 'TIMER':  # while writing, nothing else may change the mesh
            return {'RUNNING_MODAL'} if self._job.writing else {'PASS_THROUGH'}
        fraction = self._slice(context)
        if isinstance(fraction, set):
            return fraction
        self._show(context, fraction)
        return TIMER_HANDLED

    def _show(self, context, fraction):
        context.window_manager.progress_update(fraction)
        in_blender = "" if self._job.worker_failure is None else ", in Blender: worker processes failed"
        doing = "writing" if self._job.writing else "binding"
        context.workspace.status_text_set(
            f"GenCoords: {doing} '{self._job.obj.name}' {fraction:.0%}{in_blender} (Esc to cancel)")


class OBJECT_OT_gencoords_unbind(MeshOperator, bpy.types.Operator):
    """Remove GenCoords modifiers, their node groups and their bind data: without other
    changes the mesh is exactly as it was before Bind"""

    bl_idname = "object.gencoords_unbind"
    bl_label = "Unbind"

    modifier: bpy.props.StringProperty(
        name="Modifier", options={'SKIP_SAVE'},
        description="The binding's modifier to remove; empty: every binding of the mesh")

    def execute(self, context):
        obj = context.active_object
        found = [b for b in bindings.bindings(obj)
                 if not self.modifier or b.modifier.name == self.modifier]
        if not found:
            what = f"bound with the modifier '{self.modifier}'" if self.modifier else "bound"
            self.report({'ERROR'}, f"'{obj.name}' is not {what}")
            return {'CANCELLED'}
        if obj.library is not None or obj.data.library is not None:
            self.report({'ERROR'}, f"'{obj.name}' is linked from a library and cannot be "
                                   "changed")
            return {'CANCELLED'}
        try:
            with object_mode(context, obj):
                bindings.remove(obj, found)
        except Exception as error:
            removed = getattr(error, "gencoords_removed", [])
            if not removed:
                return internal_error(self, error)
            if len(removed) == len(found):  # only the cleanup after the modifiers failed
                return internal_error(self, error, "the binding was removed but unused "
                                                    "hidden data may remain")
            return internal_error(self, error, f"only {', '.join(removed)} was removed: Unbind "
                                                "again to remove the rest")
        return {'FINISHED'}


class OBJECT_OT_gencoords_make_cage(MeshOperator, bpy.types.Operator):
    """Make a closed cage around the active mesh (convex, of triangles; or tight: hugging
    the mesh, of quads and triangles) and pick it as the mesh's cage"""

    bl_idname = "object.gencoords_make_cage"
    bl_label = "Make Cage"

    shape: bpy.props.EnumProperty(
        name="Shape", default='CONVEX', items=(
            ('CONVEX', "Convex", "A convex hull around the mesh: quick, and every coordinate "
                                 "type accepts it, but it fills the gaps between limbs"),
            ('TIGHT', "Tight", "Hugs the mesh at the offset, keeping the gaps between limbs "
                               "(voxel remesh and decimation): non-convex, so bind it with "
                               "Harmonic (positive weights, each part of the mesh to its own "
                               "part of the cage); Mean Value and Green accept it too")))
    target_vertices: bpy.props.IntProperty(
        name="Vertices", default=100, min=8, soft_min=20, soft_max=500,
        description="About how many vertices the cage gets")
    offset_unit: bpy.props.EnumProperty(
        name="Offset In", default='SHARE', items=(
            ('SHARE', "Share of Size", "The gap is a share of the mesh's size (its bounding "
                                       "box diagonal)"),
            ('DISTANCE', "Distance", "The gap is a distance")))
    margin: bpy.props.FloatProperty(
        name="Margin", default=0.05, min=0.0, soft_max=0.5, subtype='FACTOR',
        description="Gap between the mesh and a convex cage, relative to the mesh's size (0 "
                    "keeps 0.0004: rounding must not leave a vertex outside)")
    offset: bpy.props.FloatProperty(
        name="Offset", default=0.01, min=0.0, soft_max=0.1, subtype='FACTOR',
        description="Gap between the mesh and a tight cage, relative to the mesh's size "
                    "(larger gaps close the space between limbs)")
    distance: bpy.props.FloatProperty(
        name="Distance", default=0.03, min=0.0, soft_max=1.0, subtype='DISTANCE',
        description="Gap between the mesh and the cage")
    keep_gaps: bpy.props.BoolProperty(
        name="Keep Gaps", default=True, description="Tight: an offset above a third of the narrowest gap "
        "between the mesh's parts (fingers) lowered to a sixth of it, so the cage keeps them apart")
    # The dialog's OK calls execute(), which hands over to a modal Make Cage (progress, Esc).
    dialog_shown: bpy.props.BoolProperty(name="Dialog Shown", options={'HIDDEN', 'SKIP_SAVE'})
    confirmed: bpy.props.BoolProperty(name="Confirmed", options={'HIDDEN', 'SKIP_SAVE'},
                                      description="Make the cage between events (progress, Esc)")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.prop(self, "shape", expand=True)
        layout.prop(self, "target_vertices")
        layout.prop(self, "offset_unit", expand=True)
        layout.prop(self, "distance" if self.offset_unit == 'DISTANCE'
                    else "offset" if self.shape == 'TIGHT' else "margin")
        if self.shape == 'TIGHT':
            layout.prop(self, "keep_gaps")

    def invoke(self, context, event):
        """In the UI: the options dialog, then the cage made between events (progress, Esc)."""
        if not interactive(context):
            return self.execute(context)
        if self.confirmed:
            return self._start(context)
        self.dialog_shown = True  # its OK runs execute(), which hands over to a modal one
        return context.window_manager.invoke_props_dialog(self)

    def _arguments(self, context):
        tight = self.shape == 'TIGHT'
        return (context.active_object, context, self.target_vertices, self.offset if tight else self.margin,
                tight, self.distance if self.offset_unit == 'DISTANCE' else None, self.keep_gaps)

    def execute(self, context):
        """Run to the end: scripts and background mode."""
        if self.dialog_shown and not self.confirmed and interactive(context):
            # OK in the dialog: a modal Make Cage does it; this call ends here (no undo step).
            options = {name: getattr(self, name) for name in ("shape", "target_vertices", "offset_unit",
                                                              "margin", "offset", "distance", "keep_gaps")}
            bpy.ops.object.gencoords_make_cage('INVOKE_DEFAULT', confirmed=True, **options)
            return {'CANCELLED'}
        try:
            made = cage_maker.make_cage(*self._arguments(context))
        except Exception as error:
            return self._refused(error)
        return self._made(context.active_object, *made)

    def _refused(self, error):
        if not isinstance(error, CageError):
            return internal_error(self, error)
        self.report({'ERROR'}, f"Cannot make a cage: {error}")
        return {'CANCELLED'}

    def _made(self, obj, cage, worker_failure):
        made = f"Made '{cage.name}' ({len(cage.data.vertices)} vertices) around '{obj.name}'"
        self.report(*(({'INFO'}, made) if worker_failure is None else ({'WARNING'}, f"{made}; {worker_failure}")))
        return {'FINISHED'}

    def _start(self, context):
        self._obj = context.active_object
        self._steps, window_manager = SlicedSteps(cage_maker.make_cage_steps(*self._arguments(context))), context.window_manager
        self._timer = window_manager.event_timer_add(0.01, window=context.window)
        window_manager.progress_begin(0.0, 1.0)
        window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def _stop(self, context):
        """The window as it was; the steps closed (what they made so far removed)."""
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        context.workspace.status_text_set(None)
        self._steps.close()

    def modal(self, context, event):
        if event.type == 'ESC':
            self._stop(context)
            self.report({'WARNING'}, "Make Cage cancelled: nothing was changed")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}  # the mesh was read: nothing else changes it meanwhile
        try:
            fraction = self._steps.advance()
        except StopIteration as done:
            self._stop(context)
            return self._made(self._obj, *done.value)
        except Exception as error:
            self._stop(context)
            return self._refused(error)
        context.window_manager.progress_update(fraction)
        context.workspace.status_text_set(f"GenCoords: making a cage around '{self._obj.name}' "
                                          f"{fraction:.0%} (Esc to cancel)")
        return TIMER_HANDLED


class MESH_OT_gencoords_select_dented_faces(MeshOperator, bpy.types.Operator):
    """Select the faces of the active cage that dent inward (meet a neighbour at an edge
    bent inward): what keeps it from being convex"""

    bl_idname = "mesh.gencoords_select_dented_faces"
    bl_label = "Select Dented Faces"

    def execute(self, context):
        obj = context.active_object
        with object_mode(context, obj):
            count = cage_maker.select_dented_faces(obj)
        if count == 0:
            self.report({'INFO'}, f"No face of '{obj.name}' dents inward: it is convex")
        else:
            self.report({'INFO'}, f"Selected the {count} faces of '{obj.name}' that dent inward")
        return {'FINISHED'}


def draw_select_menu(self, context):
    """Edit Mode's Select menu."""
    self.layout.separator()
    self.layout.operator(MESH_OT_gencoords_select_dented_faces.bl_idname)


SELECT_MENU = bpy.types.VIEW3D_MT_select_edit_mesh


CLASSES = (
    OBJECT_OT_gencoords_make_cage,
    OBJECT_OT_gencoords_bind,
    OBJECT_OT_gencoords_unbind,
    MESH_OT_gencoords_select_dented_faces,
)
