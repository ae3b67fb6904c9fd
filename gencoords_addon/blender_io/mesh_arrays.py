"""Blender mesh data as numpy arrays, and back: the one place this is written.

``foreach_get``/``foreach_set`` on flat, C-contiguous float32 buffers avoid a Python
object per vertex; the ``position`` attribute is the fastest path to vertex coordinates
(35 times faster than ``vertices``: 2 ms for a million).

This module imports only ``bpy``, ``bmesh`` and ``numpy`` (no relative imports), so the scripts and
the tests load this very file by path (``importlib.util.spec_from_file_location``): they also drive Blender without
the extension installed, and their numbers then come from the same reader as the
add-on's. The add-on reads positions, faces and its bind data's attributes here and
writes its attributes here; ``write_positions`` is for scripts and tests (Bind never
writes positions).
"""

import bmesh
import bpy
import numpy as np

POSITION = "position"
CORNER_VERTEX = ".corner_vert"  # internal attribute (leading dot), in Blender since 4.0


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


def write_shape_key(key_block, positions):
    """Set the positions of a shape key (``obj.data.shape_keys.key_blocks[...]``, or what
    ``obj.shape_key_add`` returns): (k, 3) float, in the mesh's local space."""
    key_block.data.foreach_set("co", np.ascontiguousarray(positions, dtype=np.float32).reshape(-1))


def read_loop_triangles(mesh):
    """Blender's triangulation of ``mesh``'s faces, (m, 3) int64, windings kept."""
    mesh.calc_loop_triangles()
    flat = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", flat)
    return flat.reshape(-1, 3)


def read_faces(mesh):
    """Each face's first corner and corner count, and each corner's vertex.

    Returns
    -------
    starts, sizes : (f,) int64
    corners : (c,) int64
    """
    starts = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_start", starts)
    return starts, read_face_sizes(mesh), read_corner_vertices(mesh)


def read_face_sizes(mesh):
    """Each face's corner count, (f,) int64."""
    sizes = np.empty(len(mesh.polygons), dtype=np.int64)
    mesh.polygons.foreach_get("loop_total", sizes)
    return sizes


def read_corner_vertices(mesh):
    """Each corner's vertex, (c,) int64."""
    corners = np.empty(len(mesh.loops), dtype=np.int64)
    # Blender's own storage of ``loops[i].vertex_index``: one block copy, where reading
    # through ``mesh.loops`` costs 8 times as much. A mesh without faces has no corners
    # and no such attribute.
    attribute = mesh.attributes.get(CORNER_VERTEX)
    if attribute is not None:
        attribute.data.foreach_get("value", corners)
    return corners


def read_loop_triangle_faces(mesh):
    """Blender's triangulation (``read_loop_triangles``) and each triangle's face,
    (m, 3) and (m,) int64."""
    triangles = read_loop_triangles(mesh)
    faces = np.empty(len(triangles), dtype=np.int64)
    mesh.loop_triangles.foreach_get("polygon_index", faces)
    return triangles, faces


def write_triples(mesh, names, values):
    """Store the columns of ``values`` ((rows, s) float, rows <= the mesh's vertex count)
    three at a time as new vector point attributes ``names`` (zeros beyond ``rows``)."""
    packed = np.zeros((len(mesh.vertices), 3 * len(names)), dtype=np.float32)
    packed[:len(values), :values.shape[1]] = values
    for t, name in enumerate(names):
        attribute = mesh.attributes.new(name, 'FLOAT_VECTOR', 'POINT')
        attribute.data.foreach_set("vector", np.ascontiguousarray(packed[:, 3 * t:3 * t + 3]).ravel())


def read_triples(mesh, names, slot_count):
    """The first ``slot_count`` columns stored by ``write_triples`` ((k, slot_count)
    float32), or None when one is missing."""
    result = np.empty((len(mesh.vertices), 3 * len(names)), dtype=np.float32)
    flat = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    for t, name in enumerate(names):
        attribute = mesh.attributes.get(name)
        if attribute is None or attribute.data_type != 'FLOAT_VECTOR' or attribute.domain != 'POINT':
            return None
        attribute.data.foreach_get("vector", flat)
        result[:, 3 * t:3 * t + 3] = flat.reshape(-1, 3)
    return result[:, :slot_count]


def write_point_colors(attribute, colors):
    """Set a point color attribute to ``colors`` ((k, 4) float)."""
    attribute.data.foreach_set("color", np.ascontiguousarray(colors, dtype=np.float32).reshape(-1))


