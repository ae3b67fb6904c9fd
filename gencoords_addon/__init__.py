"""GenCoords add-on: bind a mesh to a closed cage mesh and let the cage deform it.

Scripting API (works headless, e.g. ``blender -b`` or ``import bpy``):

Properties, on every object as ``obj.gencoords`` (read when binding):
    cage          Object   the cage: a closed mesh object around ``obj`` (not ``obj`` itself)
    kind          enum     'WACHSPRESS', 'MEAN_VALUE' (default), 'DISCRETE_HARMONIC', 'VORONOI',
                           'POWER' (with ``gamma``), 'GREEN', 'HARMONIC' (local, never
                           negative in any closed cage; with ``resolution``)
    gamma         float    power coordinates' exponent, -16 to 16 (default -0.5)
    outside       enum     vertices outside the cage: 'RAISE' (default: refuse to bind),
                           'PROJECT' (nearest cage surface point), 'EXTRAPOLATE'
    automatic_resolution bool  harmonic coordinates: the grid as fine as the cage's narrowest
                           gap asks (default True; setting ``resolution`` turns it off)
    resolution    int      harmonic coordinates: grid cells along the cage's longest side (48)
    storage       enum     'AUTO' (default), 'EXACT', 'COMPACT', 'SPARSE' (see the README)
    compact_size  int      numbers per vertex in compact storage (default 36)
    sparse_size   int      (cage vertex, weight) pairs per vertex in sparse storage (16;
                           harmonic: per grid node)
    auto_rebind   bool     bind again on leaving Edit Mode after vertices were added/deleted
    field_vertex  int      cage vertex whose coordinate field Show Coordinate paints

Operators, acting on the active mesh object (all undoable):
    bpy.ops.object.gencoords_bind()        compute the coordinates and add the "GenCoords"
                                           Geometry Nodes modifier (first in the stack)
                                           that moves the mesh with the cage
    bpy.ops.object.gencoords_unbind()      remove the modifier, its node group and the bind
                                           data: the mesh is bitwise as before Bind
    bpy.ops.object.gencoords_show_field()  paint field ``field_vertex`` into the colour
                                           attribute "GenCoords Field" (FLOAT_COLOR, POINT)
    bpy.ops.object.gencoords_clear_field() remove that attribute
    bpy.ops.object.gencoords_bake_bones(max_influences=0, keyframes=True)
                                           replace the binding by an armature (a bone per
                                           cage vertex) and vertex groups, keyframed over
                                           the scene's frame range (also Object > Animation;
                                           docs/SCRIPTING.md)
    bpy.ops.object.gencoords_make_cage(shape='CONVEX', target_vertices=100)
                                           make a closed cage around the mesh ('CONVEX':
                                           a hull, any type binds it; 'TIGHT': hugging the
                                           mesh at ``offset``, non-convex: bind it with
                                           Harmonic) and pick it as the mesh's cage
    bpy.ops.mesh.gencoords_select_dented_faces()
                                           select the active cage's faces that dent inward
                                           (Edit Mode > Select), what keeps it from being convex

Preferences (Edit > Preferences > Add-ons > GenCoords): Worker Processes, 'AUTO'
(default), 'BLENDER' (1: compute in Blender's own process) or 'FIXED' (``worker_count``);
where worker processes fail, Bind and Make Cage compute in Blender instead and report
it as a warning.

Failures are reported as errors and change nothing; in background scripts ``bpy.ops``
then raises RuntimeError with the message. The deformation is Blender's own evaluation
of the modifier: no handler runs at playback or render, and a file opened without the
extension still deforms. ``gencoords_addon.ui.status.status_lines(obj)`` gives the panel's
status lines; ``binding_result(obj)`` (also ``bl_ext.user_default.gencoords.binding_result``)
what Bind measured and stored, read-only: kind, storage chosen, smallest coordinate,
deviations (``api.BindingResult``); ``binding_results(obj)`` every binding in stack order.
"""

import bpy

from . import handlers
from .api import BindingResult, binding_result, binding_results  # noqa: F401 (public)
from .ui import bake_operator, field_operators, operators, panel
from .preferences import GenCoordsPreferences
from .ui.properties import GenCoordsSettings

CLASSES = (GenCoordsSettings, GenCoordsPreferences, *operators.CLASSES, *field_operators.CLASSES, *bake_operator.CLASSES, *panel.CLASSES)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.gencoords = bpy.props.PointerProperty(
        type=GenCoordsSettings, name="GenCoords",
        description="GenCoords cage deformation settings of this object (read when binding)")
    bake_operator.MENU.append(bake_operator.draw_menu)
    operators.SELECT_MENU.append(operators.draw_select_menu)
    handlers.register()


def unregister():
    handlers.unregister()
    operators.SELECT_MENU.remove(operators.draw_select_menu)
    bake_operator.MENU.remove(bake_operator.draw_menu)
    del bpy.types.Object.gencoords
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
