"""The cage link: a do-nothing modifier that makes Blender evaluate the cage with the mesh.

Blender leaves an object that is disabled in renders (or viewports) out of that depsgraph
unless something evaluated there depends on it, which is how a hidden armature still
deforms its mesh. GenCoords reads the evaluated cage from handlers, which the depsgraph
cannot see, so binding gives the mesh a geometry-nodes modifier that passes the mesh
through unchanged and whose Cage input is the cage: that input makes the mesh's geometry
depend on the cage's transform and evaluated geometry (shape keys, armatures, modifiers),
so render farms get the animated cage even when the artist hides it from renders.

A modifier rather than a constraint: a constraint would make the mesh's transform depend
on the cage, a dependency cycle as soon as the cage is parented to the mesh.
"""

import bpy

LINK_NAME = "GenCoords cage link"  # the modifier, as the artist sees it in the stack
GROUP_NAME = "." + LINK_NAME  # a leading dot keeps the group out of Add > Group menus
CAGE_INPUT = "Cage"
GEOMETRY = "Geometry"


def _pass_through_group():
    """The node group shared by every link: geometry in, the same geometry out."""
    group = bpy.data.node_groups.get(GROUP_NAME)
    if group is not None:
        return group
    group = bpy.data.node_groups.new(GROUP_NAME, 'GeometryNodeTree')
    group.description = "GenCoords: makes Blender evaluate the cage (passes the mesh through)"
    interface = group.interface
    interface.new_socket(GEOMETRY, in_out='INPUT', socket_type='NodeSocketGeometry')
    interface.new_socket(CAGE_INPUT, in_out='INPUT', socket_type='NodeSocketObject')
    interface.new_socket(GEOMETRY, in_out='OUTPUT', socket_type='NodeSocketGeometry')
    group_input = group.nodes.new('NodeGroupInput')
    group_output = group.nodes.new('NodeGroupOutput')
    group.links.new(group_input.outputs[GEOMETRY], group_output.inputs[GEOMETRY])
    return group


def link(obj, cage):
    """Give ``obj`` a fresh link to ``cage``, replacing any earlier one."""
    unlink(obj)
    group = _pass_through_group()
    modifier = obj.modifiers.new(LINK_NAME, 'NODES')
    modifier.show_expanded = False
    modifier.node_group = group
    # An ID property write tags nothing; the modifier was just added, which makes the
    # depsgraph rebuild its relations (and so see this input) on its next evaluation.
    modifier[group.interface.items_tree[CAGE_INPUT].identifier] = cage


def unlink(obj):
    """Remove the link of ``obj``, and the node group once no link uses it."""
    modifier = obj.modifiers.get(LINK_NAME)
    if modifier is not None:
        obj.modifiers.remove(modifier)
    group = bpy.data.node_groups.get(GROUP_NAME)
    if group is not None and group.users == 0:
        bpy.data.node_groups.remove(group)
