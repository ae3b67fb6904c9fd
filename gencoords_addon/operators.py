"""Operators: Bind, Unbind, Show Coordinate, Clear Coordinate, Make Cage and Bake to
Bones (all undoable).

Every operator either finishes or leaves the file as it found it: errors become a
report saying what to do (in scripts, ``bpy.ops`` raises RuntimeError with it).
"""

import contextlib
import traceback

import bpy

from . import bake_fitted, binding, bones, cage_maker, visualise


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


@contextlib.contextmanager
def object_mode(context, obj):
    """Leave Edit Mode for the block (bind data are written to the mesh, which Edit Mode
    would overwrite on exit), and return to it afterwards."""
    editing = obj.mode == 'EDIT'
    if editing:
        bpy.ops.object.mode_set(mode='OBJECT')  # also writes the edit into the mesh
    try:
        yield
    finally:
        if editing and context.view_layer.objects.active == obj:
            bpy.ops.object.mode_set(mode='EDIT')


# Meshes (Object.session_uid) a modal Bind is computing for: Auto Rebind waits for it
# rather than start a second one (tabbing in and out of Edit Mode meanwhile).
MODAL_BINDS = set()


def interactive(context):
    """Whether an operator runs in a window that processes events (progress, Esc)."""
    return not bpy.app.background and context.window is not None


ALL_INFLUENCES = "0: All influences, every weight kept (exact)"
FITTED_DEFAULT_INFLUENCES = f"0: {bake_fitted.DEFAULT_INFLUENCES} influences per vertex, as game engines read"


