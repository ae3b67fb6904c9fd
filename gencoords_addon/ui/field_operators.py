"""Operators: Show Coordinate and Clear Coordinate (the field of one cage vertex painted on
the mesh as colours; ``visualise`` paints it)."""

import bpy

from ..bind.service import object_mode
from . import visualise
from .operators import MeshOperator, internal_error


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
            return internal_error(self, error, "the field may be partly painted: Clear "
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
            return internal_error(self, error, "the field may be partly cleared: Clear "
                                                "Coordinate again")
        if not cleared:
            self.report({'WARNING'}, "No coordinate field is shown")
        return {'FINISHED'}


CLASSES = (OBJECT_OT_gencoords_show_field, OBJECT_OT_gencoords_clear_field)
