"""Show coordinate: paint one cage vertex's coordinate field on the mesh as colours, and
mark that vertex on the cage."""

import bpy

from ... import core
from ..bind import bindings
from ..blender_io.mesh_arrays import write_point_colors

FIELD_ATTRIBUTE = "GenCoords Field"
# On the mesh data, beside the colours: (lowest, highest) of the field shown, from
# ``core.reports.field_range``, for the panel's legend. A leading underscore hides it in the UI.
FIELD_RANGE = "_gencoords_field_range"
# On the mesh object: the empty that marks the chosen cage vertex.
FIELD_MARKER = "_gencoords_field_marker"
MARKER_SIZE = 0.04  # of the cage's bounding-box diagonal: visible, not in the way


def field_problem(obj):
    """Why the field of ``obj.gencoords.field_vertex`` cannot be shown, or None."""
    found = bindings.binding(obj)
    if found is None:
        return f"'{obj.name}' is not bound: Bind it to a cage first"
    if found.cage is None:  # the field's marker sits on the cage
        gone = f"The cage '{found.deleted_cage}' was" if found.deleted_cage else "The cage was"
        return f"{gone} deleted: pick another cage and Bind, then Show Coordinate"
    count = found.data.cage_vertex_count
    if obj.gencoords.field_vertex >= count:
        return f"Cage Vertex must be below {count}: the cage has {count} vertices"
    if len(obj.data.vertices) != found.data.mesh_vertex_count:
        return f"'{obj.name}' was edited since Bind (vertices added or deleted): Bind again"
    return None


def paint_field(obj):
    """Write the chosen field (``core.reports.field_colors``) as the mesh's active colour attribute.

    Call only when ``field_problem(obj)`` is None.
    """
    values = bindings.binding(obj).coordinate_column(obj.data, obj.gencoords.field_vertex)
    if values is None:
        return False
    colors = core.reports.field_colors(values)
    mesh = obj.data
    attribute = mesh.color_attributes.get(FIELD_ATTRIBUTE)
    kind = ('POINT', 'FLOAT_COLOR')
    if attribute is not None and (attribute.domain, attribute.data_type) != kind:
        mesh.color_attributes.remove(attribute)
        attribute = None
    if attribute is None:
        attribute = mesh.color_attributes.new(FIELD_ATTRIBUTE, kind[1], kind[0])
    write_point_colors(attribute, colors)
    mesh.color_attributes.active_color = attribute
    mesh[FIELD_RANGE] = core.reports.field_range(values)
    mesh.update()
    mark_cage_vertex(obj, bindings.binding(obj).cage, obj.gencoords.field_vertex)
    return True


def field_range(obj):
    """(lowest, highest) of the field shown on ``obj``, or None when none is shown."""
    if FIELD_ATTRIBUTE not in obj.data.color_attributes or FIELD_RANGE not in obj.data:
        return None
    lowest, highest = obj.data[FIELD_RANGE]
    return lowest, highest


def mark_cage_vertex(obj, cage, vertex):
    """Put a small sphere empty on ``cage``'s vertex ``vertex``: the field's origin.

    Vertex-parented to the cage, so it follows every cage edit and animation with no
    Python running; drawn in front, not selectable, not rendered.
    """
    marker = obj.get(FIELD_MARKER)
    if marker is None or marker.name not in bpy.data.objects:
        marker = bpy.data.objects.new(f"{obj.name}: field vertex", None)
        marker.empty_display_type = 'SPHERE'
        marker.show_in_front = True
        marker.hide_select = True
        marker.hide_render = True
        for collection in cage.users_collection:
            collection.objects.link(marker)
        obj[FIELD_MARKER] = marker
    marker.parent = cage
    marker.parent_type = 'VERTEX'
    marker.parent_vertices = (vertex, 0, 0)
    marker.location = (0.0, 0.0, 0.0)
    # A vertex parent passes on the vertex's world position only, not the cage's scale;
    # a cage of no size (Blender clamps the empty's size) has nothing to mark.
    marker.empty_display_size = MARKER_SIZE * cage.dimensions.length
    return marker


def remove_marker(obj):
    marker = obj.get(FIELD_MARKER)
    if FIELD_MARKER in obj:
        del obj[FIELD_MARKER]
    if marker is not None and marker.name in bpy.data.objects:
        bpy.data.objects.remove(marker)


def repaint_if_shown(obj):
    """Follow a change of the chosen cage vertex while a field is displayed."""
    if FIELD_ATTRIBUTE in obj.data.color_attributes and field_problem(obj) is None:
        paint_field(obj)


def clear_field(obj):
    """Remove the field colours; False when there were none."""
    mesh = obj.data
    remove_marker(obj)
    if FIELD_RANGE in mesh:
        del mesh[FIELD_RANGE]
    attribute = mesh.color_attributes.get(FIELD_ATTRIBUTE)
    if attribute is None:
        return False
    mesh.color_attributes.remove(attribute)
    mesh.update()
    return True


def show_colors_in_viewports(screen):
    """Switch solid-mode 3D views of ``screen`` to show colour attributes (none headless)."""
    if screen is None:
        return
    for area in screen.areas:
        if area.type == 'VIEW_3D':
            area.spaces.active.shading.color_type = 'VERTEX'
