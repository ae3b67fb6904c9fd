"""Shared helper groups that add many slot triples' share of the displacement in one node,
so that a binding's node group holds a node per ``CHUNK_SIZES[0]`` triples of slots
instead of two per triple (building a node tree from Python costs time quadratic in its
size: every link and every value set updates the whole tree).

A chunk of ``size`` triples takes, per triple k, the name of its slot attribute
(``Slots k``) and where its lanes come from: for exact storage its index on the lane
cloud (``Triple k``), for compact storage the name of its basis attribute (``Basis k``).
The names and indices are values set on the chunk's node, not links, so the binding's
group gets a few links per chunk whatever the chunk's size. The groups are made once per
file and shared by every binding; the number in their names is their layout.
"""

import bpy

from ...core.storage import Storage
from .builder import new_group
from .helpers import DISPLACEMENT, HELPER_COLUMNS, LANES, SUMS, accumulate_group, cloud_lanes_group

# A binding's chunks, largest first: 64 triples (192 slots) a node, the rest in sixteens,
# fours and ones (no slot computed for nothing). A chunk of 64 holds four of 16 added up
# pairwise: one chain through 64 would make Blender gather the attributes it depends on
# at every node (see ``deformer.CHAIN``).
CHUNK_SIZES = (64, 16, 4, 1)
NESTED = {64: 16}
CHUNK_PREFIX = ".GenCoords chunk "
COMPACT_LANES_GROUP = ".GenCoords compact lanes 1"
# What each storage's chunk reads its lanes from, and its per-triple inputs.
SOURCES = {Storage.EXACT: ("Cloud",), Storage.COMPACT: ("Mesh", "Cage")}
ENTRIES = {Storage.EXACT: ("Slots", "Triple"), Storage.COMPACT: ("Slots", "Basis")}


def chunk_name(storage, size):
    """The shared group's name in the file (``.GenCoords chunk exact 16 1``: files keep it)."""
    return f"{CHUNK_PREFIX}{storage.value.lower()} {size} 1"


def chunk_plan(triples):
    """The chunk sizes covering ``triples`` triples, largest first."""
    plan = []
    for size in CHUNK_SIZES:
        plan += [size] * ((triples - sum(plan)) // size)
    return plan


def chunk_group(storage, size):
    """Helper group: ``Sum c += sum over its triples k of slots(Slots k) * Lane c of k``."""
    name = chunk_name(storage, size)
    group = _existing(name)
    if group is not None:
        return group
    entry_types = {"Slots": 'NodeSocketString', "Triple": 'NodeSocketInt', "Basis": 'NodeSocketString'}
    inputs = ([(source, 'NodeSocketGeometry') for source in SOURCES[storage]]
              + [(total, 'NodeSocketVector') for total in SUMS]
              + [(f"{entry} {k}", entry_types[entry]) for k in range(size) for entry in ENTRIES[storage]])
    group, build, group_input, group_output = new_group(
        name, inputs, [(total, 'NodeSocketVector') for total in SUMS],
        f"GenCoords: adds {size} triples of slots' share of the displacement", HELPER_COLUMNS)
    if size in NESTED:
        _nested_chunks(build, group_input, group_output, storage, size, NESTED[size])
        return group
    lanes_helper = cloud_lanes_group() if storage is Storage.EXACT else compact_lanes_group()
    accumulate = accumulate_group()
    sums = [group_input.outputs[total] for total in SUMS]
    for k in range(size):
        lanes = build.add('GeometryNodeGroup', "read", node_tree=lanes_helper)
        for source, socket in zip(SOURCES[storage], lanes.inputs):
            build.link(group_input.outputs[source], socket)
        build.link(group_input.outputs[f"{ENTRIES[storage][1]} {k}"], lanes.inputs[len(SOURCES[storage])])
        node = build.add('GeometryNodeGroup', "combine", node_tree=accumulate)
        build.link(group_input.outputs[f"Slots {k}"], node.inputs["Name"])
        for lane in LANES:
            build.link(lanes.outputs[lane], node.inputs[lane])
        for total, value in zip(SUMS, sums):
            build.link(value, node.inputs[total])
        sums = [node.outputs[total] for total in SUMS]
    for total, value in zip(SUMS, sums):
        build.link(value, group_output.inputs[total])
    return group


def _nested_chunks(build, group_input, group_output, storage, size, inner_size):
    """A chunk of ``size`` triples made of chunks of ``inner_size``, their sums added up
    pairwise (the first one's starting from the chunk's own ``Sum`` inputs)."""
    inner = chunk_group(storage, inner_size)
    partial = []
    for first in range(0, size, inner_size):
        node = build.add('GeometryNodeGroup', "read", node_tree=inner)
        for source in SOURCES[storage]:
            build.link(group_input.outputs[source], node.inputs[source])
        for k in range(inner_size):
            for entry in ENTRIES[storage]:
                build.link(group_input.outputs[f"{entry} {first + k}"], node.inputs[f"{entry} {k}"])
        if not partial:
            for total in SUMS:
                build.link(group_input.outputs[total], node.inputs[total])
        partial.append([node.outputs[total] for total in SUMS])
    while len(partial) > 1:
        partial = [[build.math("combine", 'ADD', a, b) for a, b in zip(left, right)]
                   for left, right in zip(partial[::2], partial[1::2])] + partial[len(partial) // 2 * 2:]
    for total, value in zip(SUMS, partial[0]):
        build.link(value, group_output.inputs[total])


def compact_lanes_group():
    """Helper group: the three lanes of one triple of compact slots, ``sum_j basis_j *
    D_j.c`` over the cage's points j for axes c (``Basis``: the attribute holding the
    triple's three basis columns on the mesh's first points; ``DISPLACEMENT`` on the cage)."""
    group = _existing(COMPACT_LANES_GROUP)
    if group is not None:
        return group
    group, build, group_input, group_output = new_group(
        COMPACT_LANES_GROUP, [("Mesh", 'NodeSocketGeometry'), ("Cage", 'NodeSocketGeometry'),
                              ("Basis", 'NodeSocketString')],
        [(lane, 'NodeSocketVector') for lane in LANES], "GenCoords: one triple's compact lanes", HELPER_COLUMNS)
    read = build.add('GeometryNodeInputNamedAttribute', "read", data_type='FLOAT_VECTOR')
    build.link(group_input.outputs["Basis"], read.inputs["Name"])
    index = build.add('GeometryNodeInputIndex', "read").outputs[0]
    basis = build.sample_index("read", group_input.outputs["Mesh"], read.outputs["Attribute"], index)
    displacement = build.add('ShaderNodeSeparateXYZ', "read")
    build.link(build.named_attribute("read", DISPLACEMENT), displacement.inputs[0])
    for axis, lane in enumerate(LANES):
        total = build.statistic_sum("combine", group_input.outputs["Cage"],
                                    build.scale("combine", basis, displacement.outputs[axis]))
        build.link(total, group_output.inputs[lane])
    return group


def _existing(name):
    return bpy.data.node_groups.get(name)
