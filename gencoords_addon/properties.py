"""Per-object settings, reached from scripts as ``obj.gencoords``."""

import bpy

from .. import core
from ..core.base.inputs import GAMMA_LIMIT

# Enum identifiers are the core's names in upper case (see ``core_name``); the core's
# table of kinds is the one list.
KIND_ITEMS = tuple((kind.name.upper(), kind.label, kind.description) for kind in core.KIND_TABLE)
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


STORAGE_ITEMS = (
    ("AUTO", "Automatic",
     "Exact while its cost is moderate (mesh vertices x cage vertices up to 8 million, "
     "cages up to 400 vertices); beyond, Compact with the fewest slots that keep the "
     "deviation under 1e-3 of the cage diagonal, measured at Bind, else Exact"),
    ("EXACT", "Exact",
     "Every coordinate of every vertex: the deformation is exact to float32 rounding"),
    ("COMPACT", "Compact",
     "A few numbers per vertex: exact for affine and smooth cage motions, close for "
     "others (the panel shows the deviation); for dense meshes and large cages"),
)


def _is_cage_candidate(settings, obj):
    return obj.type == 'MESH' and obj != settings.id_data


def _field_vertex_changed(settings, context):
    from . import visualise  # it reads bindings, whose module reads these tables
    visualise.repaint_if_shown(settings.id_data)


# Settings read when binding are not animatable: keyframing them would do nothing.
class GenCoordsSettings(bpy.types.PropertyGroup):
    cage: bpy.props.PointerProperty(
        name="Cage", type=bpy.types.Object, poll=_is_cage_candidate, options=set(),
        description="Closed mesh around this object whose vertices drive it after binding",
    )
    kind: bpy.props.EnumProperty(
        name="Coordinates", items=KIND_ITEMS, default="MEAN_VALUE", options=set(),
        description="Generalized barycentric coordinates used to bind the mesh to the cage",
    )
    gamma: bpy.props.FloatProperty(
        name="Gamma", default=-0.5, soft_min=-2.0, soft_max=2.0, min=-GAMMA_LIMIT,
        max=GAMMA_LIMIT, step=10, options=set(),
        description="Power coordinates' exponent: -1 is Wachspress, 1 Voronoi. Positive "
                    "on every cage for -1; measured positive for -1 to -0.5 on irregular "
                    "cages, up to 1 on regular ones (docs/POWER.md)",
    )
    outside: bpy.props.EnumProperty(
        name="Outside", items=OUTSIDE_ITEMS, default="RAISE", options=set(),
        description="What to do with mesh vertices that lie outside the cage when binding",
    )
    storage: bpy.props.EnumProperty(
        name="Storage", items=STORAGE_ITEMS, default="AUTO", options=set(),
        description="How the bind data is stored on the mesh and evaluated",
    )
    compact_size: bpy.props.IntProperty(
        name="Compact Slots", default=36, min=4, soft_max=96, options=set(),
        description="Numbers per vertex in Compact storage: more follow sharper cage "
                    "edits, fewer evaluate faster (Automatic measures how many it needs)",
    )
    auto_rebind: bpy.props.BoolProperty(
        name="Auto Rebind", default=False, options=set(),
        description="Bind again when leaving Edit Mode after the mesh's vertices were "
                    "added or deleted",
    )
    field_vertex: bpy.props.IntProperty(
        name="Cage Vertex", min=0, default=0, update=_field_vertex_changed, options=set(),
        description="Cage vertex whose coordinate field Show Coordinate paints on the mesh",
    )
