"""GenCoords add-on: bind a mesh to a closed cage mesh and let the cage deform it.

Scripting API (works headless, e.g. ``blender -b`` or ``import bpy``):

Properties, on every object as ``obj.gencoords``:
    cage          Object   the cage: a closed mesh object around ``obj`` (not ``obj`` itself)
    kind          enum     'WACHSPRESS', 'MEAN_VALUE' (default), 'DISCRETE_HARMONIC', 'VORONOI'
    outside       enum     vertices outside the cage: 'RAISE' (default: refuse to bind),
                           'PROJECT' (nearest cage surface point), 'EXTRAPOLATE'
    live          bool     follow the cage (default True); False shows the rest shape
    field_vertex  int      cage vertex whose coordinate field Show Coordinate paints
    bind_data     Text     the hidden datablock with the bind data (None if unbound);
                           managed by Bind/Unbind; do not set
    edited_while_bound
                  bool     the bound mesh was edited (not by the cage): it stops following
                           until Bind (binds the edited shape) or Unbind; do not set

Operators, acting on the active mesh object (all undoable):
    bpy.ops.object.gencoords_bind()        compute coordinates, store the rest shape, follow;
                                           adds the pass-through modifier "GenCoords cage
                                           link" so cages hidden from renders still drive it
    bpy.ops.object.gencoords_unbind()      restore the rest shape bitwise, delete bind data
                                           and the cage link
    bpy.ops.object.gencoords_show_field()  paint field ``field_vertex`` into the colour
                                           attribute "GenCoords Field" (FLOAT_COLOR, POINT)
    bpy.ops.object.gencoords_clear_field() remove that attribute

Failures are reported as errors; in background scripts ``bpy.ops`` then raises
RuntimeError with the message. The deformed shape is written into the mesh itself on cage
edits, frame changes and renders (``scene.render.use_lock_interface`` is set on bind).
``gencoords_addon.status.status_lines(obj)`` gives the panel's status lines.
"""

import bpy

from . import live, operators, panel
from .properties import GenCoordsSettings

CLASSES = (GenCoordsSettings, *operators.CLASSES, *panel.CLASSES)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.gencoords = bpy.props.PointerProperty(type=GenCoordsSettings)
    live.register()


def unregister():
    live.unregister()
    del bpy.types.Object.gencoords
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
