"""Bake to Bones: the operator (Object > Animation, and the panel) replacing a binding by
an armature, a bone per cage vertex (``bake.bones``) or a few bones fitted to the
deformation (``bake.fitted``: modal in a window, its fit in a thread)."""

import bpy

from ..bake import bones, fitted
from ..bind import bindings
from ..bind.service import object_mode
from ..errors import BakeError
from .modal import TIMER_HANDLED, SlicedSteps
from .operators import MeshOperator, interactive, internal_error

ALL_INFLUENCES = "0: All influences, every weight kept (exact)"
FITTED_DEFAULT_INFLUENCES = f"0: {fitted.DEFAULT_INFLUENCES} influences per vertex, as game engines read"

class OBJECT_OT_gencoords_bake_bones(MeshOperator, bpy.types.Operator):
    """Replace the binding by an armature (a bone per cage vertex, following it, keyframed
    over the scene's frame range) and vertex groups holding the coordinates, or (Fitted)
    a few rotating bones and 4 weights per vertex fitted to the deformation, for game
    engines and exporters such as glTF"""

    bl_idname = "object.gencoords_bake_bones"
    bl_label = "Bake to Bones"

    max_influences: bpy.props.IntProperty(
        name="Max Influences", default=0, min=0, max=8,
        description="Weights kept per vertex, renormalised, at most 8 (game engines take 4 or 8; "
                    "three.js reads 4); 0 keeps all, which is exact (Fitted: 0 fits 4)")
    mode: bpy.props.EnumProperty(
        name="Mode", default='CAGE_VERTICES', items=(
            ('CAGE_VERTICES', "Bone per Cage Vertex",
             "A bone per cage vertex, following it; the coordinates as weights (exact with "
             "every weight kept; game engines keep 4, which cannot follow the cage)"),
            ('FITTED', "Fitted (game engines)",
             "A few rotating bones and at most Max Influences weights per vertex (0: 4), "
             "fitted to the deformation over the frame range and keyframed; any kind")))
    bones: bpy.props.IntProperty(
        name="Bones", default=fitted.DEFAULT_BONES, min=1, max=255,
        description="Fitted: bones to seed (those left weighing no vertex are dropped); "
                    "more follow the cage more closely, and cost more to fit and to play")
    use_scene_range: bpy.props.BoolProperty(
        name="Scene Frame Range", default=True,
        description="Fitted: sample the scene's frame range; off: Start to End")
    frame_start: bpy.props.IntProperty(name="Start", default=1,
                                       description="Fitted: the first frame sampled")
    frame_end: bpy.props.IntProperty(name="End", default=250,
                                     description="Fitted: the last frame sampled")
    fitted_confirmed: bpy.props.BoolProperty(
        name="Fitted Confirmed", options={'HIDDEN', 'SKIP_SAVE'},
        description="Set on the modal Fitted bake that the options dialog hands over to")
    keyframes: bpy.props.BoolProperty(
        name="Keyframe Cage Motion", default=True,
        description="Also keyframe the bones on the cage at every frame of the scene's "
                    "range: exporters such as glTF write keyframes, not the constraints "
                    "that make the bones follow the cage in Blender")

    @classmethod
    def poll(cls, context):
        if not super().poll(context):
            return False
        if bindings.binding(context.active_object) is None:
            cls.poll_message_set(f"'{context.active_object.name}' is not bound: Bind it first")
            return False
        return True

    def draw(self, context):
        """The options dialog: each mode's own options; Max Influences 0 says what it means."""
        layout = self.layout
        layout.prop(self, "mode")
        layout.prop(self, "max_influences")
        if self.max_influences == 0:
            layout.label(text=ALL_INFLUENCES if self.mode != 'FITTED' else FITTED_DEFAULT_INFLUENCES, icon='INFO')
        if self.mode != 'FITTED':
            layout.prop(self, "keyframes")
            return
        layout.prop(self, "bones")
        layout.prop(self, "use_scene_range")
        row = layout.row(align=True)
        row.enabled = not self.use_scene_range
        row.prop(self, "frame_start")
        row.prop(self, "frame_end")

    def invoke(self, context, event):
        """In the UI: ask for the options first (Fitted: then fit with progress and Esc)."""
        if not interactive(context):
            return self.execute(context)
        if self.mode == 'FITTED' and self.fitted_confirmed:
            return self._start_fitted(context)
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        if self.mode == 'FITTED' and interactive(context) and not self.fitted_confirmed:
            bpy.ops.object.gencoords_bake_bones('INVOKE_DEFAULT', fitted_confirmed=True,
                                                **self._fitted_options())
            return {'CANCELLED'}  # this call ends here: the modal bake does the work
        if self.mode == 'FITTED':
            return self._bake_fitted(context)
        obj = context.active_object
        try:
            with object_mode(context, obj):
                rig, deviation = bones.bake(obj, context, self.max_influences, self.keyframes)
        except BakeError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:
            return internal_error(self, error)
        info = rig.data[bones.BAKE_INFO]
        frames = info.get("frames")
        keyed = f", keyframed over frames {frames[0]} to {frames[1]}" if frames else ""
        # Blender's glTF exporter cuts to 4 influences by default, with only a console warning.
        over = (f"; {info['vertices_over_4']} vertices have more than 4 influences: glTF "
                "export keeps 4 unless Skinning > Include All Bone Influences is ticked"
                if info["vertices_over_4"] else "")
        self.report({'INFO'}, f"Baked '{obj.name}' to '{rig.name}' ({len(rig.data.bones)} "
                              f"bones{keyed}): deviation {deviation:.2e} of the cage size for "
                              "the standard smooth cage motion, measured on the weights "
                              f"written{over}")
        return {'FINISHED'}

    # Fitted, in a window: the options dialog's OK calls execute(), which would block the
    # window for the whole fit; it hands over to a modal bake (progress, Esc) instead.
    def _fitted_options(self):
        return {name: getattr(self, name) for name in ("mode", "bones", "max_influences",
                                                        "use_scene_range", "frame_start", "frame_end")}

    def _guarded(self, step, *args):
        """``step(*args)``, its errors reported: {'CANCELLED'} on one."""
        try:
            return step(*args)
        except BakeError as error:
            self.report({'ERROR'}, str(error))
        except fitted.Cancelled:
            self.report({'WARNING'}, "Bake to Bones cancelled: nothing was changed")
        except Exception as error:
            return internal_error(self, error)
        return {'CANCELLED'}

    def _fitted_job(self, context, sample=True):
        obj = context.active_object
        frames = (None if self.use_scene_range else
                  fitted.frame_range(context.scene, self.frame_start, self.frame_end))
        with object_mode(context, obj):
            return fitted.FittedBakeJob(
                obj, context, self.bones, self.max_influences or fitted.DEFAULT_INFLUENCES, frames,
                sample=sample)

    def _commit_fitted(self, context, job):
        with object_mode(context, job.obj):
            rig, figures = job.commit(context)
        return self._finished(job, rig, figures)

    def _finished(self, job, rig, figures):
        self.report({'INFO'}, fitted.summary(job.obj, rig, figures))
        return {'FINISHED'}

    def _bake_fitted(self, context):
        """At once (scripts, background): progress only where a window shows it."""
        def run():
            job = self._fitted_job(context)
            job.run(context.window_manager.progress_update)
            return self._commit_fitted(context, job)
        context.window_manager.progress_begin(0.0, 1.0)
        try:
            return self._guarded(run)
        finally:
            context.window_manager.progress_end()

    def _start_fitted(self, context):
        """The modal bake (``fitted.baking_steps``): the checks, the frames sampled and
        the rig written a step a timer event, the fit in a thread between; progress
        shown and Esc taken throughout."""
        self._job = self._guarded(self._fitted_job, context, False)
        if isinstance(self._job, set):
            return self._job
        self._baking = SlicedSteps(fitted.baking_steps(self._job, context))
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(0.01, window=context.window)
        window_manager.progress_begin(0.0, 1.0)
        window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def _step(self, context):
        """One timer event's work (a step of the bake): the fraction done, or the
        operator's result once the rig is written."""
        job = self._job
        try:
            with object_mode(context, job.obj):
                return self._baking.advance()
        except StopIteration as done:
            return self._finished(job, *done.value)

    def _cancel(self, context):
        """Esc: the bake closed (the fit stopped, whatever was written removed)."""
        with object_mode(context, self._job.obj):
            self._baking.close()
        raise fitted.Cancelled

    def modal(self, context, event):
        if event.type == 'ESC':
            self._end_modal(context)
            return self._guarded(self._cancel, context)
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}  # nothing else is edited while the bake runs
        fraction = self._guarded(self._step, context)
        if isinstance(fraction, set):  # finished, or failed (reported)
            self._end_modal(context)
            return fraction
        context.window_manager.progress_update(fraction)
        context.workspace.status_text_set(f"GenCoords: baking '{self._job.obj.name}' to fitted bones "
                                          f"{fraction:.0%} (Esc to cancel)")
        return TIMER_HANDLED

    def _end_modal(self, context):
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        context.workspace.status_text_set(None)


def draw_menu(self, context):
    """Object > Animation, beside Bake Action (F3 search finds it there too)."""
    self.layout.separator()
    self.layout.operator_context = 'INVOKE_REGION_WIN'
    self.layout.operator(OBJECT_OT_gencoords_bake_bones.bl_idname, icon='ARMATURE_DATA')


MENU = bpy.types.VIEW3D_MT_object_animation


CLASSES = (OBJECT_OT_gencoords_bake_bones,)
