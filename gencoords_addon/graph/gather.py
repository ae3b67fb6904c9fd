"""Sparse storage's deformer: a Geometry Nodes group gathering K weighted cage
displacements per mesh vertex, whose size does not depend on K or on the cage.

Sparse storage keeps, per mesh vertex i, its K largest coordinates as pairs
(cage vertex ``j_ik``, weight ``w_ik``), renormalised to sum 1 (translations stay exact),
in 2K point attributes: K INT attributes (indices) and K FLOAT attributes (weights),
written by :func:`write_pairs`. The group outputs

    P_i + strength * mask_i * sum_k w_ik (C_{j_ik} - R_{j_ik})

with one gather per slot (Sample Index of the cage's displacement ``C - R`` at the stored
index) inside a Repeat Zone of K iterations that reads slot k's attributes by name: the
group has the same 36 nodes for any K and any cage, so building it costs
milliseconds (``scripts/benchmarks/bench_sparse_routes.py`` measured it against a lane
group instanced K times, plain per-slot nodes and the Armature modifier: the three
Geometry Nodes routes play back within 10 % of each other, about 0.8x Mesh Deform p5's
CPU time at K = 16 on the 43k-vertex character; the Armature modifier 1.4x, and never
bitwise at rest).

Two-level layout (harmonic coordinates, which are interpolations of grid-node values):
the N grid nodes the mesh's vertices are interpolated from carry their own pairs over the
cage (K' of them, three to a vector attribute, stacked in columns as long as the mesh:
``write_node_pairs``; three to a vector cut the node stage's time by a fifth, where the
mesh vertices' own pairs are faster one to an attribute); the group makes a
point cloud of the N nodes, stores each one's displacement ``sum_j w'_aj (C - R)`` on it,
then each mesh vertex gathers its 4 nodes with its interpolation weights (4 slots,
whatever the cage; indices into the cloud: ``gencoords.harmonic.interpolation``).

At rest ``C == R`` bitwise (the rest cage is read back through the group's own Object
Info node), every gathered displacement is exactly 0 and the mesh is unchanged bitwise.
The guard, strength, mask and attribute stripping are the deformer's own
(``deformer.py``).
"""

import bpy
import numpy as np

from ...core.tools import sparse
from ..bind_layout import (SLOT_MARK, index_attribute_names, name_template, node_column_count,
                           node_displacement_name, sparse_attribute_names, weight_attribute_names)
from ..blender_io import mesh_arrays
from ..blender_io.compat import compare_operands
from . import deformer
from .builder import Builder
from .helpers import GEOMETRY

SUM, SLOT = "Sum", "Slot"  # the Repeat Zone's state


def write_pairs(mesh, key, indices, weights, level="vertex"):
    """Store sparse pairs on ``mesh``: ``indices`` ((rows, K) int, rows <= its vertex
    count) as INT and ``weights`` ((rows, K) float) as FLOAT point attributes (zeros
    beyond ``rows``)."""
    count = np.shape(indices)[1]
    mesh_arrays.write_columns(mesh, index_attribute_names(key, count, level), indices, 'INT')
    mesh_arrays.write_columns(mesh, weight_attribute_names(key, count, level), weights, 'FLOAT')


