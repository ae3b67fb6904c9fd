"""What Bind reads from Blender meshes: positions (``mesh_arrays``), triangles, face
fingerprints and the evaluated cage."""

import contextlib
import hashlib
from dataclasses import dataclass

import numpy as np

from ... import core
from ...core.planning import bind_steps
from .mesh_arrays import (read_corner_vertices, read_face_sizes, read_faces, read_loop_triangle_faces,
                          read_positions)


def read_triangles(mesh, positions):
    """Triangulation of ``mesh``'s faces, with the face each triangle comes from.

    Quads are split by the core along the diagonal that keeps a bent quad convex (a
    dragged corner of a convex quad cage must not make it non-convex); other faces use
    ``loop_triangles``, Blender's own triangulation. Windings follow the face normals.

    Returns
    -------
    triangles : (m, 3) int64
    faces : (m,) int64
        Index of the mesh face of each triangle (for messages the artist can act on).
    """
    starts, sizes, corners = read_faces(mesh)
    blender, blender_faces = read_loop_triangle_faces(mesh)
    keep = sizes[blender_faces] != 4
    quads = np.flatnonzero(sizes == 4)
    quad_corners = corners[starts[quads, None] + np.arange(4)]
    triangles = np.concatenate([blender[keep], core.cages.triangulate_quads(positions, quad_corners)])
    return triangles, np.concatenate([blender_faces[keep], np.repeat(quads, 2)])


def read_polygons(mesh):
    """The faces of ``mesh`` as triangles and quads, unsplit; faces of more corners in
    Blender's triangulation (``loop_triangles``).

    Returns
    -------
    polygons : (p, 4) int64
        A triangle's fourth index is -1.
    faces : (p,) int64
        Index of the mesh face of each polygon.
    """
    starts, sizes, corners = read_faces(mesh)
    small = np.flatnonzero(sizes <= 4)
    polygons = np.full((len(small), 4), -1, dtype=np.int64)
    for size in (3, 4):
        chosen = sizes[small] == size
        polygons[chosen, :size] = corners[starts[small[chosen], None] + np.arange(size)]
    blender, blender_faces = read_loop_triangle_faces(mesh)
    large = sizes[blender_faces] > 4
    split = np.column_stack([blender[large], np.full(int(large.sum()), -1, dtype=np.int64)])
    return np.concatenate([polygons, split]), np.concatenate([small, blender_faces[large]])


def count_non_triangles(mesh):
    """Number of faces of ``mesh`` with more than three corners (quads and n-gons)."""
    return int(np.count_nonzero(read_face_sizes(mesh) != 3))


def faces_hash(mesh):
    """Short fingerprint of which vertices each face of ``mesh`` joins, in order.

    Notices cage topology edits after binding without triangulating: it hashes the faces'
    corner counts and corner vertex indices, which Blender stores as they are.
    """
    return hashlib.sha1(read_face_sizes(mesh).tobytes() + read_corner_vertices(mesh).tobytes()).hexdigest()[:16]


@dataclass
class CageGeometry:
    """The evaluated cage as the core needs it, in the cage object's local space."""

    positions: np.ndarray  # (n, 3) float32
    triangles: np.ndarray  # (m, 3) int64
    triangle_faces: np.ndarray  # (m,) int64: the mesh face each triangle comes from
    non_triangles: int  # quads and n-gons that were triangulated
    faces_hash: str  # ``faces_hash`` of the cage's faces
    polygons: np.ndarray  # (p, 4) int64: ``read_polygons``, for the kinds that read quads
    polygon_faces: np.ndarray  # (p,) int64: the mesh face each polygon comes from


@contextlib.contextmanager
def evaluated_mesh(obj, depsgraph):
    """``obj``'s mesh with its modifiers, shape keys and edit-mode changes applied.

    Valid inside the ``with`` block only. ``to_mesh`` (rather than ``evaluated.data``)
    also gives real vertex arrays while the object is in edit mode.
    """
    evaluated = obj.evaluated_get(depsgraph)
    try:
        yield evaluated.to_mesh()
    finally:
        evaluated.to_mesh_clear()


def read_evaluated_cage(cage, depsgraph):
    """Everything binding needs of the evaluated ``cage`` (see ``evaluated_mesh``)."""
    with evaluated_mesh(cage, depsgraph) as mesh:
        positions = read_positions(mesh)
        return CageGeometry(positions, *read_triangles(mesh, positions),
                            count_non_triangles(mesh), faces_hash(mesh), *read_polygons(mesh))


def zero_scale_axes(matrix):
    """The local axes ('X', 'Y', 'Z') an object matrix (4x4) scales to (nearly) nothing,
    which flattens the object: a list, empty for a usable matrix (the core's
    ``bind_steps.zero_scale_axes`` at float32's tolerance)."""
    return bind_steps.zero_scale_axes(matrix, core.base.tolerances.FLOAT32)


def invertible(matrix):
    """Whether Blender inverts the object matrix (4x4) as the deformer does (Invert
    Matrix: a float32 determinant that is not zero)."""
    return bool(np.linalg.det(np.array(matrix, dtype=np.float32)) != 0.0)
