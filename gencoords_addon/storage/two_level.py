"""Two-level sparse storage (harmonic coordinates, which are interpolations of grid-node
values): each mesh vertex its grid nodes, each grid node its pairs over the cage.

Mesh vertex i keeps 8 pairs (grid node ``a_ik``, interpolation weight ``w_ik``) as sparse
storage keeps its pairs (``storage.sparse``: K = 8 INT and FLOAT attributes, whatever the
cage; node indices into the group's cloud: ``gencoords.harmonic.interpolation``). The N
grid nodes the mesh's cells touch carry their own K' pairs (cage vertex ``j_al``, weight
``w'_al``), three to a vector attribute (indices as floats), stacked in columns as long as
the mesh (``core.storage.sparse.stacked_columns``: row ``s * N + a`` of each column holds
triples of node a): three to a vector cut the node stage's time by a fifth, where the mesh
vertices' own pairs are faster one to an attribute. The group (``graph.gather``) sums each
mesh row's weighted gathers of the cage's displacement ``C - R``, makes a point cloud of
the N nodes, stores on node a the sum of its rows, ``sum_l w'_al (C - R)_{j_al}``, then
gathers each mesh vertex's 8 nodes with its interpolation weights.
"""

import numpy as np

from ...core.storage import sparse as sparse_codec
from ..bind_layout import index_attribute_names, node_column_count, weight_attribute_names
from ..blender_io import mesh_arrays
from ..graph import gather
from . import sparse


def nbytes(data):
    """Bytes of the attributes: the vertices' pairs (``storage.sparse``), and the nodes'
    index and weight columns, a float32 vector per mesh vertex each."""
    return sparse.nbytes(data) + 2 * 12 * data.mesh_vertex_count * _column_count(data)


def _column_count(data):
    return node_column_count(data.mesh_vertex_count, data.node_count, data.node_slot_count)


def write_node_pairs(mesh, key, indices, weights):
    """Store the N grid nodes' pairs ((N, K') each), three to a vector point attribute
    (indices as floats), stacked in columns as long as the mesh
    (``core.storage.sparse.stacked_columns``, over the triples)."""
    rows = len(mesh.vertices)
    for values, names in ((indices, index_attribute_names), (weights, weight_attribute_names)):
        triples = np.zeros((len(values), -(-values.shape[1] // 3) * 3), dtype=np.float32)
        triples[:, :values.shape[1]] = values  # indices below 2**24: exact as float32
        columns, _ = sparse_codec.stacked_columns(triples.reshape(len(values), -1, 3), rows)
        mesh_arrays.write_triples(mesh, names(key, columns.shape[1], "node"), columns.reshape(rows, -1))


def write_steps(mesh, data, result):
    """Write each vertex's pairs and the grid nodes' (``result.nodes``: (N, K') indices
    and weights): a generator taking one step."""
    yield from sparse.write_steps(mesh, data, result)
    write_node_pairs(mesh, data.key, *result.nodes)


def read_node_pairs(mesh, data):
    """The grid nodes' pairs :func:`write_node_pairs` stored ((N, K') int64 and float32),
    or None when an attribute is missing."""
    count, triples = _column_count(data), -(-data.node_slot_count // 3)
    nodes = []
    for names in (index_attribute_names, weight_attribute_names):
        columns = mesh_arrays.read_triples(mesh, names(data.key, count, "node"), 3 * count)
        if columns is None:
            return None
        stacked = sparse_codec.unstacked(columns.reshape(len(columns), count, 3), data.node_count, triples)
        nodes.append(stacked.reshape(data.node_count, -1)[:, :data.node_slot_count])
    return nodes[0].astype(np.int64), nodes[1]


def read_coordinates(mesh, data):
    """The (k, n) float32 coordinates the stored pairs stand for, or None."""
    nodes = read_node_pairs(mesh, data)
    return None if nodes is None else sparse.read_coordinates(mesh, data, nodes)


def read_column(mesh, data, cage_vertex):
    """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
    coordinates = read_coordinates(mesh, data)
    return None if coordinates is None else coordinates[:, cage_vertex]


def group_steps(name, data, result):
    """The binding's node group, built in one step: sparse storage's (``storage.sparse``)
    gathering from the grid nodes' displacements."""
    def node_source(build, mesh, moving):
        k, node_count = data.mesh_vertex_count, data.node_count
        blocks = min(k // node_count, -(-data.node_slot_count // 3))  # rows per node
        return gather.node_displacements(build, mesh, *moving, data.key, node_count, _column_count(data), blocks)
    return sparse.group_steps(name, data, result, node_source)