def write_node_pairs(mesh, key, indices, weights):
    """Store the N grid nodes' pairs ((N, K') each), three to a vector point attribute
    (indices as floats), stacked in columns as long as the mesh
    (``core.tools.sparse.stacked_columns``, over the triples)."""
    rows = len(mesh.vertices)
    for values, names in ((indices, index_attribute_names), (weights, weight_attribute_names)):
        triples = np.zeros((len(values), -(-values.shape[1] // 3) * 3), dtype=np.float32)
        triples[:, :values.shape[1]] = values  # indices below 2**24: exact as float32
        columns, _ = sparse.stacked_columns(triples.reshape(len(values), -1, 3), rows)
        mesh_arrays.write_triples(mesh, names(key, columns.shape[1], "node"), columns.reshape(rows, -1))


def read_pairs(mesh, key, slot_count, level="vertex"):
    """The pairs :func:`write_pairs` stored ((k, K) int32 and float32), or None when an
    attribute is missing."""
    indices = mesh_arrays.read_columns(mesh, index_attribute_names(key, slot_count, level), 'INT')
    weights = mesh_arrays.read_columns(mesh, weight_attribute_names(key, slot_count, level), 'FLOAT')
    return None if indices is None or weights is None else (indices, weights)


def read_coordinates(mesh, key, cage_vertex_count, slot_count, node_count=0, node_slot_count=0):
    """The coordinates a sparse binding's stored data stands for ((k, n) float64), or
    None when an attribute is missing."""
    pairs = read_pairs(mesh, key, slot_count)
    if pairs is None:
        return None
    nodes = None
    if node_count:
        count, triples = node_column_count(len(mesh.vertices), node_count, node_slot_count), -(-node_slot_count // 3)
        nodes = []
        for names in (index_attribute_names, weight_attribute_names):
            columns = mesh_arrays.read_triples(mesh, names(key, count, "node"), 3 * count)
            if columns is None:
                return None
            stacked = sparse.unstacked(columns.reshape(len(columns), count, 3), node_count, triples)
            nodes.append(stacked.reshape(node_count, -1)[:, :node_slot_count])
        nodes[0] = nodes[0].astype(np.int64)
    return sparse.layout_coordinates(*pairs, cage_vertex_count, nodes)


def _slot_attribute(build, number_text, template, data_type):
    """The field of the attribute ``template`` names for the slot ``number_text``."""
    name = build.add('FunctionNodeReplaceString', "accumulate")
    name.inputs["String"].default_value = template
    name.inputs["Find"].default_value = SLOT_MARK
    build.link(number_text, name.inputs["Replace"])
    read = build.add('GeometryNodeInputNamedAttribute', "accumulate", data_type=data_type)
    build.link(name.outputs[0], read.inputs["Name"])
    return read.outputs["Attribute"]


def _repeat_zone(build, count):
    """A Repeat Zone of ``count`` iterations carrying the sum and the slot number."""
    zone_in = build.add('GeometryNodeRepeatInput', "accumulate")
    zone_out = build.add('GeometryNodeRepeatOutput', "accumulate")
    zone_in.pair_with_output(zone_out)
    zone_out.repeat_items.clear()
    zone_out.repeat_items.new('VECTOR', SUM)
    zone_out.repeat_items.new('INT', SLOT)
    zone_in.inputs["Iterations"].default_value = count
    return zone_in, zone_out


def _close_zone(build, zone_in, zone_out, gathered, weight, total=None):
    """Sum (or ``total``) += weight * gathered, the next slot; the zone's final sum."""
    total = zone_in.outputs[SUM] if total is None else total
    build.link(build.math("accumulate", 'MULTIPLY_ADD', gathered, weight, total), zone_out.inputs[SUM])
    build.link(build.math("accumulate", 'ADD', zone_in.outputs[SLOT], 1.0, vector=False),
               zone_out.inputs[SLOT])
    return zone_out.outputs[SUM]


def _text(build, number):
    node = build.add('FunctionNodeValueToString', "accumulate")
    build.link(number, node.inputs["Value"])
    return node.outputs[0]


def weighted_gather(build, source, value, key, slot_count, level="vertex"):
    """The field ``sum_k Weight_k * value(source, at Index_k)`` over the K slots of
    ``level`` (attributes read on the geometry the field is evaluated on): a Repeat Zone
    of K iterations, each reading its slot's attributes by name, so the group's size does
    not depend on K."""
    zone_in, zone_out = _repeat_zone(build, slot_count)
    number = _text(build, zone_in.outputs[SLOT])
    index = _slot_attribute(build, number, name_template(key, level, "index"), 'INT')
    weight = _slot_attribute(build, number, name_template(key, level, "weight"), 'FLOAT')
    gathered = build.sample_index("accumulate", source, value, index)
    return _close_zone(build, zone_in, zone_out, gathered, weight)


def _close_triple(build, zone_in, zone_out, source, value, indices, weights):
    """Sum += three weighted gathers (``indices`` and ``weights``: vector fields, three
    slots each), the next slot; the zone's final sum."""
    parts = []
    for packed in (indices, weights):
        separate = build.add('ShaderNodeSeparateXYZ', "accumulate")
        build.link(packed, separate.inputs[0])
        parts.append(separate.outputs)
    total = zone_in.outputs[SUM]
    for axis in range(2):
        gathered = build.sample_index("accumulate", source, value, parts[0][axis])
        total = build.math("accumulate", 'MULTIPLY_ADD', gathered, parts[1][axis], total)
    gathered = build.sample_index("accumulate", source, value, parts[0][2])
    return _close_zone(build, zone_in, zone_out, gathered, parts[1][2], total)


def _node_displacements(build, mesh, cage, displacement, key, node_count, column_count, blocks):
    """A point cloud of the N grid nodes with each one's displacement stored (two-level
    layout), and that attribute's field.

    The nodes' pairs are stacked (``core.tools.sparse.stacked_columns``): row
    ``s * N + a`` of each column holds triples of node a. So each mesh row p first sums
    its columns' weighted gathers (read where they are stored: no lookup of the pairs),
    stored on the mesh; node a then adds up its ``blocks`` rows ``s * N + a``."""
    zone_in, zone_out = _repeat_zone(build, column_count)
    number = _text(build, zone_in.outputs[SLOT])
    index, weight = (_slot_attribute(build, number, name_template(key, "node", what), 'FLOAT_VECTOR')
                     for what in ("index", "weight"))
    rows = build.store("lane_store", mesh, node_displacement_name(key),
                       _close_triple(build, zone_in, zone_out, cage, displacement, index, weight))
    # Only the rows that hold pairs: the others would add zeros.
    used = build.add('FunctionNodeCompare', "lane_store", data_type='INT', operation='LESS_THAN')
    operands = compare_operands(used)
    build.link(build.add('GeometryNodeInputIndex', "lane_store").outputs[0], operands[0])
    operands[1].default_value = node_count * blocks
    build.link(used.outputs[0], rows.node.inputs["Selection"])
    zone_in, zone_out = _repeat_zone(build, blocks)
    node_index = build.add('GeometryNodeInputIndex', "lane_gather").outputs[0]
    row = build.math("lane_gather", 'MULTIPLY_ADD', zone_in.outputs[SLOT], float(node_count), node_index,
                     vector=False)
    gathered = build.sample_index("lane_gather", rows, build.named_attribute("lane_gather", node_displacement_name(key)),
                                  row)
    total = _close_zone(build, zone_in, zone_out, gathered, (1.0, 1.0, 1.0))
    cloud = build.add('GeometryNodePoints', "lane_index")
    cloud.inputs["Count"].default_value = node_count
    stored = build.store("lane_store", cloud.outputs[0], node_displacement_name(key), total)
    return stored, build.named_attribute("lane_gather", node_displacement_name(key))


def build_sparse_group(name, key, rest_cage, mesh_vertex_count, slot_count,
                       node_count=0, node_slot_count=0):
    """A new node group deforming a mesh of ``mesh_vertex_count`` vertices from sparse
    bind data (attribute names: ``index_attribute_names``, ``weight_attribute_names``).

    Parameters
    ----------
    name : str
        Of the node group.
    key : str
        The binding's key: names its attributes.
    rest_cage : (n, 3) float32
        The cage at bind time in the mesh's local space, exactly as the group's Object
        Info node gives it.
    mesh_vertex_count : int
        k (another count passes the mesh through).
    slot_count : int
        K: the pairs per mesh vertex (4 in the two-level layout: its interpolating nodes).
    node_count : int
        Two-level layout: N <= k, the grid nodes the mesh's cells touch (the mesh
        vertices' indices are nodes); 0 for the direct layout (they are cage vertices).
    node_slot_count : int
        Two-level layout: K', the pairs per grid node (``write_node_pairs``).
    """
    rest_cage = np.asarray(rest_cage, dtype=np.float32)
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.description = ("GenCoords cage deformation (sparse storage): moves the mesh with "
                         "its cage (bind data in the mesh's point attributes)")
    deformer._deformer_interface(group.interface)
    build = Builder(group, deformer.DEFORMER_COLUMNS)
    group_input = build.add('NodeGroupInput', "input")
    mesh = group_input.outputs[GEOMETRY]
    cage, displacement = deformer._cage_displacement(build, group_input, rest_cage)
    source, value = cage, displacement
    if node_count:
        node_columns = node_column_count(mesh_vertex_count, node_count, node_slot_count)
        blocks = min(mesh_vertex_count // node_count, -(-node_slot_count // 3))  # rows per node
        source, value = _node_displacements(build, mesh, cage, displacement, key, node_count,
                                            node_columns, blocks)
    offset = weighted_gather(build, source, value, key, slot_count)
    moved = deformer._moved_mesh(build, group_input, offset)
    usable = deformer._usable(build, mesh, cage, (cage, displacement), len(rest_cage),
                              mesh_vertex_count)
    switch = build.add('GeometryNodeSwitch', "guard_switch", input_type='GEOMETRY')
    build.link(usable, switch.inputs["Switch"])
    build.link(mesh, switch.inputs["False"])
    build.link(moved, switch.inputs["True"])
    output = deformer._strip_attributes(build, switch.outputs[0], key, sparse_attribute_names(
        key, slot_count, mesh_vertex_count, node_count, node_slot_count))
    build.link(output, build.add('NodeGroupOutput', "output").inputs[GEOMETRY])
    return group


__all__ = ["build_sparse_group", "weighted_gather", "write_pairs", "write_node_pairs", "read_pairs",
           "read_coordinates"]
