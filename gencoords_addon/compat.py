"""What differs between the Blender versions GenCoords supports (4.2 LTS to 5.2).

The one place that knows: everything else calls these functions instead of testing
``bpy.app.version`` itself.
"""

import bpy

VERSION = bpy.app.version


def set_modifier_input(modifier, name, value):
    """Set the Geometry Nodes modifier input called ``name`` (its group socket's name)."""
    socket = modifier.node_group.interface.items_tree[name]
    try:
        modifier[socket.identifier] = value
    except TypeError:
        # 5.2 keeps modifier inputs out of ID properties: they are RNA properties there.
        _modern_input(modifier, socket).value = value


def set_modifier_input_attribute(modifier, name, attribute):
    """Make the field input ``name`` read the attribute (or vertex group) ``attribute``."""
    socket = modifier.node_group.interface.items_tree[name]
    try:
        modifier[socket.identifier + "_use_attribute"] = True
        modifier[socket.identifier + "_attribute_name"] = attribute
    except TypeError:
        item = _modern_input(modifier, socket)
        item.use_attribute, item.attribute_name = True, attribute
    modifier.node_group.interface_update(bpy.context)


def get_modifier_input(modifier, name):
    """The value of the Geometry Nodes modifier input called ``name``."""
    socket = modifier.node_group.interface.items_tree[name]
    try:
        return modifier[socket.identifier]
    except (TypeError, KeyError):
        return _modern_input(modifier, socket).value


def _modern_input(modifier, socket):
    inputs = getattr(modifier, "inputs", None)
    if inputs is None:
        raise RuntimeError(f"Blender {bpy.app.version_string}: cannot set the input "
                           f"'{socket.name}' of modifier '{modifier.name}'")
    for item in inputs:
        if getattr(item, "identifier", None) == socket.identifier or item.name == socket.name:
            return item
    raise KeyError(socket.name)


def set_wildcard_removal(node, pattern):
    """Make a Remove Named Attribute node remove every attribute matching ``pattern``."""
    mode = node.inputs.get("Pattern Mode")
    if mode is not None:
        mode.default_value = 'Wildcard'
        node.inputs["Name"].default_value = pattern
        return True
    return False


def new_index_switch_items(node, count):
    """Give an Index Switch node ``count`` inputs (it is created with two)."""
    items = node.index_switch_items
    while len(items) < count:
        items.new()


def move_modifier(obj, modifier, index):
    """Move ``modifier`` to position ``index`` of the stack of ``obj``."""
    current = list(obj.modifiers).index(modifier)
    if current != index:
        obj.modifiers.move(current, index)
