"""Make Cage, Tight: a non-convex cage of quads and triangles that hugs the mesh at an offset.

Blender's own tools shape it, on a temporary copy of the mesh in world space: a voxel
remesh (the union of overlapping parts, one closed surface), a displacement along the
normals by the offset, a second voxel remesh (folds of the displaced surface in
hollows become one surface again) and a collapse decimation to the vertex count;
bmesh's Tris to Quads joins about half of the triangles into quads, which an artist
edits more easily. The core then pushes the cage out until it encloses every mesh
vertex and checks it (closed, manifold, outward, neither touching nor passing through
itself): ``gencoords.cages.tight_cage.fit_tight_cage``. Nothing of the copy is left
behind.
"""

import math

import bmesh
import bpy
import numpy as np
from mathutils.bvhtree import BVHTree

from ... import core
from ...core.cages import enclosing, surface, tight_cage
from .. import preferences
from ..blender_io import mesh_io
from ..blender_io.mesh_arrays import read_loop_triangles, read_positions
from ..errors import CageError
from ..steps import scaled
from .scene import FLOAT32_TOLERANCE
from .service import steps_in_workers_or_blender

# Voxels: half the offset, within these shares of the mesh's size (a fine grid costs
# time and memory; a coarse one loses thin parts before they are offset).
FINEST_VOXEL = 1.0 / 400
COARSEST_VOXEL = 1.0 / 60
CLEARANCE = 0.25  # a pushed face passes left-out vertices by this share of the offset
# Triangles join into a quad where their normals and the quad's corners stay within this
# of flat and square: about half of a decimated cage's faces become quads.
QUAD_ANGLE = math.radians(40.0)


def join_triangles(vertices, triangles):
    """Pairs of triangles joined into quads, as an artist edits more easily (bmesh's
    Tris to Quads): the triangles left (m, 3) and the quads (q, 4), windings kept."""
    bm = bmesh.new()
    try:
        verts = [bm.verts.new(point) for point in vertices]
        for triangle in triangles:
            bm.faces.new([verts[index] for index in triangle])
        bm.verts.index_update()
        bm.normal_update()
        bmesh.ops.join_triangles(bm, faces=bm.faces[:], angle_face_threshold=QUAD_ANGLE,
                                 angle_shape_threshold=QUAD_ANGLE)
        faces = [[vert.index for vert in face.verts] for face in bm.faces]
    finally:
        bm.free()
    return (np.array([face for face in faces if len(face) == 3], dtype=np.int64).reshape(-1, 3),
            np.array([face for face in faces if len(face) == 4], dtype=np.int64).reshape(-1, 4))


def voxel_size(offset, size):
    """The remesh's voxel size for ``offset`` around a mesh of bounding-box diagonal ``size``."""
    return float(np.clip(offset / 2.0, FINEST_VOXEL * size, COARSEST_VOXEL * size))


def _temporary_object(points, triangles, context):
    mesh = bpy.data.meshes.new("GenCoords tight cage (temporary)")
    mesh.from_pydata(points.tolist(), [], triangles.tolist())
    mesh.update()
    obj = bpy.data.objects.new(mesh.name, mesh)
    context.scene.collection.objects.link(obj)
    return obj


def _add_modifiers(obj, offset, voxel):
    first = obj.modifiers.new("Union", 'REMESH')
    first.mode, first.voxel_size = 'VOXEL', voxel
    displace = obj.modifiers.new("Offset", 'DISPLACE')
    displace.direction, displace.mid_level, displace.strength = 'NORMAL', 0.0, offset
    second = obj.modifiers.new("Unfold", 'REMESH')
    second.mode, second.voxel_size = 'VOXEL', voxel


