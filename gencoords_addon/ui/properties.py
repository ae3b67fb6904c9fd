"""Per-object settings, reached from scripts as ``obj.gencoords``."""

import bpy

from ...core.base.parameters import GAMMA_LIMIT
from ...core.storage import Storage
from ...core.harmonic.cage_features import AUTOMATIC_FLOOR
from ...core.planning.request import BIND_RESOLUTION, SPARSE_SIZE
from ..enums import DEFAULT_KIND, KIND_ITEMS, OUTSIDE_ITEMS, STORAGE_ITEMS
from . import visualise


def _is_cage_candidate(settings, obj):
    return obj.type == 'MESH' and obj != settings.id_data


def _resolution_set(settings, context):
    # A Resolution typed or set from a script is the one wanted: not automatic any more.
    settings.automatic_resolution = False


def _field_vertex_changed(settings, context):
    visualise.repaint_if_shown(settings.id_data)


# Settings read when binding are not animatable: keyframing them would do nothing.
class GenCoordsSettings(bpy.types.PropertyGroup):
    cage: bpy.props.PointerProperty(
        name="Cage", type=bpy.types.Object, poll=_is_cage_candidate, options=set(),
        description="Closed mesh around this object whose vertices drive it after binding",
    )
    kind: bpy.props.EnumProperty(
        name="Coordinates", items=KIND_ITEMS, default=DEFAULT_KIND, options=set(),
        description="Generalized barycentric coordinates used to bind the mesh to the cage",
    )
    gamma: bpy.props.FloatProperty(
        name="Gamma", default=-0.5, soft_min=-2.0, soft_max=2.0, min=-GAMMA_LIMIT,
        max=GAMMA_LIMIT, step=10, options=set(),
        description="Power coordinates' exponent: -1 is Wachspress, 1 Voronoi. Positive "
                    "on every cage for -1; measured positive for -1 to -0.5 on irregular "
                    "cages, up to 1 on regular ones (docs/POWER.md). Bind refuses coordinates too large "
                    "to store precisely (large |gamma| in irregular cages)",
    )
    automatic_resolution: bpy.props.BoolProperty(
        name="Automatic", default=True, options=set(),
        description=f"Harmonic coordinates: a grid of {AUTOMATIC_FLOOR} cells along the cage's longest "
                    "side (fewer only where the free memory asks). Parts closer than a cell (pressed "
                    "fingers, closed lips) are kept apart by the grid itself, and the panel reports the "
                    "narrowest gap and thinnest part it met. Setting Resolution turns this off",
    )
    resolution: bpy.props.IntProperty(
        name="Resolution", default=BIND_RESOLUTION, min=4, soft_min=8, soft_max=128, max=512,
        options=set(), update=_resolution_set,
        description="Harmonic coordinates: grid cells along the cage's longest side, instead of "
                    "Automatic's (cubes, so a thin limb gets the cells its thickness allows). Finer "
                    "follows the cage more closely and binds slower (the time and memory grow as its "
                    "cube; Bind refuses a grid that would not fit in the free memory and names a "
                    "Resolution that does)",
    )
    outside: bpy.props.EnumProperty(
        name="Outside", items=OUTSIDE_ITEMS, default="RAISE", options=set(),
        description="What to do with mesh vertices that lie outside the cage when binding",
    )
    storage: bpy.props.EnumProperty(
        name="Storage", items=STORAGE_ITEMS, default=Storage.AUTO.value, options=set(),
        description="How the bind data is stored on the mesh and evaluated",
    )
    compact_size: bpy.props.IntProperty(
        name="Compact Slots", default=36, min=4, soft_max=96, options=set(),
        description="Numbers per vertex in Compact storage: more follow sharper cage "
                    "edits, fewer evaluate faster (Automatic measures how many it needs)",
    )
    sparse_size: bpy.props.IntProperty(
        name="Sparse Pairs", default=SPARSE_SIZE, min=1, soft_max=64, max=256, options=set(),
        description="Pairs (cage vertex, weight) per vertex in Sparse storage (Harmonic: per "
                    "grid node): more follow the exact coordinates more closely, fewer evaluate "
                    "faster (Automatic measures how many it needs)",
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