def evaluated_positions(obj, depsgraph=None, out=None):
    """Positions of ``obj``'s evaluated mesh (modifiers, shape keys and the GenCoords
    deformation applied), in its local space, (k, 3) float32.

    ``evaluated.data`` rather than ``to_mesh()``: no copy, and the same read for every
    deformer a benchmark compares. Outside edit mode only (see ``mesh_io.evaluated_mesh``).
    """
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    return read_positions(obj.evaluated_get(depsgraph).data, out)



def read_edges(mesh):
    """Each edge's two vertices: (e, 2) int32."""
    edges = np.empty(2 * len(mesh.edges), dtype=np.int32)
    mesh.edges.foreach_get("vertices", edges)
    return edges.reshape(-1, 2)


def select_faces(mesh, faces):
    """Select exactly the faces where ``faces`` ((f,) bool) is True, with their edges and
    vertices (what Edit Mode shows as those faces selected)."""
    starts, sizes, corners = read_faces(mesh)
    vertices = np.zeros(len(mesh.vertices), dtype=bool)
    vertices[corners[np.repeat(np.asarray(faces, dtype=bool), sizes)]] = True
    mesh.vertices.foreach_set("select", vertices)
    mesh.edges.foreach_set("select", vertices[read_edges(mesh)].all(axis=1))
    mesh.polygons.foreach_set("select", np.asarray(faces, dtype=bool))
    mesh.update()


def read_weights(obj, names):
    """The weights of the vertex groups ``names`` of ``obj``, as Blender stores them.

    Returns
    -------
    weights : (k, len(names)) float64
    """
    columns = {obj.vertex_groups[name].index: j for j, name in enumerate(names)
               if name in obj.vertex_groups}
    weights = np.zeros((len(obj.data.vertices), len(names)))
    bm = bmesh.new()
    try:
        bm.from_mesh(obj.data)
        layer = bm.verts.layers.deform.active
        if layer is None:
            return weights
        for vert in bm.verts:
            for group, weight in vert[layer].items():
                j = columns.get(group)
                if j is not None:
                    weights[vert.index, j] = weight
    finally:
        bm.free()
    return weights


def write_weights(obj, names, weights):
    """Set the vertex groups ``names`` of ``obj`` (made as needed) to the positive
    entries of ``weights`` ((k, len(names))); Blender clamps them to [0, 1]."""
    groups = [(obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name)).index
              for name in names]
    bm = bmesh.new()
    try:
        bm.from_mesh(obj.data)
        layer = bm.verts.layers.deform.verify()
        bm.verts.ensure_lookup_table()
        rows, columns = np.nonzero(weights > 0.0)
        values = weights[rows, columns].tolist()
        group_of = [groups[j] for j in columns.tolist()]
        deform = None
        last = -1
        for i, group, value in zip(rows.tolist(), group_of, values):
            if i != last:
                deform, last = bm.verts[i][layer], i
            deform[group] = value
        bm.to_mesh(obj.data)
    finally:
        bm.free()


def write_columns(mesh, names, values, data_type):
    """Store each column of ``values`` ((rows, len(names)), rows <= the mesh's vertex
    count) as a new point attribute of ``names``: ``data_type`` 'INT' (int32) or 'FLOAT'
    (float32); zeros beyond ``rows``. Sparse storage's indices and weights."""
    dtype = np.int32 if data_type == 'INT' else np.float32
    column = np.zeros(len(mesh.vertices), dtype=dtype)
    for j, name in enumerate(names):
        column[:len(values)] = values[:, j]
        column[len(values):] = 0
        mesh.attributes.new(name, data_type, 'POINT').data.foreach_set("value", column)


def read_columns(mesh, names, data_type):
    """The point attributes ``names`` written by ``write_columns`` as a (k, len(names))
    array (int32 or float32), or None when one is missing or of another type."""
    dtype = np.int32 if data_type == 'INT' else np.float32
    result = np.empty((len(mesh.vertices), len(names)), dtype=dtype)
    column = np.empty(len(mesh.vertices), dtype=dtype)
    for j, name in enumerate(names):
        attribute = mesh.attributes.get(name)
        if attribute is None or attribute.data_type != data_type or attribute.domain != 'POINT':
            return None
        attribute.data.foreach_get("value", column)
        result[:, j] = column
    return result
