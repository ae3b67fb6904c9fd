"""Blender mesh data as numpy arrays, and back: the one place this is written.

``foreach_get``/``foreach_set`` on flat, C-contiguous float32 buffers avoid a Python
object per vertex; the ``position`` attribute is the fastest path to vertex coordinates
(35 times faster than ``vertices``: 2 ms for a million).

This module imports only ``bpy`` and ``numpy`` (no relative imports), so the scripts and
the tests load this very file by path (``importlib.util.spec_from_file_location``): they also drive Blender without
the extension installed, and their numbers then come from the same reader as the
add-on's. The add-on itself uses ``read_positions``; the writer is for scripts and tests
(Bind never writes positions).
"""

import bpy
import numpy as np

POSITION = "position"


def read_positions(mesh, out=None):
    """Vertex positions of ``mesh`` (its own local space) as a (k, 3) float32 array.

    ``out``: a float32 buffer of 3k numbers to fill (no allocation, for timings).
    """
    flat = np.empty(len(mesh.vertices) * 3, dtype=np.float32) if out is None else out
    attribute = mesh.attributes.get(POSITION)
    if attribute is not None:  # a mesh without vertices has no "position" attribute
        attribute.data.foreach_get("vector", flat)
    return flat.reshape(-1, 3)


def write_positions(mesh, positions):
    """Set the vertex positions of ``mesh`` and tag it so the depsgraph re-evaluates."""
    mesh.attributes[POSITION].data.foreach_set(
        "vector", np.ascontiguousarray(positions, dtype=np.float32).reshape(-1))
    mesh.update()


def read_loop_triangles(mesh):
    """Blender's triangulation of ``mesh``'s faces, (m, 3) int64, windings kept."""
    mesh.calc_loop_triangles()
    flat = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", flat)
    return flat.reshape(-1, 3)


def evaluated_positions(obj, depsgraph=None, out=None):
    """Positions of ``obj``'s evaluated mesh (modifiers, shape keys and the GenCoords
    deformation applied), in its local space, (k, 3) float32.

    ``evaluated.data`` rather than ``to_mesh()``: no copy, and the same read for every
    deformer a benchmark compares. Outside edit mode only (see ``mesh_io.evaluated_mesh``).
    """
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    return read_positions(obj.evaluated_get(depsgraph).data, out)

