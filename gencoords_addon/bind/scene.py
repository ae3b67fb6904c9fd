"""What a Bind reads from the scene, once, and checks: the settings (``BindSettings``),
the mesh and its cage (``BindInput``: positions in the frame the coordinates are computed
in), and the bind-time cage exactly as the deformer's Object Info node will give it.
Every problem is a ``BindError`` saying what to do; nothing in the file changes.
"""

from dataclasses import dataclass
from typing import Optional

import bpy
import numpy as np

from ... import core
from ...core.planning import bind_steps
from .. import messages
from ..blender_io import compat, mesh_io
from ..blender_io.mesh_io import zero_scale_axes
from ..enums import core_name, is_green, is_harmonic, kind_label, kind_parameter, reads_quads
from ..errors import BindError
from ..graph import deformer, helpers
from .bindings import drives, is_deleted

# Blender stores positions as float32: a flat cage face after Apply Rotation, or a mesh
# vertex on the cage surface, is exact only to ~1e-7 of the cage's size, which the
# core's float64 default would call non-convex or outside.
FLOAT32_TOLERANCE = core.base.tolerances.FLOAT32


@dataclass(frozen=True)
class BindSettings:
    """The settings one Bind uses, read once when it starts: editing the panel while a
    modal Bind computes changes nothing in it."""

    cage: bpy.types.Object
    kind: str  # the core's name, e.g. 'mean_value'
    gamma: Optional[float]  # the kind's parameter; None for kinds without one
    outside: str  # the core's name, e.g. 'raise'
    storage: str  # the Storage setting: 'AUTO', 'EXACT', 'COMPACT' or 'SPARSE'
    compact_size: int
    sparse_size: int
    resolution: Optional[int]  # harmonic coordinates' grid; None: automatic, and for the other kinds
    kind_label: str  # the kind's user-facing name, for messages

    @classmethod
    def of(cls, obj):
        """A snapshot of ``obj.gencoords``."""
        settings = obj.gencoords
        has_gamma = kind_parameter(settings.kind) == "gamma"
        return cls(cage=settings.cage, kind=core_name(settings.kind),
                   gamma=float(settings.gamma) if has_gamma else None,
                   outside=core_name(settings.outside), storage=settings.storage,
                   compact_size=int(settings.compact_size), sparse_size=int(settings.sparse_size),
                   resolution=(None if settings.automatic_resolution else int(settings.resolution))
                   if is_harmonic(settings.kind) else None,
                   kind_label=kind_label(settings.kind))


@dataclass(frozen=True, eq=False)
class BindInput:
    """The mesh and the cage as a Bind computes with them."""

    points: np.ndarray  # (k, 3) float64: world space (Green: the mesh's local space)
    cage_vertices: np.ndarray  # (n, 3) float64, in the same space
    triangles: np.ndarray  # (m, 3) int, outward in that space
    triangle_faces: np.ndarray  # (m,) int: the cage face each triangle comes from
    rest_cage: np.ndarray  # (n, 3) float32, mesh-local, as Object Info gives it
    origins: np.ndarray  # (2, 3) float64: the mesh's and the cage's origins, in that space
    faces_hash: str  # mesh_io.faces_hash of the cage
    non_triangles: int  # the cage's faces split into triangles: quads and n-gons (quad kinds: n-gons)
    polygons: np.ndarray  # (p, 4) int: the cage's triangles and quads (mesh_io.read_polygons)
    polygon_faces: np.ndarray  # (p,) int: the cage face each polygon comes from


def check_inputs(obj):
    """Raise BindError unless ``obj`` is a mesh with a usable cage chosen."""
    if obj is None or obj.type != 'MESH':
        raise BindError("Select a mesh object to bind")
    if obj.library is not None or obj.data.library is not None:
        raise BindError(f"'{obj.name}' is linked from the library "
                        f"'{(obj.library or obj.data.library).filepath}' and cannot be "
                        "changed: use Object > Library Override > Make, then Bind")
    if obj.override_library is not None and obj.data.override_library is None \
            and obj.data.library is not None:
        raise BindError(f"The mesh of '{obj.name}' is linked from a library: make it local "
                        "(Object > Relations > Make Local > Object and Data), then Bind")
    cage = obj.gencoords.cage
    if cage is None:
        raise BindError(f"Choose a cage for '{obj.name}' first (GenCoords panel > Cage)")
    if cage == obj:
        raise BindError(f"'{obj.name}' cannot be its own cage: choose another mesh object")
    if cage.type != 'MESH':
        raise BindError(f"The cage '{cage.name}' must be a mesh object")
    if is_deleted(cage):
        raise BindError(f"The cage '{cage.name}' was deleted: pick another cage for "
                        f"'{obj.name}' (GenCoords panel > Cage)")
    if drives(obj, cage):
        raise BindError(f"'{cage.name}' is itself bound to '{obj.name}': a mesh and its cage "
                        "cannot drive each other")
    if len(obj.data.vertices) == 0:
        raise BindError(f"'{obj.name}' has no vertices to bind")


