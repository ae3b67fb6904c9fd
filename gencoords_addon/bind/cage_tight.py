"""Make Cage, Tight: a non-convex cage of quads and triangles that hugs the mesh at an offset.

Blender's own tools shape it, on a temporary copy of the mesh in world space: a voxel
remesh (the union of overlapping parts, one closed surface), a displacement along the
normals by the offset, a second voxel remesh (folds of the displaced surface in
hollows become one surface again) and a collapse decimation to the vertex count;
bmesh's Tris to Quads joins about half of the triangles into quads, which an artist
edits more easily. The core then pushes the cage out until it encloses every mesh
vertex and checks it (closed, manifold, outward, neither touching nor passing through
itself): ``gencoords.tools.tight_cage.fit_tight_cage``. Nothing of the copy is left
behind.
"""

import math

import bmesh
import bpy
import numpy as np

from ... import core
from ...core.tools import surface, tight_cage
from .. import preferences
from ..blender_io import mesh_io
from ..blender_io.mesh_arrays import read_loop_triangles, read_positions
from ..errors import CageError
from .scene import FLOAT32_TOLERANCE
from .service import in_workers_or_blender

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


def _decimated(obj, remeshed_count, target_vertices, context):
    decimate = obj.modifiers.get("Vertices") or obj.modifiers.new("Vertices", 'DECIMATE')
    decimate.decimate_type, decimate.use_collapse_triangulate = 'COLLAPSE', True
    # A share of the faces: a closed mesh's faces and vertices shrink in proportion.
    decimate.ratio = min(1.0, target_vertices / remeshed_count)
    return _evaluated(obj, context)


def offset_surface(points, triangles, offset, target_vertices, context):
    """The mesh's surface offset by ``offset`` and decimated to about ``target_vertices``:
    vertices (n, 3) float64 and triangles (m, 3), in the points' space.

    A mesh with holes or thin open parts can come out of a fine voxel remesh in many
    small pieces, each of which the decimation shrinks to two back-to-back triangles:
    the coarsest voxels are tried then, which keep such a mesh in one piece."""
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    obj = _temporary_object(points, triangles, context)
    mesh = obj.data
    try:
        for voxel in dict.fromkeys((voxel_size(offset, size), COARSEST_VOXEL * size)):
            obj.modifiers.clear()
            _add_modifiers(obj, offset, voxel)
            remeshed, _ = _evaluated(obj, context)
            if len(remeshed) < 4:
                raise CageError("the voxel remesh left nothing: the mesh has no volume to wrap "
                                "(close it, or use Convex)")
            decimated = _decimated(obj, len(remeshed), target_vertices, context)
            if not surface.degenerate_pieces(decimated[1]):
                return decimated
        raise CageError("the voxel remesh breaks the mesh into more pieces than the vertices asked "
                        "for can wrap (holes or thin open parts): raise Vertices, raise Offset (up "
                        f"to {tight_cage.LARGEST_OFFSET:g}) to wrap the thin parts whole, close the "
                        "holes, or use Convex")
    finally:
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)


def make_tight_cage_geometry(points, triangles, target_vertices, offset, tolerance, context,
                             workers=None):
    """Vertices (c, 3) float64 and outward faces (a list of triangles and quads, lists of
    vertex indices) of a tight cage around the mesh.

    Parameters
    ----------
    points : (k, 3) float
        Mesh vertices in world space.
    triangles : (t, 3) int
        The mesh's triangles.
    target_vertices : int
    offset : float
        Distance between the mesh and the cage, in world units.
    tolerance : float
        Relative to the cage's size (positions are stored as float32).
    workers : int or None
        Worker processes for the enclosure check.
    """
    if not len(triangles):
        raise CageError("Tight wraps the mesh's faces and it has none: use Convex")
    # Blender shapes a copy of unit size about the origin: voxel sizes have a floor, and
    # float32 positions far from the origin lose the detail.
    centre = (points.min(axis=0) + points.max(axis=0)) / 2.0
    size = float(np.linalg.norm(np.ptp(points, axis=0)))
    unit, faces = offset_surface((points - centre) / size, triangles, offset / size,
                                 target_vertices, context)
    triangles, quads = join_triangles(unit, faces)
    vertices = unit * size + centre
    clearance = CLEARANCE * max(offset, FINEST_VOXEL * size)
    try:  # checked as stored (float32) and as Bind splits the quads
        # Once each: the mesh data's and the evaluated mesh's vertices often coincide.
        vertices, _ = tight_cage.fit_tight_cage(vertices, triangles, np.unique(points, axis=0),
                                                clearance, tolerance,
                                                workers=workers, stored_as=np.float32, quads=quads)
    except (core.CageError, tight_cage.TightCageError) as error:
        raise CageError(f"the tight cage failed: {error}") from None
    return vertices, triangles.tolist() + quads.tolist()


def enclosed_triangles(obj, context):
    """Triangles (m, 3) of the points Make Cage encloses (``cage_maker._enclosed_points``):
    the mesh data's (what Bind binds), then the evaluated mesh's (modifiers and shape
    keys, what the artist sees), numbered after the mesh data's vertices."""
    with mesh_io.evaluated_mesh(obj, context.evaluated_depsgraph_get()) as evaluated:
        seen = read_loop_triangles(evaluated)
    return np.concatenate([read_loop_triangles(obj.data), seen + len(obj.data.vertices)])


def make_tight_cage(points, triangles, target_vertices, margin, context):
    """:func:`make_tight_cage_geometry` with the offset a share ``margin`` of the mesh's
    bounding-box diagonal, float32 tolerances and the preferences' worker processes (in
    Blender's process if they cannot start): vertices, triangles and None or what to say
    about the workers (:func:`service.in_workers_or_blender`)."""
    size = float(np.linalg.norm(np.ptp(points, axis=0)))  # > 0: Make Cage checked
    try:
        tight_cage.check_offset(margin)
    except tight_cage.TightCageError as error:
        raise CageError(str(error)) from None
    (vertices, faces), worker_failure = in_workers_or_blender(
        lambda workers: make_tight_cage_geometry(points, triangles, target_vertices, margin * size,
                                                 FLOAT32_TOLERANCE, context, workers),
        preferences.worker_count(context))
    return vertices, faces, worker_failure
