"""Operators: Bind, Unbind, Show Coordinate and Clear Coordinate (all undoable)."""

import traceback

import bpy

from . import binding, cage_link, live, mesh_io, storage, visualise


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


class OBJECT_OT_gencoords_bind(MeshOperator, bpy.types.Operator):
    """Bind the active mesh to its cage: compute the coordinates of every vertex"""

    bl_idname = "object.gencoords_bind"
    bl_label = "Bind"

    def execute(self, context):
        obj = context.active_object
        if obj.mode == 'EDIT':
            obj.update_from_editmode()  # bind what the artist sees
        progress = context.window_manager
        progress.progress_begin(0.0, 1.0)
        try:
            bind = binding.bind(obj, context.evaluated_depsgraph_get(), progress.progress_update)
        except binding.BindError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        except Exception as error:  # keep the user's scene intact, the trace in the console
            traceback.print_exc()
            self.report({'ERROR'}, f"GenCoords internal error (see the console): {error}")
            return {'CANCELLED'}
        finally:
            progress.progress_end()
        storage.save(obj, bind)
        storage.remove_orphans()
        # The bind data belong to this cage: picking another one must not silently drive
        # the mesh with coordinates computed for the first (same vertex count or not).
        obj.gencoords.bound_cage = obj.gencoords.cage
        cage_link.link(obj, obj.gencoords.bound_cage)
        obj.gencoords.edited_while_bound = False  # the edited shape is the new rest
        live.forget(obj)
        message = (f"Bound '{obj.name}' ({bind.mesh_vertex_count} vertices) to "
                   f"'{obj.gencoords.cage.name}' in {bind.bind_seconds:.2f} s")
        # Renders evaluate frame handlers on their own thread; lock the UI meanwhile.
        render = context.scene.render
        if not render.use_lock_interface:
            render.use_lock_interface = True
            message += "; Render > Lock Interface turned on so renders read the cage safely"
        live.apply_live_setting(obj, context.evaluated_depsgraph_get())
        self.report({'INFO'}, message)
        return {'FINISHED'}


class OBJECT_OT_gencoords_unbind(MeshOperator, bpy.types.Operator):
    """Restore the rest shape of the active mesh exactly and remove its bind data"""

    bl_idname = "object.gencoords_unbind"
    bl_label = "Unbind"

    def execute(self, context):
        obj = context.active_object
        if obj.gencoords.bind_data is None:
            self.report({'ERROR'}, f"'{obj.name}' is not bound")
            return {'CANCELLED'}
        if obj.mode == 'EDIT':
            self.report({'ERROR'}, "Leave Edit Mode before unbinding")
            return {'CANCELLED'}
        problem = live.rest_shape_problem(obj)
        if problem is None:
            # Bitwise, also over edits of the bound mesh: the user asked for the rest shape.
            mesh_io.write_positions(obj.data, storage.load(obj).rest_positions)
        storage.remove(obj)
        cage_link.unlink(obj)
        obj.gencoords.bound_cage = None
        obj.gencoords.edited_while_bound = False
        live.forget(obj)
        if problem:
            self.report({'WARNING'}, f"Unbound '{obj.name}' and kept its current shape: "
                                     f"the rest shape could not be restored, as {problem}")
        return {'FINISHED'}


class OBJECT_OT_gencoords_show_field(MeshOperator, bpy.types.Operator):
    """Paint the coordinate field of the chosen cage vertex on the mesh (lighter is larger,
    black is negative) as the colour attribute "GenCoords Field\""""

    bl_idname = "object.gencoords_show_field"
    bl_label = "Show Coordinate"

    def execute(self, context):
        obj = context.active_object
        problem = visualise.field_problem(obj)
        if problem:
            self.report({'ERROR'}, problem)
            return {'CANCELLED'}
        visualise.paint_field(obj)
        visualise.show_colors_in_viewports(context.screen)
        return {'FINISHED'}


class OBJECT_OT_gencoords_clear_field(MeshOperator, bpy.types.Operator):
    """Remove the coordinate field colours from the mesh"""

    bl_idname = "object.gencoords_clear_field"
    bl_label = "Clear Coordinate"

    def execute(self, context):
        if not visualise.clear_field(context.active_object):
            self.report({'WARNING'}, "No coordinate field is shown")
        return {'FINISHED'}


CLASSES = (
    OBJECT_OT_gencoords_bind,
    OBJECT_OT_gencoords_unbind,
    OBJECT_OT_gencoords_show_field,
    OBJECT_OT_gencoords_clear_field,
)