CAPTURE_GROUP = ".GenCoords capture"


def capture_rest_cage(obj, cage, context):
    """The evaluated cage in the mesh's local space, exactly as Object Info gives it.

    The deformer subtracts this from what its Object Info node reads at every
    evaluation; reading it through the same node (a temporary modifier last in the
    stack) makes the difference exactly zero at rest, so the mesh is unchanged bitwise.
    """
    group = helpers.build_capture_group(CAPTURE_GROUP)
    modifier = None
    try:
        modifier = obj.modifiers.new("GenCoords capture", 'NODES')
        modifier.node_group = group
        modifier.show_in_editmode = True
        compat.set_modifier_input(modifier, deformer.CAGE, cage)
        with mesh_io.evaluated_mesh(obj, context.evaluated_depsgraph_get()) as captured:
            return mesh_io.read_positions(captured).copy()
    finally:
        if modifier is not None:
            compat.remove_nodes_modifier(obj, modifier)
        bpy.data.node_groups.remove(group)


def read_bind_input(obj, settings, context):
    """Read the mesh ``obj`` and its cage (``settings.cage``) and check them: a
    ``BindInput`` in world space (Green coordinates: the mesh's local space)."""
    cage = settings.cage
    if is_harmonic(settings.kind) and settings.outside == 'extrapolate':  # refused before its field is solved
        raise BindError(messages.no_extrapolation(settings.kind_label))
    depsgraph = context.evaluated_depsgraph_get()
    rest = mesh_io.read_positions(obj.data).astype(np.float64)
    undefined = np.flatnonzero(~np.isfinite(rest).all(axis=1))
    if len(undefined):
        raise BindError(f"'{obj.name}' has {len(undefined)} vertices at undefined (NaN or "
                        f"infinite) positions (first: vertex {undefined[0]}): fix or "
                        "delete them, then Bind")
    flat_axes = zero_scale_axes(obj.evaluated_get(depsgraph).matrix_world)
    if flat_axes:  # its vertices would be flat in world space, and huge in its own
        raise BindError(messages.zero_scale("mesh", obj.name, flat_axes, "Bind"))
    try:
        geometry = mesh_io.read_evaluated_cage(cage, depsgraph)
    except core.CageError as error:  # NaN or infinite vertices: caught before triangles
        raise BindError(messages.cage_error(cage.name, error, settings.kind_label, ())) from None
    if len(geometry.triangles) == 0:
        raise BindError(f"The cage '{cage.name}' has no faces: it must be a closed "
                        "surface around the mesh (add faces, e.g. Mesh > Convex Hull)")
    flat_axes = zero_scale_axes(cage.evaluated_get(depsgraph).matrix_world)
    if flat_axes:
        raise BindError(messages.zero_scale("cage", cage.name, flat_axes, "Bind"))
    rest_cage = capture_rest_cage(obj, cage, context)
    if len(rest_cage) != len(geometry.positions):
        raise BindError(f"The cage '{cage.name}' changed while binding: try again")
    # Coordinates are computed where the artist sees the shapes, in world space (Green
    # coordinates in the mesh's local space: the core's ``computing_frame``).
    frame = (rest, rest_cage.astype(np.float64), geometry.triangles,
             np.array(obj.evaluated_get(depsgraph).matrix_world, dtype=np.float64),
             np.array(cage.evaluated_get(depsgraph).matrix_world)[:3, 3])
    points, cage_vertices, triangles, origins = bind_steps.computing_frame(*frame)
    if not np.isfinite(cage_vertices).all():
        raise BindError(f"The cage '{cage.name}' has vertices at undefined (NaN or "
                        "infinite) positions, or an object has zero scale: fix them, "
                        "then Bind")
    if is_green(settings.kind):
        if settings.outside == 'extrapolate':
            raise BindError(messages.no_extrapolation(settings.kind_label))
        points, cage_vertices, triangles, origins = bind_steps.computing_frame(*frame, local=True)
    # Kinds reading quads split only the faces of more corners (each gives several polygons).
    split = (int(np.count_nonzero(np.bincount(geometry.polygon_faces) > 1)) if reads_quads(settings.kind)
             else geometry.non_triangles)
    return BindInput(points, cage_vertices, triangles, geometry.triangle_faces, rest_cage, origins,
                     geometry.faces_hash, split, geometry.polygons, geometry.polygon_faces)
