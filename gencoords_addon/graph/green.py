"""Green coordinates' face terms in the deformer: per cage triangle, its unit normal now
scaled by its stretch factor minus its unit normal at rest (docs/MATH.md), 0 while its
corners have not moved."""

import numpy as np

from ..blender_io.compat import compare_operands
from .helpers import DISPLACEMENT, REST

CORNERS = "gencoords_corners"  # on the cloud: a triangle's corner indices


def green_displacements(build, cage, cage_vertex_count, triangles):
    """A point cloud of n + m points with ``DISPLACEMENT`` stored: the cage's vertices'
    (``C - R``), then each triangle's ``s n' - n`` (0 while its corners are at rest, so
    the mesh stays bitwise at rest); and that attribute's field. The triangles' corner
    indices ((m, 3) int, exact as float32 below 2^24) are kept in the group, stored on
    the cloud once (an Index Switch over m constants costs m^2 at each evaluation)."""
    cloud = build.add('GeometryNodePoints', "face_corners")
    cloud.inputs["Count"].default_value = cage_vertex_count + len(triangles)
    index = build.add('GeometryNodeInputIndex', "face_corners").outputs[0]
    triangle = build.math("face_corners", 'SUBTRACT', index, float(cage_vertex_count), vector=False)
    geometry = build.store("face_corners", cloud.outputs[0], CORNERS, build.index_switch(
        "face_corners", triangle, np.asarray(triangles, dtype=np.float64).tolist()))
    corners = build.add('ShaderNodeSeparateXYZ', "face_corners")
    build.link(build.named_attribute("face_corners", CORNERS), corners.inputs[0])
    position = build.add('GeometryNodeInputPosition', "face_corners").outputs[0]
    rest_field = build.named_attribute("face_corners", REST)
    now = [build.sample_index("face_vectors", cage, position, corners.outputs[c]) for c in range(3)]
    rest = [build.sample_index("face_vectors", cage, rest_field, corners.outputs[c]) for c in range(3)]
    edges_now = [build.math("face_vectors", 'SUBTRACT', now[c], now[0]) for c in (1, 2)]
    edges_rest = [build.math("face_vectors", 'SUBTRACT', rest[c], rest[0]) for c in (1, 2)]
    face = _scaled_normal_change(build, edges_rest, edges_now)
    # Exactly 0 while the triangle's corners are where they were at Bind.
    still = build.compare("face_normals", 'FLOAT', build.math("face_normals", 'ADD', build.math(
        "face_normals", 'ADD', build.math("face_normals", 'DISTANCE', now[0], rest[0]),
        build.math("face_normals", 'DISTANCE', now[1], rest[1]), vector=False),
        build.math("face_normals", 'DISTANCE', now[2], rest[2]), vector=False), 0.0)
    face = build.switch("face_store", 'VECTOR', still, face, (0.0, 0.0, 0.0))
    vertex = build.sample_index("face_store", cage, build.named_attribute("face_store", DISPLACEMENT), index)
    is_vertex = build.add('FunctionNodeCompare', "face_store", data_type='INT', operation='LESS_THAN')
    operands = compare_operands(is_vertex)
    build.link(index, operands[0])
    operands[1].default_value = cage_vertex_count
    value = build.switch("face_store", 'VECTOR', is_vertex.outputs[0], face, vertex)
    cloud = build.store("face_store", geometry, DISPLACEMENT, value)
    return cloud, build.named_attribute("face_store", DISPLACEMENT)


def _scaled_normal_change(build, edges_rest, edges_now):
    """``s n' - n`` of a triangle from its edge vectors at rest (u, v) and now (u', v'):
    ``s = ||(u', v')|| / (sqrt(2) |u x v|)``, ``||(u', v')||^2 = |u'|^2 |v|^2
    - 2 (u'.v')(u.v) + |v'|^2 |u|^2`` (docs/MATH.md)."""
    (u, v), (u_now, v_now) = edges_rest, edges_now
    column = "face_normals"

    def dot(a, b):
        return build.math(column, 'DOT_PRODUCT', a, b)

    def times(a, b):
        return build.math(column, 'MULTIPLY', a, b, vector=False)

    doubled_rest = build.math(column, 'CROSS_PRODUCT', u, v)
    squared = build.math(column, 'ADD', build.math(column, 'SUBTRACT', times(dot(u_now, u_now), dot(v, v)),
                                                   times(2.0, times(dot(u_now, v_now), dot(u, v))), vector=False),
                         times(dot(v_now, v_now), dot(u, u)), vector=False)
    root = build.math(column, 'SQRT', build.math(column, 'MAXIMUM', squared, 0.0, vector=False), vector=False)
    stretch = build.math(column, 'DIVIDE', root, times(np.sqrt(2.0), build.math(column, 'LENGTH', doubled_rest)),
                         vector=False)
    normal_now = build.math(column, 'NORMALIZE', build.math(column, 'CROSS_PRODUCT', u_now, v_now))
    return build.math(column, 'SUBTRACT', build.scale(column, normal_now, stretch),
                      build.math(column, 'NORMALIZE', doubled_rest))
