"""Per-object settings, reached from scripts as ``obj.gencoords``."""

import bpy

from . import live, visualise

# Enum identifiers are the core's names in upper case (see ``core_name``).
KIND_ITEMS = (
    ("WACHSPRESS", "Wachspress", "Smooth, positive and affine invariant; needs a convex cage"),
    ("MEAN_VALUE", "Mean Value",
     "Smooth and positive inside convex cages; also works on non-convex closed cages"),
    ("DISCRETE_HARMONIC", "Discrete Harmonic",
     "Cotangent weights; needs a convex cage and can be negative"),
    ("VORONOI", "Voronoi", "Voronoi-cell weights; needs a convex cage and can be negative"),
)
OUTSIDE_ITEMS = (
    ("RAISE", "Report Error", "Refuse to bind when mesh vertices lie outside the cage"),
    ("PROJECT", "Project",
     "Vertices outside the cage take the coordinates of the nearest point on its surface"),
    ("EXTRAPOLATE", "Extrapolate",
     "Evaluate the coordinate formula outside the cage too (may be unstable far away)"),
)


def core_name(identifier):
    """The core's string for an enum identifier: 'MEAN_VALUE' -> 'mean_value'."""
    return identifier.lower()


def enum_label(items, identifier):
    """The user-facing name of ``identifier`` in an ``*_ITEMS`` table."""
    return next(name for key, name, _ in items if key == identifier)


def _is_cage_candidate(settings, obj):
    return obj.type == 'MESH' and obj != settings.id_data


def _live_changed(settings, context):
    live.apply_live_setting(settings.id_data, context.evaluated_depsgraph_get())


def _field_vertex_changed(settings, context):
    visualise.repaint_if_shown(settings.id_data)


class GenCoordsSettings(bpy.types.PropertyGroup):
    cage: bpy.props.PointerProperty(
        name="Cage", type=bpy.types.Object, poll=_is_cage_candidate,
        description="Closed mesh around this object whose vertices drive it after binding",
    )
    kind: bpy.props.EnumProperty(
        name="Coordinates", items=KIND_ITEMS, default="MEAN_VALUE",
        description="Generalized barycentric coordinates used to bind the mesh to the cage",
    )
    outside: bpy.props.EnumProperty(
        name="Outside", items=OUTSIDE_ITEMS, default="RAISE",
        description="What to do with mesh vertices that lie outside the cage when binding",
    )
    live: bpy.props.BoolProperty(
        name="Live", default=True, update=_live_changed,
        description="Follow the cage; when off the mesh shows its rest shape",
    )
    field_vertex: bpy.props.IntProperty(
        name="Cage Vertex", min=0, default=0, update=_field_vertex_changed,
        description="Cage vertex whose coordinate field Show Coordinate paints on the mesh",
    )
    bound_cage: bpy.props.PointerProperty(
        name="Bound Cage", type=bpy.types.Object,
        description="The cage the bind data refers to and the mesh follows (set by Bind; "
                    "picking another Cage takes effect on the next Bind)",
    )
    bind_data: bpy.props.PointerProperty(
        name="Bind Data", type=bpy.types.Text,
        description="Hidden text datablock holding the coordinates and rest shape "
                    "(managed by Bind/Unbind; do not set)",
    )
    edited_while_bound: bpy.props.BoolProperty(
        name="Edited While Bound",
        description="The bound mesh was edited, not by the cage, and stopped following it "
                    "until Bind or Unbind (managed by GenCoords; do not set)",
    )
