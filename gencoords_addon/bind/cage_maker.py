"""Make Cage: a closed, convex, triangulated cage around a mesh, built for binding.

The core intersects supporting half-spaces around the mesh (``core.cages.enclosing``), so the
cage is convex and encloses every vertex by construction; bmesh's convex hull orders the
polar dual and the final faces. The result is checked with the core's own cage
validation before it is added to the scene.
"""

import bmesh
import bpy
import numpy as np

from ... import core
from ...core.cages import enclosing
from .. import messages, preferences
from ..blender_io import mesh_arrays, mesh_io
from ..errors import CageError
from ..steps import run_to_end
from . import cage_tight
from .scene import FLOAT32_TOLERANCE, zero_scale_axes
from .service import in_workers_or_blender, object_mode


CORNER_MERGE = 1e-4  # corners closer than this (of the mesh's size) are one
# Margin 0 still keeps this gap (of the mesh's size): merging corners and float32 rounding
# move the cage's faces by up to ~2 CORNER_MERGE, which must not cut a vertex off.
MIN_MARGIN = 4 * CORNER_MERGE
MARGIN_TRIES, MARGIN_GROWTH = 4, 4.0
# Bind reads the cage in the mesh's local space, in float32, through Blender's float32
# matrix arithmetic (``scene.capture_rest_cage``): its vertices there are off by up to
# this many float32 steps (two roundings of half a step) at the size of the mesh's local
# coordinates.
BIND_ROUNDING_STEPS = 1.0
HULL_TRIES = 64  # hulls, each without the corners the last one left not convex


def _hull(points):
    """Triangles of the convex hull of ``points`` ((k, 3)), by point index, outward."""
    bm = bmesh.new()
    try:
        verts = [bm.verts.new(p) for p in points]
        for index, vert in enumerate(verts):
            vert.index = index
        result = bmesh.ops.convex_hull(bm, input=verts, use_existing_faces=False)
        faces = [f for f in result["geom"] if isinstance(f, bmesh.types.BMFace)]
        bmesh.ops.triangulate(bm, faces=faces)
        return np.array([[v.index for v in f.verts] for f in bm.faces if len(f.verts) == 3
                         and all(v.index >= 0 for v in f.verts)], dtype=np.int64)
    finally:
        bm.free()


