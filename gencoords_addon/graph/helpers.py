"""The small node groups beside a binding's deformer: the shared helpers its group calls
(one node per three slots keeps that group small: building a node tree from Python costs
time quadratic in its node count) and the capture group Bind reads the rest cage through.
"""

import bpy

from .builder import new_group

GEOMETRY = "Geometry"
CAGE = "Cage"
DISPLACEMENT = "gencoords_displacement"  # on the cage's copy inside the group
REST = "gencoords_rest"  # Green: the rest cage, also stored on it
LANE_NAMES = ("gencoords_lane_x", "gencoords_lane_y", "gencoords_lane_z")
# Helper groups: input, read, combine, output.
HELPER_COLUMNS = ("input", "read", "combine", "output")
# The rest-cage capture: the deformer's Object Info node, alone.
CAPTURE_COLUMNS = ("input", "cage", "output")
HELPER_PREFIX = ".GenCoords "  # shared helpers (here and graph.chunks); the number is their layout
ACCUMULATE_GROUP = HELPER_PREFIX + "accumulate 1"
CLOUD_LANES_GROUP = HELPER_PREFIX + "cloud lanes 1"
SUMS = ("Sum X", "Sum Y", "Sum Z")
LANES = ("Lane X", "Lane Y", "Lane Z")


def build_capture_group(name):
    """A node group outputting its Cage input's geometry as the deformer's Object Info
    node gives it (relative to the modified object): ``bind.scene.capture_rest_cage``
    reads the rest cage through it."""
    group, build, group_input, group_output = new_group(
        name, [(GEOMETRY, 'NodeSocketGeometry'), (CAGE, 'NodeSocketObject')],
        [(GEOMETRY, 'NodeSocketGeometry')], "GenCoords: the cage as the deformer sees it",
        CAPTURE_COLUMNS)
    build.link(cage_info(build, group_input), group_output.inputs[GEOMETRY])
    return group


def cage_info(build, group_input):
    """The cage's geometry in the modified object's space.

    Object Info's Relative space skips transforms within ~1e-6 of the identity (absolute:
    a 1e-6-sized cage moved by 5e-7 would not be followed), so the cage is read in its
    own space and moved into the object's point by point, with no shortcut; where Object
    Info has no Transform output, by Relative space. Not by the product (mesh world)^-1
    (cage world) either: for objects far from the world's origin against the mesh
    object's scale, its translation is the float32 difference of two huge numbers (6e7
    for objects 6e4 away at scale 0.001: the cage lands 4 mesh units off). Instead
    ``L_mesh^-1 (L_cage c + (t_cage - t_mesh))``: the two origins' difference first,
    exact for nearby objects, then only the linear parts, on numbers of the cage's size.
    """
    info = build.add('GeometryNodeObjectInfo', "cage", transform_space='ORIGINAL')
    build.link(group_input.outputs[CAGE], info.inputs["Object"])
    if "Transform" not in info.outputs:
        info.transform_space = 'RELATIVE'
        return info.outputs["Geometry"]
    own = build.add('GeometryNodeObjectInfo', "cage", transform_space='ORIGINAL')
    build.link(build.add('GeometryNodeSelfObject', "cage").outputs[0], own.inputs["Object"])
    origins = [_transformed(build, 'FunctionNodeTransformPoint', matrix, (0.0, 0.0, 0.0))
               for matrix in (info.outputs["Transform"], own.outputs["Transform"])]
    position = build.add('GeometryNodeInputPosition', "cage").outputs[0]
    turned = _transformed(build, 'FunctionNodeTransformDirection', info.outputs["Transform"], position)
    world = build.math("cage", 'ADD', turned, build.math("cage", 'SUBTRACT', *origins))
    inverse = build.add('FunctionNodeInvertMatrix', "cage")
    build.link(own.outputs["Transform"], inverse.inputs[0])
    placed = build.add('GeometryNodeSetPosition', "cage")
    build.link(info.outputs["Geometry"], placed.inputs["Geometry"])
    build.link(_transformed(build, 'FunctionNodeTransformDirection', inverse.outputs[0], world),
               placed.inputs["Position"])
    # A mesh object scaled to zero has no space to place the cage in (the inverse would
    # be the identity): no cage then, and the deformer's guard passes the mesh through.
    kept = build.add('GeometryNodeSwitch', "cage", input_type='GEOMETRY')
    build.link(inverse.outputs["Invertible"], kept.inputs["Switch"])
    build.link(placed.outputs["Geometry"], kept.inputs["True"])
    return kept.outputs[0]


def _transformed(build, node_type, matrix, vector):
    """A Transform Point or Transform Direction node's output: ``vector`` (a socket or a
    value) by ``matrix``."""
    node = build.add(node_type, "cage")
    if isinstance(vector, bpy.types.NodeSocket):
        build.link(vector, node.inputs[0])
    else:
        node.inputs[0].default_value = vector
    build.link(matrix, node.inputs[1])
    return node.outputs[0]


def accumulate_group():
    """Helper group: ``Sum c += slots(Name) * Lane c`` for the three axes c.

    One node per three slots in the binding's group keeps it small: building a node tree
    from Python costs time quadratic in its node count.
    """
    group = bpy.data.node_groups.get(ACCUMULATE_GROUP)
    if group is not None:
        return group
    vector = 'NodeSocketVector'
    group, build, group_input, group_output = new_group(
        ACCUMULATE_GROUP, [("Name", 'NodeSocketString'), *((n, vector) for n in LANES + SUMS)],
        [(n, vector) for n in SUMS], "GenCoords: adds three slots' share of the displacement", HELPER_COLUMNS)
    slots = build.add('GeometryNodeInputNamedAttribute', "read", data_type='FLOAT_VECTOR')
    build.link(group_input.outputs["Name"], slots.inputs["Name"])
    for lane, total in zip(LANES, SUMS):
        build.link(build.math("combine", 'MULTIPLY_ADD', slots.outputs["Attribute"],
                              group_input.outputs[lane], group_input.outputs[total]),
                   group_output.inputs[total])
    return group


def cloud_lanes_group():
    """Helper group: the three lane vectors of triple ``Triple`` stored on ``Cloud``."""
    group = bpy.data.node_groups.get(CLOUD_LANES_GROUP)
    if group is not None:
        return group
    group, build, group_input, group_output = new_group(
        CLOUD_LANES_GROUP, [("Cloud", 'NodeSocketGeometry'), ("Triple", 'NodeSocketInt')],
        [(n, 'NodeSocketVector') for n in LANES], "GenCoords: one triple's cage displacements", HELPER_COLUMNS)
    for lane, name in zip(LANES, LANE_NAMES):
        build.link(build.sample_index("combine", group_input.outputs["Cloud"],
                                      build.named_attribute("read", name),
                                      group_input.outputs["Triple"]),
                   group_output.inputs[lane])
    return group


def remove_unused_helpers():
    """Delete the shared helper groups once no binding uses them (helpers use helpers:
    removing one may leave another unused)."""
    unused = True
    while unused:
        unused = [group for group in bpy.data.node_groups
                  if group.name.startswith(HELPER_PREFIX) and group.users == 0]
        for group in unused:
            bpy.data.node_groups.remove(group)
