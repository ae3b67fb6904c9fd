"""Exact storage: every coordinate of every mesh vertex.

Mesh vertex i keeps its s coordinates ``u_i`` (s = n, or n + m for Green coordinates'
``[phi, psi]``) as float32, three to a vector point attribute (``BindData.slot_names``:
``.gencoords_<key>_<t>`` holds slots 3t, 3t + 1, 3t + 2). The group (``graph.deformer``)
gathers the cage's displacements ``D = C - R`` once per evaluation onto a lane cloud, a
point per triple t holding ``(D_3t.c, D_3t+1.c, D_3t+2.c)`` for each axis c, and shared
chunk groups (``graph.chunks``) add ``u_i,3t+l * lane`` over the triples: the vertex moves
by ``sum_j u_ij D_j``, exactly as the coordinates say (up to float32).
"""

from ...core.storage import Storage
from ..bind import attributes
from ..blender_io import mesh_arrays
from ..graph import deformer
from ..graph.helpers import LANE_NAMES

STORAGE = Storage.EXACT


def nbytes(data):
    """Bytes of the attributes: a float32 vector per slot triple and mesh vertex."""
    return 12 * data.mesh_vertex_count * len(data.slot_names)


def write_steps(mesh, data, result):
    """Write the slots (``result.slots``, (k, s) float32): a generator yielding the fraction
    written (``bind.attributes.write_steps``)."""
    return attributes.write_steps(mesh, [(data.slot_names, result.slots)])


def read_slots(mesh, data):
    """The stored slots ((k, s) float32), or None when an attribute is missing."""
    return mesh_arrays.read_triples(mesh, data.slot_names, data.slot_count)


def read_coordinates(mesh, data):
    """The (k, rows) float32 coordinates the mesh deforms with, or None."""
    return read_slots(mesh, data)


def read_column(mesh, data, cage_vertex):
    """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
    slots = read_slots(mesh, data)
    return None if slots is None else slots[:, cage_vertex]


def group_steps(name, data, result):
    """The binding's node group (``graph.deformer.group_steps``), a generator yielding the
    fraction built and returning the group."""
    def offset_steps(build, mesh, moving):
        lanes = lane_cloud(build, *moving, data.slot_count)
        return deformer.chunk_offset_steps(build, STORAGE, lanes, data.slot_names, range(len(data.slot_names)))
    return deformer.group_steps(name, data.key, result.rest_cage, data.mesh_vertex_count, offset_steps,
                                data.attribute_names, result.triangles)


def lane_cloud(build, cage, displacement, slot_count):
    """The lane cloud: a point per triple t of slots holding its three lanes
    (D_3t.c, D_3t+1.c, D_3t+2.c) for axes c (``LANE_NAMES``), read by the chunks."""
    triples = -(-slot_count // 3)
    cloud = build.add('GeometryNodePoints', "lane_index")
    cloud.inputs["Count"].default_value = triples
    index = build.add('GeometryNodeInputIndex', "lane_index").outputs[0]
    parts = []
    for offset in range(3):
        cage_vertex = build.math("lane_index", 'MULTIPLY_ADD', index, 3.0, float(offset),
                                 vector=False)
        sampled = build.sample_index("lane_gather", cage, displacement, cage_vertex)
        separate = build.add('ShaderNodeSeparateXYZ', "lane_split")
        build.link(sampled, separate.inputs[0])
        parts.append(separate.outputs)
    geometry = cloud.outputs[0]
    for axis, name in enumerate(LANE_NAMES):
        combine = build.add('ShaderNodeCombineXYZ', "lane_join")
        for offset in range(3):
            build.link(parts[offset][axis], combine.inputs[offset])
        geometry = build.store("lane_store", geometry, name, combine.outputs[0])
    return {"Cloud": geometry}
