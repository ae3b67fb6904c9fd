"""The node-tree builder the GenCoords groups are made with: nodes placed in named columns
(so a group reads left to right, one column per stage) and linked, with the few node
patterns the groups repeat (vector maths, stored and read attributes, Sample Index, ...)."""

import bpy

from ..blender_io.compat import compare_operands, new_index_switch_items

COLUMN_WIDTH, ROW_HEIGHT = 220.0, 160.0
# Constants an Index Switch node holds: an item added costs more the more it holds (a
# 1,000-vertex cage's rest positions in one node: 2.0 s of Bind, 2,000: 13.7 s).
SWITCH_ITEMS = 64


class Builder:
    """Adds nodes in columns (so the group reads left to right) and links them."""

    def __init__(self, group, columns):
        self.group = group
        self.columns = columns  # stage names, left to right
        self.rows = {}

    def add(self, node_type, column, **settings):
        """A new node in the column of the stage ``column``, below the ones already there."""
        node = self.group.nodes.new(node_type)
        row = self.rows.get(column, 0)
        self.rows[column] = row + 1
        node.location = (COLUMN_WIDTH * self.columns.index(column), -ROW_HEIGHT * row)
        for name, value in settings.items():
            setattr(node, name, value)
        return node

    def link(self, output, node_input):
        self.group.links.new(output, node_input, verify_limits=False)

    def math(self, column, operation, a, b=None, c=None, vector=True):
        node = self.add('ShaderNodeVectorMath' if vector else 'ShaderNodeMath', column,
                        operation=operation)
        for socket, value in zip(node.inputs, (a, b, c)):
            if value is None:
                continue
            if isinstance(value, bpy.types.NodeSocket):
                self.link(value, socket)
            else:
                socket.default_value = value
        if vector and operation in ('LENGTH', 'DOT_PRODUCT', 'DISTANCE'):
            return node.outputs["Value"]  # its first output, a vector, stays unused
        return node.outputs[0]

    def store(self, column, geometry, name, value):
        """``geometry`` with the vector point attribute ``name`` set to ``value``."""
        node = self.add('GeometryNodeStoreNamedAttribute', column, data_type='FLOAT_VECTOR',
                        domain='POINT')
        node.inputs["Name"].default_value = name
        self.link(geometry, node.inputs["Geometry"])
        self.link(value, node.inputs["Value"])
        return node.outputs[0]

    def scale(self, column, vector, factor):
        node = self.add('ShaderNodeVectorMath', column, operation='SCALE')
        self.link(vector, node.inputs[0])
        self.link(factor, node.inputs["Scale"])
        return node.outputs[0]

    def named_attribute(self, column, name, data_type='FLOAT_VECTOR'):
        node = self.add('GeometryNodeInputNamedAttribute', column, data_type=data_type)
        node.inputs["Name"].default_value = name
        return node.outputs["Attribute"]

    def sample_index(self, column, geometry, value, index):
        node = self.add('GeometryNodeSampleIndex', column, data_type='FLOAT_VECTOR',
                        domain='POINT')
        self.link(geometry, node.inputs["Geometry"])
        self.link(value, node.inputs["Value"])
        if isinstance(index, bpy.types.NodeSocket):
            self.link(index, node.inputs["Index"])
        else:
            node.inputs["Index"].default_value = index
        return node.outputs[0]

    def index_switch(self, column, index, vectors, **settings):
        """A field that is ``vectors[index]``: per-cage constants kept in the group, at
        most SWITCH_ITEMS to an Index Switch node; of more, the node returned (``settings``
        its) chooses by ``index // SWITCH_ITEMS`` among those holding them."""
        if len(vectors) <= SWITCH_ITEMS:
            return self._switch(column, index, vectors, **settings)
        # Exact in floats: indices below 2^24, over a power of two.
        within = self.math(column, 'MODULO', index, float(SWITCH_ITEMS), vector=False)
        chunk = self.math(column, 'FLOOR', self.math(column, 'DIVIDE', index, float(SWITCH_ITEMS), vector=False),
                          vector=False)
        parts = [self._switch(column, within, vectors[start:start + SWITCH_ITEMS])
                 for start in range(0, len(vectors), SWITCH_ITEMS)]
        return self.index_switch(column, chunk, parts, **settings)

    def _switch(self, column, index, values, **settings):
        """One Index Switch node over ``values`` (constants or sockets)."""
        node = self.add('GeometryNodeIndexSwitch', column, data_type='VECTOR', **settings)
        new_index_switch_items(node, len(values))
        self.link(index, node.inputs["Index"])
        for socket, value in zip(node.inputs[1:], values):
            if isinstance(value, bpy.types.NodeSocket):
                self.link(value, socket)
            else:
                socket.default_value = value
        return node.outputs[0]

    def statistic_sum(self, column, geometry, value):
        node = self.add('GeometryNodeAttributeStatistic', column, data_type='FLOAT_VECTOR',
                        domain='POINT')
        self.link(geometry, node.inputs["Geometry"])
        self.link(value, node.inputs["Attribute"])
        return node.outputs["Sum"]

    def compare(self, column, data_type, a, b):
        """Whether ``a == b`` exactly (single values or fields)."""
        node = self.add('FunctionNodeCompare', column, data_type=data_type, operation='EQUAL')
        if data_type == 'FLOAT':
            node.inputs["Epsilon"].default_value = 0.0
        for socket, value in zip(compare_operands(node), (a, b)):
            if isinstance(value, bpy.types.NodeSocket):
                self.link(value, socket)
            else:
                socket.default_value = value
        return node.outputs[0]

    def both(self, column, a, b):
        node = self.add('FunctionNodeBooleanMath', column, operation='AND')
        self.link(a, node.inputs[0])
        self.link(b, node.inputs[1])
        return node.outputs[0]

    def switch(self, column, input_type, condition, if_false, if_true):
        """``if_true`` where ``condition``, else ``if_false`` (sockets or constants)."""
        node = self.add('GeometryNodeSwitch', column, input_type=input_type)
        self.link(condition, node.inputs["Switch"])
        for socket, value in ((node.inputs["False"], if_false), (node.inputs["True"], if_true)):
            if isinstance(value, bpy.types.NodeSocket):
                self.link(value, socket)
            else:
                socket.default_value = value
        return node.outputs[0]


def new_group(name, inputs, outputs, description, columns):
    """A new node group with sockets ``inputs`` and ``outputs`` ((name, socket type)
    pairs), its builder, and its Group Input and Group Output nodes (first and last
    columns)."""
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.description = description
    for sockets, in_out in ((inputs, 'INPUT'), (outputs, 'OUTPUT')):
        for socket_name, socket_type in sockets:
            group.interface.new_socket(socket_name, in_out=in_out, socket_type=socket_type)
    build = Builder(group, columns)
    return (group, build, build.add('NodeGroupInput', columns[0]),
            build.add('NodeGroupOutput', columns[-1]))