def _evaluated(obj, context):
    """Positions (n, 3) float64 and loop triangles (m, 3) of ``obj`` with its modifiers."""
    evaluated = obj.evaluated_get(context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return read_positions(mesh).astype(np.float64), read_loop_triangles(mesh)
    finally:
        evaluated.to_mesh_clear()


def _applied(obj, context):
    """A new mesh of ``obj`` with its modifiers applied; then ``obj`` has it, and none."""
    mesh = bpy.data.meshes.new_from_object(obj.evaluated_get(context.evaluated_depsgraph_get()))
    obj.modifiers.clear()
    obj.data = mesh
    return mesh


def _decimated(obj, target_vertices, context):
    decimate = obj.modifiers.new("Vertices", 'DECIMATE')
    decimate.decimate_type, decimate.use_collapse_triangulate = 'COLLAPSE', True
    # A share of the faces: a closed mesh's faces and vertices shrink in proportion.
    decimate.ratio = min(1.0, target_vertices / len(obj.data.vertices))
    return _evaluated(obj, context)


def offset_surface_steps(points, triangles, offset, target_vertices, context):
    """The mesh's surface offset by ``offset`` and decimated to about ``target_vertices``,
    in steps (Blender's remesh, then its decimation: each one call): a generator of the
    fraction done returning vertices (n, 3) float64 and triangles (m, 3), in the points'
    space. Closed early, or failing, it leaves nothing behind.

    A mesh with holes or thin open parts can come out of a fine voxel remesh in many
    small pieces, each of which the decimation shrinks to two back-to-back triangles:
    the coarsest voxels are tried then, which keep such a mesh in one piece."""
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    obj = _temporary_object(points, triangles, context)
    meshes = [obj.data]
    try:
        for attempt, voxel in enumerate(dict.fromkeys((voxel_size(offset, size), COARSEST_VOXEL * size))):
            obj.data = meshes[0]
            _add_modifiers(obj, offset, voxel)
            meshes.append(_applied(obj, context))  # remeshed once, decimated from there
            if len(obj.data.vertices) < 4:
                raise CageError("the voxel remesh left nothing: the mesh has no volume to wrap "
                                "(close it, or use Convex)")
            yield (2 * attempt + 1) / 4
            decimated = _decimated(obj, target_vertices, context)
            if not surface.degenerate_pieces(decimated[1]):
                return decimated
            obj.modifiers.clear()
            yield (2 * attempt + 2) / 4
        raise CageError("the voxel remesh breaks the mesh into more pieces than the vertices asked "
                        "for can wrap (holes or thin open parts): raise Vertices, raise Offset (up "
                        f"to {enclosing.LARGEST_OFFSET:g}) to wrap the thin parts whole, close the "
                        "holes, or use Convex")
    finally:
        bpy.data.objects.remove(obj)
        for mesh in meshes:
            bpy.data.meshes.remove(mesh)


def enclosed_triangles(obj, context):
    """Triangles (m, 3) of the points Make Cage encloses (``cage_maker._enclosed_points``):
    the mesh data's (what Bind binds), then the evaluated mesh's (modifiers and shape
    keys, what the artist sees), numbered after the mesh data's vertices."""
    with mesh_io.evaluated_mesh(obj, context.evaluated_depsgraph_get()) as evaluated:
        seen = read_loop_triangles(evaluated)
    return np.concatenate([read_loop_triangles(obj.data), seen + len(obj.data.vertices)])


# Of Make Cage Tight's progress, Blender's shaping's share; the core's fit takes the rest.
SHAPING = 0.7
GAP_TRIES, TRY_SHARE = 2, 0.4  # tries keeping the gaps; the progress each leaves to the next
LIFT = 1e-6  # rays start this share of the mesh's size off its surface: past their own face


def narrowest_gap(points, triangles):
    """The narrowest gap between the parts of the mesh of ``points`` (k, 3) and
    ``triangles`` (t, 3), a share of its size (``inf`` where no parts face each other):
    rays from its surface (``surface.ray_samples``) cast with Blender's BVH tree, the
    core judging the hits (``surface.narrowest_gap``)."""
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    tree = BVHTree.FromPolygons(points.tolist(), triangles.tolist(), epsilon=0.0)
    origins, directions = surface.ray_samples(points, triangles)
    distances, cosines = np.full(len(origins), np.inf), np.zeros(len(origins))
    for index, (origin, direction) in enumerate(zip((origins + LIFT * size * directions).tolist(),
                                                    directions.tolist())):
        location, normal, _, distance = tree.ray_cast(origin, direction)
        if location is not None:
            distances[index], cosines[index] = distance, normal.dot(direction)
    return surface.narrowest_gap(distances, cosines) / size


def tight_cage_steps(points, triangles, target_vertices, margin, context, keep_gaps=True):
    """A tight cage around the mesh, in steps: a generator of the fraction done returning
    its vertices (c, 3) float64, its outward faces (a list of triangles and quads, lists of
    vertex indices) and None or what to say about worker processes that failed
    (:func:`service.steps_in_workers_or_blender`: the preferences' workers check the
    enclosure, Blender's process where they cannot).

    Parameters
    ----------
    points : (k, 3) float
        Mesh vertices in world space (with an extent: Make Cage checked).
    triangles : (t, 3) int
        The mesh's triangles.
    target_vertices : int
    margin : float
        Distance between the mesh and the cage, a share of the mesh's bounding-box
        diagonal.
    keep_gaps : bool
        An offset above a third of the narrowest gap between the mesh's parts lowered to
        a sixth of it (``enclosing.offset_for_gap``), so the cage keeps them apart; where
        it still crosses or touches itself, once more with twice the vertices
        (``GAP_TRIES``).
    """
    if not len(triangles):
        raise CageError("Tight wraps the mesh's faces and it has none: use Convex")
    try:
        enclosing.check_offset(margin)
    except core.CageError as error:
        raise CageError(str(error)) from None
    gap = narrowest_gap(points, triangles) if keep_gaps else np.inf
    asked, margin = margin, enclosing.offset_for_gap(margin, gap)
    # Lowered below the gaps, a cage can still cross itself where the decimation's chords
    # are long against them: once more with twice the vertices before telling the artist
    # (on the hand fixture, where crossings come and go with both settings, 100 vertices at
    # Offset 0.0032 pass and 200 or 400 cross: the second try is a second chance).
    tries = GAP_TRIES if margin < asked else 1
    for attempt in range(tries):
        start = 1.0 - TRY_SHARE ** attempt  # each try's progress after the last one's
        span = 1.0 - start if attempt == tries - 1 else (1.0 - TRY_SHARE) * TRY_SHARE ** attempt
        vertices = target_vertices * 2 ** attempt
        try:
            return (yield from scaled(_tight_cage_try(points, triangles, vertices, margin, context), start, span))
        except tight_cage.TightCageError as error:
            if error.problem not in ("pinched", "self_intersecting"):
                raise CageError(f"the tight cage failed: {error}") from None
            if attempt == tries - 1:
                advice = (error.advice if tries == 1 else
                          f"try other Vertices than {target_vertices} and {vertices}, or Offset a "
                          f"little below {margin:.2g} (lowered to 1/{round(1 / enclosing.GAP_SHARE)} of "
                          f"the narrowest gap between the mesh's parts, {gap:.2g} of its size, "
                          "already); or Convex")
                raise CageError(f"the tight cage failed: {error.cause}: {advice}") from None
        except core.CageError as error:
            raise CageError(f"the tight cage failed: {error}") from None


def _tight_cage_try(points, triangles, target_vertices, margin, context):
    """One try of :func:`tight_cage_steps` at ``target_vertices`` and the offset
    ``margin``: the same generator and result; the core's errors pass."""
    # Blender shapes a copy of unit size about the origin: voxel sizes have a floor, and
    # float32 positions far from the origin lose the detail.
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    shaping = offset_surface_steps((points - centre) / size, triangles, margin, target_vertices, context)
    unit, faces = yield from scaled(shaping, 0.0, SHAPING)
    triangles, quads = join_triangles(unit, faces)
    # Checked as stored (float32) and as Bind splits the quads; the mesh data's and the
    # evaluated mesh's vertices, which often coincide, once each.
    clearance = CLEARANCE * max(margin, FINEST_VOXEL) * size
    fitting = steps_in_workers_or_blender(
        lambda workers: tight_cage.fit_tight_cage_steps(unit * size + centre, triangles, np.unique(points, axis=0),
                                                        clearance, FLOAT32_TOLERANCE, workers=workers,
                                                        stored_as=np.float32, quads=quads),
        preferences.worker_count(context))
    (vertices, _), worker_failure = yield from scaled(fitting, SHAPING, 1.0 - SHAPING)
    return vertices, triangles.tolist() + quads.tolist(), worker_failure
