"""What differs between the Blender versions GenCoords supports (4.2 LTS to 5.2).

The one place that knows: everything else calls these functions instead of testing
``bpy.app.version`` itself.
"""

import bpy

VERSION = bpy.app.version


def _rna_input(modifier, name):
    """Blender 5.2+: the RNA item of the modifier input ``name``, or None before 5.2.

    5.2 moved Geometry Nodes modifier inputs out of the modifier's ID properties
    (``modifier[identifier]`` raises TypeError) into RNA:
    ``modifier.properties.inputs.<identifier>`` with ``value``, ``type`` ('VALUE' or
    'ATTRIBUTE') and ``attribute_name``.
    """
    inputs = getattr(getattr(modifier, "properties", None), "inputs", None)
    if inputs is None:
        return None
    return getattr(inputs, _identifier(modifier, name))


def _identifier(modifier, name):
    return modifier.node_group.interface.items_tree[name].identifier


def set_modifier_input(modifier, name, value):
    """Set the Geometry Nodes modifier input called ``name`` (its group socket's name)."""
    item = _rna_input(modifier, name)
    if item is None:
        modifier[_identifier(modifier, name)] = value
    else:
        item.value = value


def set_modifier_input_attribute(modifier, name, attribute):
    """Make the field input ``name`` read the attribute (or vertex group) ``attribute``."""
    item = _rna_input(modifier, name)
    if item is None:
        identifier = _identifier(modifier, name)
        modifier[identifier + "_use_attribute"] = True
        modifier[identifier + "_attribute_name"] = attribute
    else:
        item.type, item.attribute_name = 'ATTRIBUTE', attribute
    # Before 5.2 ID property writes do not tag the modifier for re-evaluation.
    modifier.node_group.interface_update(bpy.context)


def remove_nodes_modifier(obj, modifier):
    """Remove the Geometry Nodes modifier ``modifier`` of ``obj``.

    5.2 keeps a user of every object an input points at when the modifier is removed with
    the input set (a deleted cage then lives on and is saved with the file): the object
    inputs are cleared first.
    """
    if modifier.node_group is not None:
        for item in modifier.node_group.interface.items_tree:
            if getattr(item, "in_out", None) == 'INPUT' and item.socket_type == 'NodeSocketObject':
                set_modifier_input(modifier, item.name, None)
    obj.modifiers.remove(modifier)


def get_modifier_input(modifier, name):
    """The value of the Geometry Nodes modifier input called ``name``."""
    item = _rna_input(modifier, name)
    if item is None:
        return modifier.get(_identifier(modifier, name))  # None when it was never set
    return item.value


def compare_operands(node):
    """The A and B inputs of a Compare node for its current data type.

    Up to 5.1 a Compare node has the sockets of every data type (A and B for float, int,
    vector, ...; only the data type's are available); 5.2 has only the current type's.
    """
    a_sockets = [socket for socket in node.inputs if socket.name == "A"]
    b_sockets = [socket for socket in node.inputs if socket.name == "B"]
    if len(a_sockets) == 1:
        return a_sockets[0], b_sockets[0]
    available = [(a, b) for a, b in zip(a_sockets, b_sockets) if a.enabled]
    if len(available) != 1:
        raise RuntimeError(f"Blender {bpy.app.version_string}: no single pair of Compare "
                           f"inputs for data type {node.data_type}")
    return available[0]


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


def action_fcurves(obj):
    """The F-curves of the action ``obj`` is animated by: layered actions (Blender 4.4
    and later; ``Action.fcurves`` is gone in 5.0) keep them per slot in a channel bag."""
    animation = obj.animation_data
    action = animation.action
    if getattr(action, "layers", None):
        return action.layers[0].strips[0].channelbag(animation.action_slot).fcurves
    return action.fcurves
