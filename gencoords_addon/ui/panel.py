"""The GenCoords panel, drawn identically in the Modifiers tab (above the stack, with the
modifier Bind adds) and in the 3D view sidebar."""

import textwrap

import bpy

from ...core.storage import Storage
from ..bind.bindings import binding, bindings, meshes_driven_by
from ..enums import is_green, is_harmonic, kind_parameter
from .status import status_lines
from .visualise import field_range


CHARACTER_WIDTH = 7  # pixels of an average interface character at UI scale 1
HEADLINE_ICONS = {'ERROR', 'LINKED', 'UNLINKED'}  # status lines always shown: faults, what it is bound to


def wrapped(text, width):
    """``text`` in lines of at most ``width`` characters (``None``: one line); status
    lines are sentences, and a label Blender cuts off loses their end."""
    return [text] if width is None else textwrap.wrap(text, max(width, 16)) or [""]


def draw_type(column, settings, width=None):
    """The Type setting, its parameter (Gamma, Resolution) and, for the types that differ
    most, a line saying what they do."""
    column.prop(settings, "kind", text="Type")  # short: the Properties editor is narrow
    if kind_parameter(settings.kind) == "gamma":
        column.prop(settings, "gamma")
    if is_harmonic(settings.kind):
        row = column.row(align=True)
        row.prop(settings, "automatic_resolution", text="Auto", toggle=True)
        field = row.row(align=True)
        field.active = not settings.automatic_resolution  # greyed, still editable: typing turns Auto off
        field.prop(settings, "resolution")
    # Green: the one type that is not affine invariant; Harmonic: the local one.
    explanation = ("Keeps details' shape when the cage stretches" if is_green(settings.kind) else
                   "Local, never negative: a limb's cage moves that limb alone"
                   if is_harmonic(settings.kind) else None)
    if explanation is not None:
        for number, line in enumerate(wrapped(explanation, width)):
            column.label(text=line, icon='INFO' if number == 0 else 'BLANK1')


def draw_settings(layout, obj, width=None):
    """Everything the panel shows for the mesh object ``obj``; ``width``: characters that
    fit on a status line (None: no wrapping)."""
    settings = obj.gencoords
    bound = binding(obj) is not None
    column = layout.column()
    column.prop(settings, "cage")
    if settings.cage is None:  # a button of its own: a bare icon beside the field cut its name
        for mesh in meshes_driven_by(obj):  # Make Cage on a cage is rarely what is meant
            for number, line in enumerate(wrapped(f"This is the cage of '{mesh.name}'", width)):
                column.label(text=line, icon='INFO' if number == 0 else 'BLANK1')
        column.operator("object.gencoords_make_cage", icon='MESH_ICOSPHERE')
    else:
        # Artists keep cages out of the way: as wires or bounds, or hidden (still driving).
        column.prop(settings.cage, "display_type", text="Display")
    draw_type(column, settings, width)
    column.prop(settings, "outside")
    column.prop(settings, "storage")
    if settings.storage == Storage.COMPACT:  # Automatic picks its own slots, by measuring
        column.prop(settings, "compact_size", text="Slots")
    if settings.storage == Storage.SPARSE:
        column.prop(settings, "sparse_size", text="Pairs")
    column.prop(settings, "auto_rebind")

    row = layout.row(align=True)
    rebind = settings.cage is not None and binding(obj, settings.cage) is not None
    row.operator("object.gencoords_bind", text="Rebind" if rebind else "Bind", icon='LINKED')
    unbind = row.row(align=True)
    unbind.enabled = bound
    unbind.operator("object.gencoords_unbind", text="Unbind All" if len(bindings(obj)) > 1
                    else "Unbind", icon='UNLINKED')
    if len(bindings(obj)) > 1:
        for found in bindings(obj):
            item = layout.row(align=True)
            cage = found.cage
            item.label(text=f"{found.modifier.name}: '{cage.name if cage else '(missing)'}'",
                       icon='MOD_LATTICE')
            item.operator("object.gencoords_unbind", text="", icon='X').modifier = \
                found.modifier.name

    # What is wrong and what it is bound to first; the figures fold away below, after the
    # buttons (at full length they pushed Bake to Bones below a 1000-pixel window's edge).
    lines = status_lines(obj)
    _draw_lines(layout.box().column(align=True), [line for line in lines if line[1] in HEADLINE_ICONS], width)
    if bound:
        # For game engines and exporters; its options (influences, keyframes) in a dialog.
        layout.operator("object.gencoords_bake_bones", icon='ARMATURE_DATA')
        field = layout.column()
        field.label(text="Coordinate field of a cage vertex:")
        field.prop(settings, "field_vertex", text="Vertex")  # the heading says which
        row = field.row(align=True)  # a row of its own: beside the vertex it was cut off
        row.operator("object.gencoords_show_field", text="Show", icon='HIDE_OFF')
        shown = field_range(obj)
        if shown is not None:
            row.operator("object.gencoords_clear_field", text="Clear", icon='X')
            lowest, highest = shown
            legend = field.column(align=True)
            legend.label(text=f"Purple 0 to yellow {highest:.3g}")
            if lowest < 0.0:
                legend.label(text=f"Pink to red: negative, down to {lowest:.3g}")
    details = [line for line in lines if line[1] not in HEADLINE_ICONS]
    if details:
        header, body = layout.panel("GENCOORDS_status_details", default_closed=False)
        header.label(text="Binding Details")
        if body is not None:
            _draw_lines(body.box().column(align=True), details, width)


def _draw_lines(column, lines, width):
    """Status ``lines`` ((text, icon)) as labels, wrapped to ``width`` characters."""
    for text, icon in lines:
        for number, line in enumerate(wrapped(text, width)):
            column.label(text=line, icon=icon if number == 0 else 'BLANK1')


class GenCoordsPanel:
    bl_label = "GenCoords"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == 'MESH'

    def draw(self, context):
        self.layout.use_property_split = True
        scale = context.preferences.system.ui_scale
        # the icon and the box's margins take about 6 characters
        width = int(context.region.width / (CHARACTER_WIDTH * scale)) - 6
        draw_settings(self.layout, context.object, width)


class OBJECT_PT_gencoords(GenCoordsPanel, bpy.types.Panel):
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "modifier"


class VIEW3D_PT_gencoords(GenCoordsPanel, bpy.types.Panel):
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "GenCoords"


CLASSES = (OBJECT_PT_gencoords, VIEW3D_PT_gencoords)
