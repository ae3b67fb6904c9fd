"""Show coordinate: paint one cage vertex's coordinate field on the mesh as colours."""

from .. import core
from . import binding

FIELD_ATTRIBUTE = "GenCoords Field"


def field_problem(obj):
    """Why the field of ``obj.gencoords.field_vertex`` cannot be shown, or None."""
    found = binding.binding(obj)
    if found is None:
        return f"'{obj.name}' is not bound: Bind it to a cage first"
    count = found.info["cage_vertex_count"]
    if obj.gencoords.field_vertex >= count:
        return f"Cage Vertex must be below {count}: the cage has {count} vertices"
    if len(obj.data.vertices) != found.info["mesh_vertex_count"]:
        return f"'{obj.name}' was edited since Bind (vertices added or deleted): Bind again"
    return None


def paint_field(obj):
    """Write the chosen field (``core.field_colors``) as the mesh's active colour attribute.

    Call only when ``field_problem(obj)`` is None.
    """
    values = binding.binding(obj).coordinate_column(obj.data, obj.gencoords.field_vertex)
    if values is None:
        return False
    colors = core.field_colors(values)
    mesh = obj.data
    attribute = mesh.color_attributes.get(FIELD_ATTRIBUTE)
    kind = ('POINT', 'FLOAT_COLOR')
    if attribute is not None and (attribute.domain, attribute.data_type) != kind:
        mesh.color_attributes.remove(attribute)
        attribute = None
    if attribute is None:
        attribute = mesh.color_attributes.new(FIELD_ATTRIBUTE, kind[1], kind[0])
    attribute.data.foreach_set("color", colors.reshape(-1))
    mesh.color_attributes.active_color = attribute
    mesh.update()
    return True


def repaint_if_shown(obj):
    """Follow a change of the chosen cage vertex while a field is displayed."""
    if FIELD_ATTRIBUTE in obj.data.color_attributes and field_problem(obj) is None:
        paint_field(obj)


def clear_field(obj):
    """Remove the field colours; False when there were none."""
    mesh = obj.data
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