def make_cage_geometry(points, target_vertices, margin):
    """Vertices (c, 3) and outward triangles (m, 3) of a convex cage around ``points``.

    Parameters
    ----------
    points : (k, 3) float
        Mesh vertices in world space.
    target_vertices : int
        About how many vertices the cage gets (a polytope of d faces has about 2d - 4).
    margin : float
        Gap between the mesh and the cage, relative to the mesh's bounding-box diagonal.
    """
    points = np.asarray(points, dtype=np.float64)
    size = float(np.linalg.norm(np.ptp(points, axis=0)))  # > 0: ``_enclosed_points`` checked
    directions = enclosing.sphere_directions(max(4, target_vertices // 2 + 2))
    offsets = enclosing.supporting_offsets(points, directions, max(margin, MIN_MARGIN) * size)
    dual = enclosing.dual_points(directions, offsets, points.mean(axis=0))
    corners = enclosing.facet_vertices(directions, offsets, _hull(dual))
    # Facets of one dual face meet at one corner, and nearly parallel planes at corners
    # a hair apart that a float32 hull cannot order: keep one of each cluster (the margin
    # dwarfs the move).
    rounded = np.round(corners / (size * CORNER_MERGE)).astype(np.int64)
    _, keep = np.unique(rounded, axis=0, return_index=True)
    vertices = corners[np.sort(keep)].astype(np.float32).astype(np.float64)
    for _ in range(HULL_TRIES):
        triangles = _hull(vertices)
        used = np.unique(triangles)
        remap = np.full(len(vertices), -1)
        remap[used] = np.arange(len(used))
        vertices, triangles = vertices[used], core.cages.orient_facets_outward(vertices[used],
                                                                         remap[triangles])
        try:
            core.advanced.validate_cage(vertices, triangles, convex=True, tolerance=FLOAT32_TOLERANCE)
            return vertices, triangles
        except core.CageError as error:
            if error.problem != "non_convex" or not error.vertices:
                raise CageError(f"the cage failed the cage check: {error}") from None
            # A corner the hull left slightly inside a face: dropping it and hulling
            # again keeps the polytope convex (and, within the margin, enclosing).
            vertices = np.delete(vertices, list(error.vertices), axis=0)
    raise CageError("the cage stayed non-convex after hulling again: try another vertex count")


def _enclosed_points(obj, context):
    """The mesh's vertices to enclose, in world space ((k, 3) float64): those Bind binds
    (the mesh data) and those the artist sees (with modifiers and shape keys), with
    ``with_rounding_copies``; CageError when they cannot be."""
    depsgraph = context.evaluated_depsgraph_get()
    with mesh_io.evaluated_mesh(obj, depsgraph) as evaluated:
        seen = mesh_io.read_positions(evaluated).astype(np.float64)
    bound = mesh_io.read_positions(obj.data).astype(np.float64)
    if len(bound) < 4:
        raise CageError(f"'{obj.name}' needs at least 4 vertices to make a cage around")
    for local, where in ((bound, ""), (seen, " with its modifiers and shape keys")):
        undefined = np.flatnonzero(~np.isfinite(local).all(axis=1))
        if len(undefined):
            raise CageError(f"'{obj.name}' has {len(undefined)} vertices at undefined (NaN or infinite) "
                            f"positions{where} (first: vertex {undefined[0]}): fix or delete them first")
    local = np.concatenate([bound, seen])
    flat_axes = zero_scale_axes(obj.matrix_world)
    if flat_axes:  # the cage would be flat
        raise CageError(messages.zero_scale("mesh", obj.name, flat_axes, "Make Cage"))
    world = np.array(obj.matrix_world, dtype=np.float64)
    points, corners = local @ world[:3, :3].T + world[:3, 3], rounding_corners(local, world)
    try:  # one refusal for both shapes, before anything is made
        core.cages.enclosing.mesh_extent(points, float(np.linalg.norm(corners, axis=1).max()))
    except core.CageError as error:
        raise CageError(f"'{obj.name}': {error} (move its vertices apart in Edit Mode, or "
                        "choose another mesh)") from None
    return with_rounding_copies(points, corners)


def rounding_corners(local, world):
    """The corners (8, 3), in world space, of the box of half-width r about a point in the
    mesh's local axes: r is Bind's rounding of the cage into the mesh's local space (r per
    coordinate, ``BIND_ROUNDING_STEPS`` float32 steps at the size of ``local`` (k, 3))."""
    step = BIND_ROUNDING_STEPS * float(np.spacing(np.float32(np.abs(local).max(initial=0.0))))
    signs = np.array(np.meshgrid([-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0])).reshape(3, -1).T
    return (signs * step) @ world[:3, :3].T


def with_rounding_copies(points, corners):
    """``points`` ((k, 3), world space), and where Bind's rounding of the cage into the
    mesh's local space (``rounding_corners``) is not negligible against the mesh's size
    (its data lies far from its object's origin), copies of each at those corners: a
    cage enclosing them keeps ``points`` inside once Bind has rounded its vertices, which
    moves a face by at most r |n|_1 along its normal n (some corner lies that far beyond
    the point)."""
    if np.linalg.norm(corners, axis=1).max() <= FLOAT32_TOLERANCE * np.linalg.norm(np.ptp(points, axis=0)):
        return points
    return np.concatenate([points] + [points + corner for corner in corners])


def _enclosing_cage(obj, points, target_vertices, margin, context):
    """``make_cage_geometry`` around ``points``, checked to enclose them; where corners
    dropped to keep it convex cut a vertex off (small margins), made again with a margin
    MARGIN_GROWTH times larger, up to MARGIN_TRIES times. Returns (vertices, triangles,
    worker failure or None)."""
    for _ in range(MARGIN_TRIES):
        stored, triangles = make_cage_geometry(points, target_vertices, margin)
        outside, worker_failure = in_workers_or_blender(
            lambda workers: core.point_locations(points, stored, triangles, tolerance=FLOAT32_TOLERANCE,
                                                 workers=workers), preferences.worker_count(context))
        count = int(np.count_nonzero(outside == core.OUTSIDE))
        if count == 0:
            return stored, triangles, worker_failure
        margin = max(margin, MIN_MARGIN) * MARGIN_GROWTH
    raise CageError(f"{count} vertices of '{obj.name}' ended outside the cage: raise the margin")


def make_cage(obj, context, target_vertices=100, margin=0.05, tight=False, distance=None, keep_gaps=True):
    """:func:`make_cage_steps` run to the end (scripts, background mode)."""
    return run_to_end(make_cage_steps(obj, context, target_vertices, margin, tight, distance, keep_gaps))


def make_cage_steps(obj, context, target_vertices=100, margin=0.05, tight=False, distance=None, keep_gaps=True):
    """Add a cage object around the mesh object ``obj`` and pick it as its cage, in steps
    (see ``steps.py``: a modal Make Cage shows their progress and takes Esc between
    them; closed early, nothing is left behind): returns (the cage, None or what to say
    about worker processes that failed, see :func:`service.in_workers_or_blender`).
    ``tight``: a non-convex cage hugging the mesh (``cage_tight``); ``distance``: the
    margin in world units, not a share of the mesh's size; ``keep_gaps``: Tight's offset
    below the gaps between the mesh's parts (``cage_tight.tight_cage_steps``).

    A mesh farther from the origin than its size gets its cage object at the middle of
    its bounds (a float32 location), with vertices relative to it: float32 vertices then
    keep the cage's shape however far from the origin and however small the mesh.
    """
    with object_mode(context, obj):
        points = _enclosed_points(obj, context)
        triangles = cage_tight.enclosed_triangles(obj, context) if tight else None
    centre = ((points.min(axis=0) + points.max(axis=0)) / 2).astype(np.float32).astype(np.float64)
    if np.linalg.norm(centre) <= np.linalg.norm(np.ptp(points, axis=0)):
        centre[:] = 0.0  # near the origin: the cage object there, read back without a transform
    points = points - centre
    if distance is not None:
        margin = distance / max(float(np.linalg.norm(np.ptp(points, axis=0))), np.finfo(float).tiny)
    yield 0.0
    if tight:  # the core checks the enclosure, as stored
        stored, faces, worker_failure = yield from cage_tight.tight_cage_steps(
            points, triangles, target_vertices, margin, context, keep_gaps)
    else:
        stored, faces, worker_failure = _enclosing_cage(obj, points, target_vertices, margin, context)
    with object_mode(context, obj):
        return _add_cage(obj, stored, faces, centre), worker_failure


def _add_cage(obj, stored, faces, centre):
    """The cage object of vertices ``stored`` (c, 3) and ``faces`` (triangles, and quads
    for Tight) at ``centre``, in the mesh's collections, picked as its cage: all or
    nothing (what was added goes again on a failure)."""
    mesh = bpy.data.meshes.new(f"{obj.name} cage")
    cage = None
    try:
        mesh.from_pydata(stored.tolist(), [], [list(face) for face in faces])
        mesh.update()
        cage = bpy.data.objects.new(f"{obj.name} cage", mesh)
        cage.location = centre.tolist()
        cage.display_type = 'WIRE'
        for collection in obj.users_collection:
            collection.objects.link(cage)
        obj.gencoords.cage = cage
    except Exception:
        if cage is not None:
            bpy.data.objects.remove(cage)
        bpy.data.meshes.remove(mesh)
        raise
    return cage


def select_dented_faces(obj):
    """Select exactly the faces of the mesh object ``obj`` that dent inward
    (``core.advanced.concave_facets``); returns how many. Object Mode only."""
    mesh = obj.data
    positions = mesh_io.read_positions(mesh)
    triangles, triangle_faces = mesh_io.read_triangles(mesh, positions)
    dented = np.unique(triangle_faces[core.advanced.concave_facets(positions, triangles, FLOAT32_TOLERANCE)])
    faces = np.zeros(len(mesh.polygons), dtype=bool)
    faces[dented] = True
    mesh_arrays.select_faces(mesh, faces)
    return len(dented)