def _internal_error(operator, error, changed="nothing was changed"):
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
        obj = context.active_object
        try:
            with object_mode(context, obj):
                self._job = binding.BindJob(obj, context)
        except binding.BindError as error:
            self.report({'ERROR'}, str(error))
            return False
        return True

    def _finish(self, context):
        job = self._job
        with object_mode(context, job.obj):
            job.commit()
        info = job.result.info
        headline = (f"Bound '{job.obj.name}' ({info['mesh_vertex_count']} vertices) to "
                    f"'{job.cage.name}' in {info['bind_seconds']:.2f} s ({info['storage'].lower()} storage)")
        if job.worker_failure is None:
            self.report({'INFO'}, headline)
        else:
            self.report({'WARNING'}, f"{headline}; {job.worker_failure}")
        return {'FINISHED'}

    def execute(self, context):
        """Run to the end: scripts and background mode (progress printed there)."""
        if self.replace_asked and not self.replace_confirmed and interactive(context):
            # OK in the Replace Binding question: bind as invoke does, with progress and
            # Esc. This call ends here (nothing changed, no undo step of its own).
            bpy.ops.object.gencoords_bind('INVOKE_DEFAULT', replace_confirmed=True)
            return {'CANCELLED'}
        try:
            if not self._start(context):
                return {'CANCELLED'}
            printed = [0.0]

            def report(fraction):
                if bpy.app.background and fraction - printed[0] >= 0.1 and fraction < 1.0:
                    printed[0] = fraction
                    print(f"GenCoords: binding '{self._job.obj.name}' {fraction:.0%}", flush=True)

            self._job.run(report)
            return self._finish(context)
        except binding.BindError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:  # the file is unchanged: commit cleans up after itself
            return _internal_error(self, error)

    def invoke(self, context, event):
        """In the UI: compute between events, with a progress bar; Esc cancels. Binding a
        cage the mesh is already bound to asks before replacing that binding."""
        if not interactive(context):
            return self.execute(context)
        obj = context.active_object
        if obj.session_uid in MODAL_BINDS:
            self.report({'WARNING'}, f"'{obj.name}' is being bound already: wait for it, or Esc")
            return {'CANCELLED'}
        if not self.replace_confirmed and binding.binding(obj, obj.gencoords.cage) is not None:
            self.replace_asked = True  # OK runs execute(), which comes back here, confirmed
            return context.window_manager.invoke_confirm(
                self, event, title="Replace Binding",
                message=f"'{obj.name}' is already bound to '{obj.gencoords.cage.name}': "
                        "bind again, replacing that binding?")
        try:
            if not self._start(context):
                return {'CANCELLED'}
        except Exception as error:
            return _internal_error(self, error)
        self._steps = self._job.steps()
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(0.01, window=context.window)
        window_manager.progress_begin(0.0, 1.0)
        window_manager.modal_handler_add(self)
        self._mesh_uid = self._job.obj.session_uid
        MODAL_BINDS.add(self._mesh_uid)
        return {'RUNNING_MODAL'}

    def _stop(self, context, text=None):
        MODAL_BINDS.discard(self._mesh_uid)
        window_manager = context.window_manager
        window_manager.event_timer_remove(self._timer)
        window_manager.progress_end()
        context.workspace.status_text_set(text)
        self._steps.close()

    def modal(self, context, event):
        if event.type == 'ESC':
            self._stop(context)
            self.report({'WARNING'}, "Bind cancelled: nothing was changed")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        try:
            fraction = next(self._steps, None)
            if fraction is None:
                self._stop(context)
                return self._finish(context)
        except binding.BindError as error:
            self._stop(context)
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:
            self._stop(context)
            return _internal_error(self, error)
        context.window_manager.progress_update(fraction)
        in_blender = "" if self._job.worker_failure is None else ", in Blender: worker processes failed"
        context.workspace.status_text_set(
            f"GenCoords: binding '{self._job.obj.name}' {fraction:.0%}{in_blender} (Esc to cancel)")
        return {'RUNNING_MODAL'}


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
        found = [b for b in binding.bindings(obj)
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
                binding.remove(obj, found)
        except Exception as error:
            removed = getattr(error, "gencoords_removed", [])
            if not removed:
                return _internal_error(self, error)
            if len(removed) == len(found):  # only the cleanup after the modifiers failed
                return _internal_error(self, error, "the binding was removed but unused "
                                                    "hidden data may remain")
            return _internal_error(self, error, f"only {', '.join(removed)} was removed: Unbind "
                                                "again to remove the rest")
        return {'FINISHED'}


class OBJECT_OT_gencoords_show_field(MeshOperator, bpy.types.Operator):
    """Paint the coordinate field of the chosen cage vertex on the mesh (purple 0 to yellow
    largest, pink to red negative) as the colour attribute "GenCoords Field", and mark the
    vertex on the cage"""

    bl_idname = "object.gencoords_show_field"
    bl_label = "Show Coordinate"

    def execute(self, context):
        obj = context.active_object
        problem = visualise.field_problem(obj)
        if problem:
            self.report({'ERROR'}, problem)
            return {'CANCELLED'}
        try:
            with object_mode(context, obj):
                painted = visualise.paint_field(obj)
        except Exception as error:
            return _internal_error(self, error, "the field may be partly painted: Clear "
                                                "Coordinate removes it")
        if not painted:
            self.report({'ERROR'}, f"The bind data of '{obj.name}' is missing: Bind again")
            return {'CANCELLED'}
        visualise.show_colors_in_viewports(context.screen)
        return {'FINISHED'}


class OBJECT_OT_gencoords_clear_field(MeshOperator, bpy.types.Operator):
    """Remove the coordinate field colours from the mesh"""

    bl_idname = "object.gencoords_clear_field"
    bl_label = "Clear Coordinate"

    def execute(self, context):
        obj = context.active_object
        try:
            with object_mode(context, obj):
                cleared = visualise.clear_field(obj)
        except Exception as error:
            return _internal_error(self, error, "the field may be partly cleared: Clear "
                                                "Coordinate again")
        if not cleared:
            self.report({'WARNING'}, "No coordinate field is shown")
        return {'FINISHED'}


class OBJECT_OT_gencoords_make_cage(MeshOperator, bpy.types.Operator):
    """Make a closed, convex, triangulated cage around the active mesh and pick it as the
    mesh's cage"""

    bl_idname = "object.gencoords_make_cage"
    bl_label = "Make Cage"

    target_vertices: bpy.props.IntProperty(
        name="Vertices", default=100, min=8, soft_min=20, soft_max=500,
        description="About how many vertices the cage gets")
    margin: bpy.props.FloatProperty(
        name="Margin", default=0.05, min=0.0, soft_max=0.5, subtype='FACTOR',
        description="Gap between the mesh and the cage, relative to the mesh's size (0 keeps "
                    "0.0004: rounding must not leave a vertex outside)")

    def execute(self, context):
        obj = context.active_object
        try:
            with object_mode(context, obj):
                cage, worker_failure = cage_maker.make_cage(obj, context, self.target_vertices,
                                                            self.margin)
        except cage_maker.CageError as error:
            self.report({'ERROR'}, f"Cannot make a cage: {error}")
            return {'CANCELLED'}
        except Exception as error:
            return _internal_error(self, error)
        made = f"Made '{cage.name}' ({len(cage.data.vertices)} vertices) around '{obj.name}'"
        if worker_failure is None:
            self.report({'INFO'}, made)
        else:
            self.report({'WARNING'}, f"{made}; {worker_failure}")
        return {'FINISHED'}


class OBJECT_OT_gencoords_bake_bones(MeshOperator, bpy.types.Operator):
    """Replace the binding by an armature (a bone per cage vertex, following it, keyframed
    over the scene's frame range) and vertex groups holding the coordinates, or (Fitted)
    a few rotating bones and 4 weights per vertex fitted to the deformation, for game
    engines and exporters such as glTF"""

    bl_idname = "object.gencoords_bake_bones"
    bl_label = "Bake to Bones"

    max_influences: bpy.props.IntProperty(
        name="Max Influences", default=0, min=0, soft_max=8,
        description="Weights kept per vertex, renormalised (game engines take 4 or 8; "
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
        name="Bones", default=bake_fitted.DEFAULT_BONES, min=1, max=255,
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
        if binding.binding(context.active_object) is None:
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
        except binding.BindError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:
            return _internal_error(self, error)
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
        except binding.BindError as error:
            self.report({'ERROR'}, str(error))
        except bake_fitted.Cancelled:
            self.report({'WARNING'}, "Bake to Bones cancelled: nothing was changed")
        except Exception as error:
            return _internal_error(self, error)
        return {'CANCELLED'}

    def _fitted_job(self, context):
        obj = context.active_object
        frames = (None if self.use_scene_range else
                  bake_fitted.frame_range(context.scene, self.frame_start, self.frame_end))
        with object_mode(context, obj):
            return bake_fitted.FittedBakeJob(
                obj, context, self.bones, self.max_influences or bake_fitted.DEFAULT_INFLUENCES, frames)

    def _commit_fitted(self, context, job):
        if job.error is not None:
            raise job.error
        with object_mode(context, job.obj):
            rig, figures = job.commit(context)
        self.report({'INFO'}, bake_fitted.summary(job.obj, rig, figures))
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
        self._job = self._guarded(self._fitted_job, context)
        if isinstance(self._job, set):
            return self._job
        self._job.start()
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(0.1, window=context.window)
        window_manager.progress_begin(0.0, 1.0)
        window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        job = self._job
        if event.type == 'ESC':
            job.cancel()
            job.error = bake_fitted.Cancelled()
        elif event.type != 'TIMER':
            return {'RUNNING_MODAL'}  # nothing else is edited while the fit runs
        elif not job.done:
            context.window_manager.progress_update(job.fraction)
            context.workspace.status_text_set(f"GenCoords: fitting bones to '{job.obj.name}' "
                                              f"{job.fraction:.0%} (Esc to cancel)")
            return {'RUNNING_MODAL'}
        context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        context.workspace.status_text_set(None)
        return self._guarded(self._commit_fitted, context, job)


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


def draw_menu(self, context):
    """Object > Animation, beside Bake Action (F3 search finds it there too)."""
    self.layout.separator()
    self.layout.operator_context = 'INVOKE_REGION_WIN'
    self.layout.operator(OBJECT_OT_gencoords_bake_bones.bl_idname, icon='ARMATURE_DATA')


MENU = bpy.types.VIEW3D_MT_object_animation


CLASSES = (
    OBJECT_OT_gencoords_make_cage,
    OBJECT_OT_gencoords_bake_bones,
    OBJECT_OT_gencoords_bind,
    OBJECT_OT_gencoords_unbind,
    OBJECT_OT_gencoords_show_field,
    OBJECT_OT_gencoords_clear_field,
    MESH_OT_gencoords_select_dented_faces,
)
