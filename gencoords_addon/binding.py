"""Binding: the core's coordinates of every mesh vertex with respect to the cage."""

import time

import numpy as np

from .. import core
from . import mesh_io, messages, storage
from .properties import KIND_ITEMS, core_name, enum_label


# Blender stores positions as float32 (about 7 significant digits): a flat cage face
# after Apply Rotation, or a mesh vertex on the cage surface, is exact only to ~1e-7 of
# the cage's size. The core's default (1e-9, for float64 input) would call such a face
# non-convex and such a vertex outside; this is the float32 equivalent, with a margin.
FLOAT32_TOLERANCE = 1e-6


class BindError(Exception):
    """Binding is impossible; the message says why in Blender's terms."""


def rest_positions(obj):
    """The shape to bind: the stored rest shape when rebinding, else the mesh as it is.

    A rebind must not bake the current deformation into the rest shape; after an edit of
    the bound mesh (or a topology change) the edited mesh becomes the new rest.
    """
    bind = storage.load(obj)
    if (bind is None or obj.gencoords.edited_while_bound
            or bind.vertex_count_change(obj) is not None):
        return mesh_io.read_positions(obj.data)
    return bind.rest_positions


def _drives(obj, cage):
    """Whether ``cage`` follows ``obj``, directly or through a chain of bound cages."""
    seen = set()  # a chain already cyclic (from an older version) must not loop forever
    while cage is not None and cage.session_uid not in seen:
        if cage == obj:
            return True
        seen.add(cage.session_uid)
        cage = cage.gencoords.bound_cage
    return False


def check_inputs(obj):
    """Raise BindError unless ``obj`` is a mesh with a usable cage chosen."""
    if obj is None or obj.type != 'MESH':
        raise BindError("Select a mesh object to bind")
    cage = obj.gencoords.cage
    if cage is None:
        raise BindError(f"Choose a cage for '{obj.name}' first (GenCoords panel > Cage)")
    if cage == obj:
        raise BindError(f"'{obj.name}' cannot be its own cage: choose another mesh object")
    if cage.type != 'MESH':
        raise BindError(f"The cage '{cage.name}' must be a mesh object")
    if _drives(obj, cage.gencoords.bound_cage):
        raise BindError(f"'{cage.name}' is itself bound to '{obj.name}': a mesh and its cage "
                        "cannot drive each other")
    if len(obj.data.vertices) == 0:
        raise BindError(f"'{obj.name}' has no vertices to bind")
    if obj.data.users > 1:
        # The deformation is written into the mesh, which every user would share.
        raise BindError(f"'{obj.name}' shares its mesh with other objects (linked duplicates): "
                        "use Object > Relations > Make Single User, then Bind")
    if obj.data.shape_keys is not None:
        # Blender shows the shape-key blocks, not the ``position`` attribute Bind writes.
        raise BindError(f"'{obj.name}' has shape keys, which would hide the cage's "
                        "deformation: apply or remove them (Object Data properties > Shape "
                        "Keys), then Bind")


def bind(obj, depsgraph, report_progress=lambda fraction: None):
    """Compute and return the ``storage.BindData`` of ``obj`` (nothing is written).

    Mesh vertices are mapped into the cage's local space, where the evaluated cage
    (modifiers applied) is taken as the rest cage. Raises BindError on any problem.
    """
    started = time.perf_counter()
    check_inputs(obj)
    settings = obj.gencoords
    cage = settings.cage
    kind = core_name(settings.kind)
    outside = core_name(settings.outside)
    kind_label = enum_label(KIND_ITEMS, settings.kind)

    rest = rest_positions(obj)
    geometry = mesh_io.read_evaluated_cage(cage, depsgraph)
    try:
        mesh_to_cage = mesh_io.cage_to_mesh_matrix(obj, cage, depsgraph).inverted()
    except ValueError:
        raise BindError(f"'{obj.name}' or its cage '{cage.name}' has zero scale: "
                        "fix the transform") from None
    undefined = np.flatnonzero(~np.isfinite(rest).all(axis=1))
    if len(undefined):
        raise BindError(f"'{obj.name}' has {len(undefined)} vertices at undefined (NaN or "
                        f"infinite) positions (first: vertex {undefined[0]}): fix or delete "
                        "them, then Bind")
    points = mesh_io.transform_points(mesh_to_cage, rest)
    vertices = geometry.positions.astype(np.float64)
    triangles = geometry.triangles

    locations = np.empty(len(points), dtype=np.int8)
    try:
        # One pass validates the cage, locates the points (outside ones are an error
        # unless Outside says otherwise) and computes the coordinates. Kept as float32:
        # half the memory, and the mesh positions they yield are float32; the core
        # writes float32 directly, so no float64 matrix exists at peak.
        coordinates = core.coordinates(points, vertices, triangles, kind=kind, outside=outside,
                                       progress=report_progress, dtype=np.float32,
                                       locations=locations, tolerance=FLOAT32_TOLERANCE)
    except ValueError as error:  # every core error is a ValueError
        raise BindError(messages.core_error(cage.name, error, kind_label, len(points),
                                            geometry.triangle_faces)) from None
    if not np.isfinite(coordinates).all():
        raise BindError(f"Binding to '{cage.name}' gave undefined coordinates: "
                        "check the cage for tiny or overlapping faces")

    summary = core.coordinate_summary(coordinates)
    return storage.BindData(
        coordinates=coordinates,
        rest_positions=np.array(rest, dtype=np.float32),
        cage_vertex_count=len(vertices),
        cage_faces_hash=geometry.faces_hash,
        cage_non_triangles=geometry.non_triangles,
        kind=kind,
        outside=outside,
        bind_seconds=time.perf_counter() - started,
        points_outside=int(np.count_nonzero(locations == core.OUTSIDE)),
        points_on_boundary=int(np.count_nonzero(locations == core.BOUNDARY)),
        min_coordinate=summary["min"],
        negative_points=summary["negative_points"],
        max_affine_error=summary["max_affine_error"],
        nbytes=summary["nbytes"],
    )

