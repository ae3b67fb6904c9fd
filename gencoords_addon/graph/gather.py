"""Weighted gathers in a Geometry Nodes group whose size does not depend on how many pairs
it gathers: ``sum_k Weight_k * value(source, at Index_k)`` in a Repeat Zone of K
iterations that reads slot k's attributes by name (sparse storage, ``storage.sparse``),
and the grid nodes' displacements of the two-level layout (``storage.two_level``), from
pairs stacked three to a vector. The attributes are read, never written, here.
"""

from ..bind_layout import SLOT_MARK, name_template, node_displacement_name
from ..blender_io.compat import compare_operands

SUM, SLOT = "Sum", "Slot"  # the Repeat Zone's state


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


def node_displacements(build, mesh, cage, displacement, key, node_count, column_count, blocks):
    """A point cloud of the N grid nodes with each one's displacement stored (two-level
    layout), and that attribute's field.

    The nodes' pairs are stacked (``core.storage.sparse.stacked_columns``): row
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


__all__ = ["weighted_gather", "node_displacements"]
