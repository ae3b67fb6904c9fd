"""The deformer: a Geometry Nodes group that moves a bound mesh with its cage, natively.

For mesh vertex i with slot values ``u_i`` (s numbers, stored on the mesh as point
attributes) and the cage's vertices now (``C``) and at bind time (``R``), both in the
mesh's local space, the group outputs

    P_i + sum_l u_il E_l,        E_l = sum_j basis_jl (C_j - R_j)

where ``P`` is the incoming position (shape keys, edits and earlier modifiers pass
through). Exact storage has ``basis = I`` and ``u = coordinates``; compact storage a
basis of s cage motions (``core.tools.compact``). At rest ``C == R`` bitwise (``R`` is read
back from this same Object Info node, see ``binding.capture_rest_cage``), so the mesh
is unchanged bitwise.

Evaluation cost is in the per-vertex part: Blender's field evaluator streams whole
arrays through each node, so the slots are packed three to a vector attribute and
accumulated with one Multiply Add per output axis (``acc_x += u_t * (E_a.x, E_b.x,
E_c.x)``): one node per slot (Transform Direction would do the same in one node per
three slots but costs five times as much per vertex). The small per-cage part (the
``E`` lanes) is single values: for exact storage, lanes gathered once onto a point
cloud of s/3 points; for compact storage, one Attribute Statistic sum per lane.

Green coordinates (slots ``[phi, psi]``, n + m of them) add the cage's face terms: the
group builds a point cloud of n + m points whose displacements are the cage vertices'
``C_j - R_j`` and then, per triangle, ``s_j n'_j - n_j`` (its unit normal now scaled by its
stretch factor, minus its unit normal at rest; exactly 0 while its corners have not
moved), from the triangles' corner indices kept on the mesh's first m points. The same
lanes and sums then give ``P + sum_i phi_i (C_i - R_i) + sum_j psi_j (s_j n'_j - n_j)``.

When the cage is missing, has another vertex count or non-finite positions, or the mesh
has another vertex count than at bind time, the group passes the mesh through
unchanged (the panel says why). It removes its own attributes from its output, so
Apply gives a clean mesh and later modifiers never see them.
"""

import bpy
import numpy as np

from . import compat
from .bind_layout import PARKED_PREFIX, attribute_prefix, slot_attribute_names

GEOMETRY = "Geometry"
CAGE = "Cage"
STRENGTH = "Strength"
MASK = "Mask"
INVERT = "Invert Mask"
LANE_NAMES = ("gencoords_lane_x", "gencoords_lane_y", "gencoords_lane_z")
DISPLACEMENT = "gencoords_displacement"  # on the cage's copy inside the group
REST = "gencoords_rest"  # Green: the rest cage, also stored on it
AXES = "XYZ"
COLUMN_WIDTH, ROW_HEIGHT = 220.0, 160.0

# The binding's group reads left to right, one column per stage (``build_group``);
# compact storage's lanes use the lane columns for its basis copy and sums.
DEFORMER_COLUMNS = (
    "input",  # the modifier's inputs
    "cage",  # Object Info, the cage's index and positions
    "rest",  # the bind-time cage, kept in the group
    "displacement",  # cage now minus at rest, stored on the cage
    "face_corners",  # Green: a point per cage vertex and triangle, its corners
    "face_vectors",  # ... their edge vectors now and at rest
    "face_normals",  # ... unit normals and the stretch factor
    "face_store",  # ... each point's displacement, stored on it
    "lane_index",  # per triple of slots: which cage vertices
    "lane_gather",  # their displacements
    "lane_split",  # ... split into axes
    "lane_join",  # ... joined into lanes
    "lane_store",  # ... stored on a point cloud
    "lane_read",  # ... read back per triple
    "accumulate",  # slots times lanes, in chains
    "chain_sum",  # the chains added up pairwise
    "offset",  # each mesh vertex's displacement, the mask, the guard's sizes
    "apply",  # strength and Set Position
    "guard_compare",  # is the result meaningful?
    "guard_and",
    "guard_switch",  # ... else pass the mesh through
    "strip",  # remove the bind data's attributes from the output
    "output",
)
# Helper groups: input, read, combine, output.
HELPER_COLUMNS = ("input", "read", "combine", "output")
# The rest-cage capture: the deformer's Object Info node, alone.
CAPTURE_COLUMNS = ("input", "cage", "output")


class _Builder:
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

    def index_switch(self, column, index, vectors):
        """A field that is ``vectors[index]``: per-cage constants kept in the group."""
        node = self.add('GeometryNodeIndexSwitch', column, data_type='VECTOR')
        compat.new_index_switch_items(node, len(vectors))
        self.link(index, node.inputs["Index"])
        for socket, vector in zip(node.inputs[1:], vectors):
            socket.default_value = vector
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
        for socket, value in zip(compat.compare_operands(node), (a, b)):
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


ACCUMULATE_GROUP = ".GenCoords accumulate 1"  # shared helpers; the number is their layout
CLOUD_LANES_GROUP = ".GenCoords cloud lanes 1"
HELPER_GROUPS = (ACCUMULATE_GROUP, CLOUD_LANES_GROUP)
SUMS = ("Sum X", "Sum Y", "Sum Z")
LANES = ("Lane X", "Lane Y", "Lane Z")


def _new_group(name, inputs, outputs, description, columns=HELPER_COLUMNS):
    """A new node group with sockets ``inputs`` and ``outputs`` ((name, socket type)
    pairs), its builder, and its Group Input and Group Output nodes (first and last
    columns)."""
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.description = description
    for sockets, in_out in ((inputs, 'INPUT'), (outputs, 'OUTPUT')):
        for socket_name, socket_type in sockets:
            group.interface.new_socket(socket_name, in_out=in_out, socket_type=socket_type)
    build = _Builder(group, columns)
    return (group, build, build.add('NodeGroupInput', columns[0]),
            build.add('NodeGroupOutput', columns[-1]))


def build_capture_group(name):
    """A node group outputting its Cage input's geometry as the deformer's Object Info
    node gives it (relative to the modified object): ``binding.capture_rest_cage``
    reads the rest cage through it."""
    group, build, group_input, group_output = _new_group(
        name, [(GEOMETRY, 'NodeSocketGeometry'), (CAGE, 'NodeSocketObject')],
        [(GEOMETRY, 'NodeSocketGeometry')], "GenCoords: the cage as the deformer sees it",
        CAPTURE_COLUMNS)
    build.link(_cage_info(build, group_input), group_output.inputs[GEOMETRY])
    return group


def _cage_info(build, group_input):
    """The cage's geometry in the modified object's space.

    Object Info's Relative space skips transforms within ~1e-6 of the identity (absolute:
    a 1e-6-sized cage moved by 5e-7 would not be followed), so the cage is read in its
    own space and moved by (mesh world)^-1 (cage world) point by point, with no shortcut;
    where Object Info has no Transform output, by Relative space.
    """
    info = build.add('GeometryNodeObjectInfo', "cage", transform_space='ORIGINAL')
    build.link(group_input.outputs[CAGE], info.inputs["Object"])
    if "Transform" not in info.outputs:
        info.transform_space = 'RELATIVE'
        return info.outputs["Geometry"]
    own = build.add('GeometryNodeObjectInfo', "cage", transform_space='ORIGINAL')
    build.link(build.add('GeometryNodeSelfObject', "cage").outputs[0], own.inputs["Object"])
    inverse = build.add('FunctionNodeInvertMatrix', "cage")
    build.link(own.outputs["Transform"], inverse.inputs[0])
    relative = build.add('FunctionNodeMatrixMultiply', "cage")
    build.link(inverse.outputs[0], relative.inputs[0])
    build.link(info.outputs["Transform"], relative.inputs[1])
    moved = build.add('FunctionNodeTransformPoint', "cage")
    build.link(build.add('GeometryNodeInputPosition', "cage").outputs[0], moved.inputs[0])
    build.link(relative.outputs[0], moved.inputs[1])
    placed = build.add('GeometryNodeSetPosition', "cage")
    build.link(info.outputs["Geometry"], placed.inputs["Geometry"])
    build.link(moved.outputs[0], placed.inputs["Position"])
    return placed.outputs["Geometry"]


def _accumulate_group():
    """Helper group: ``Sum c += slots(Name) * Lane c`` for the three axes c.

    One node per three slots in the binding's group keeps it small: building a node tree
    from Python costs time quadratic in its node count.
    """
    group = bpy.data.node_groups.get(ACCUMULATE_GROUP)
    if group is not None:
        return group
    vector = 'NodeSocketVector'
    group, build, group_input, group_output = _new_group(
        ACCUMULATE_GROUP, [("Name", 'NodeSocketString'), *((n, vector) for n in LANES + SUMS)],
        [(n, vector) for n in SUMS], "GenCoords: adds three slots' share of the displacement")
    slots = build.add('GeometryNodeInputNamedAttribute', "read", data_type='FLOAT_VECTOR')
    build.link(group_input.outputs["Name"], slots.inputs["Name"])
    for lane, total in zip(LANES, SUMS):
        build.link(build.math("combine", 'MULTIPLY_ADD', slots.outputs["Attribute"],
                              group_input.outputs[lane], group_input.outputs[total]),
                   group_output.inputs[total])
    return group


def _cloud_lanes_group():
    """Helper group: the three lane vectors of triple ``Triple`` stored on ``Cloud``."""
    group = bpy.data.node_groups.get(CLOUD_LANES_GROUP)
    if group is not None:
        return group
    group, build, group_input, group_output = _new_group(
        CLOUD_LANES_GROUP, [("Cloud", 'NodeSocketGeometry'), ("Triple", 'NodeSocketInt')],
        [(n, 'NodeSocketVector') for n in LANES], "GenCoords: one triple's cage displacements")
    for lane, name in zip(LANES, LANE_NAMES):
        build.link(build.sample_index("combine", group_input.outputs["Cloud"],
                                      build.named_attribute("read", name),
                                      group_input.outputs["Triple"]),
                   group_output.inputs[lane])
    return group


def _exact_lanes(build, cage, displacement, slot_count):
    """Per triple t, its three lanes: (D_3t.c, D_3t+1.c, D_3t+2.c) for axes c."""
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
    helper = _cloud_lanes_group()
    lanes = []
    for t in range(triples):
        node = build.add('GeometryNodeGroup', "lane_read", node_tree=helper)
        build.link(geometry, node.inputs["Cloud"])
        node.inputs["Triple"].default_value = t
        lanes.append([node.outputs[lane] for lane in LANES])
    return lanes


def _compact_lanes(build, mesh, cage, displacement, basis_names):
    """Per triple t, its three lanes: sum_j basis[j, 3t:3t+3] * D_j.c for axes c.

    The basis is stored like the slots, on the mesh's first n points (compact storage
    needs a mesh with at least as many vertices as the cage).
    """
    index = build.add('GeometryNodeInputIndex', "lane_index").outputs[0]
    for name in basis_names:  # copied onto the cage once, read by three sums each
        basis = build.sample_index("lane_gather", mesh,
                                   build.named_attribute("lane_gather", name), index)
        cage = build.store("lane_split", cage, name, basis)
    separate = build.add('ShaderNodeSeparateXYZ', "lane_gather")
    build.link(displacement, separate.inputs[0])
    return [[build.statistic_sum("lane_store", cage,
                                 build.scale("lane_join", build.named_attribute("lane_split", name),
                                             separate.outputs[axis]))
             for axis in range(3)] for name in basis_names]


# Accumulation chains of at most this many helper nodes, added up pairwise: Blender
# gathers the attributes a field depends on at every node, so one chain over all slots
# costs time quadratic in their number at every evaluation (measured: 100 ms for 642
# slots on a 2k-vertex mesh, against 4 ms in chains of 16).
CHAIN = 16


def _weighted_sums(build, slot_names, lanes):
    """The three axes' sums over triples t of ``slots_t * lanes[t][axis]``."""
    helper = _accumulate_group()
    partial = []
    for start in range(0, len(slot_names), CHAIN):
        sums = None
        for name, lane in zip(slot_names[start:start + CHAIN], lanes[start:start + CHAIN]):
            node = build.add('GeometryNodeGroup', "accumulate", node_tree=helper)
            node.inputs["Name"].default_value = name
            for socket, value in zip(LANES, lane):
                build.link(value, node.inputs[socket])
            if sums is not None:
                for socket, value in zip(SUMS, sums):
                    build.link(value, node.inputs[socket])
            sums = [node.outputs[socket] for socket in SUMS]
        partial.append(sums)
    while len(partial) > 1:
        pairs = [[build.math("chain_sum", 'ADD', a, b) for a, b in zip(left, right)]
                 for left, right in zip(partial[::2], partial[1::2])]
        partial = pairs + partial[len(pairs) * 2:]
    return partial[0]


def build_group(name, key, rest_cage, mesh_vertex_count, slot_count, basis_names=None,
                triangle_name=None, face_count=0):
    """A new node group deforming a mesh of ``mesh_vertex_count`` vertices.

    Built in stages that pass sockets along, each in its own columns
    (``DEFORMER_COLUMNS``): the interface, the cage's displacement, the lanes, the
    weighted sums, the masked offset, the guard and the attribute stripping.

    Parameters
    ----------
    name : str
        Of the node group.
    key : str
        The binding's key: slot attributes are ``slot_attribute_names(key, slot_count)``.
    rest_cage : (n, 3) float32
        The cage at bind time in the mesh's local space, exactly as the group's Object
        Info node gives it.
    mesh_vertex_count : int
        The bound mesh's vertex count k (another count passes the mesh through).
    slot_count : int
        s: n for exact storage, the basis size for compact storage.
    basis_names : list of str, optional
        Compact storage: the attributes holding the basis of cage motions on the first n
        points (n + m for Green coordinates; ``bind_layout.basis_attribute_names``); None
        for exact storage.
    triangle_name : str, optional
        Green coordinates: the attribute holding the cage's m triangles (corner indices)
        on the mesh's first m points; None for the other kinds.
    face_count : int
        Green coordinates: m.
    """
    rest_cage = np.asarray(rest_cage, dtype=np.float32)
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.description = ("GenCoords cage deformation: moves the mesh with its cage "
                         "(bind data in the mesh's point attributes)")
    _deformer_interface(group.interface)
    build = _Builder(group, DEFORMER_COLUMNS)
    group_input = build.add('NodeGroupInput', "input")
    mesh = group_input.outputs[GEOMETRY]
    cage, displacement = _cage_displacement(build, group_input, rest_cage, triangle_name is not None)
    # What the slots weigh: the cage's vertices, or for Green also its faces.
    moving = (cage, displacement) if triangle_name is None else _green_displacements(
        build, mesh, cage, len(rest_cage), face_count, triangle_name)
    if basis_names is None:
        lanes = _exact_lanes(build, *moving, slot_count)
    else:
        lanes = _compact_lanes(build, mesh, *moving, basis_names)
    accumulated = _weighted_sums(build, slot_attribute_names(key, slot_count), lanes)
    moved = _moved_mesh(build, group_input, _offset(build, accumulated))
    usable = _usable(build, mesh, cage, moving, len(rest_cage), mesh_vertex_count)
    switch = build.add('GeometryNodeSwitch', "guard_switch", input_type='GEOMETRY')
    build.link(usable, switch.inputs["Switch"])
    build.link(mesh, switch.inputs["False"])
    build.link(moved, switch.inputs["True"])
    output = _strip_attributes(build, switch.outputs[0], key,
                               slot_attribute_names(key, slot_count) + (basis_names or [])
                               + ([triangle_name] if triangle_name else []))
    build.link(output, build.add('NodeGroupOutput', "output").inputs[GEOMETRY])
    return group


def _deformer_interface(interface):
    """The modifier's inputs and output."""
    interface.new_socket(GEOMETRY, in_out='INPUT', socket_type='NodeSocketGeometry')
    cage_socket = interface.new_socket(CAGE, in_out='INPUT', socket_type='NodeSocketObject')
    cage_socket.description = "The cage the mesh was bound to"
    strength = interface.new_socket(STRENGTH, in_out='INPUT', socket_type='NodeSocketFloat')
    strength.default_value, strength.min_value, strength.max_value = 1.0, -10.0, 10.0
    strength.description = "How much of the cage's motion the mesh follows (animatable)"
    mask = interface.new_socket(MASK, in_out='INPUT', socket_type='NodeSocketFloat')
    mask.default_value, mask.min_value, mask.max_value = 1.0, 0.0, 1.0
    mask.description = ("Per-vertex factor: click the attribute toggle and pick a vertex "
                        "group to limit the deformation to it")
    invert = interface.new_socket(INVERT, in_out='INPUT', socket_type='NodeSocketBool')
    invert.description = "Deform where the mask is 0 instead of where it is 1"
    interface.new_socket(GEOMETRY, in_out='OUTPUT', socket_type='NodeSocketGeometry')


def _cage_displacement(build, group_input, rest_cage, keep_rest=False):
    """The cage with ``DISPLACEMENT`` (now minus at rest) stored on its points (and
    ``REST`` with ``keep_rest``), and the displacement's field."""
    cage = _cage_info(build, group_input)
    cage_index = build.add('GeometryNodeInputIndex', "cage").outputs[0]
    position = build.add('GeometryNodeInputPosition', "cage").outputs[0]
    rest = build.index_switch("rest", cage_index, rest_cage.tolist())
    # Stored once: every consumer of a field evaluates it again, and the Index Switch
    # over n constants costs n^2 per evaluation.
    if keep_rest:
        cage = build.store("displacement", cage, REST, rest)
        rest = build.named_attribute("displacement", REST)
    cage = build.store("displacement", cage, DISPLACEMENT,
                       build.math("displacement", 'SUBTRACT', position, rest))
    return cage, build.named_attribute("displacement", DISPLACEMENT)


def _green_displacements(build, mesh, cage, cage_vertex_count, face_count, triangle_name):
    """A point cloud of n + m points with ``DISPLACEMENT`` stored: the cage's vertices'
    (``C - R``), then each triangle's ``s n' - n`` (0 while its corners are at rest, so
    the mesh stays bitwise at rest); and that attribute's field."""
    cloud = build.add('GeometryNodePoints', "face_corners")
    cloud.inputs["Count"].default_value = cage_vertex_count + face_count
    index = build.add('GeometryNodeInputIndex', "face_corners").outputs[0]
    triangle = build.math("face_corners", 'SUBTRACT', index, float(cage_vertex_count), vector=False)
    corners = build.add('ShaderNodeSeparateXYZ', "face_corners")
    build.link(build.sample_index("face_corners", mesh, build.named_attribute("face_corners", triangle_name),
                                  triangle), corners.inputs[0])
    position = build.add('GeometryNodeInputPosition', "face_corners").outputs[0]
    rest_field = build.named_attribute("face_corners", REST)
    now = [build.sample_index("face_vectors", cage, position, corners.outputs[c]) for c in range(3)]
    rest = [build.sample_index("face_vectors", cage, rest_field, corners.outputs[c]) for c in range(3)]
    edges_now = [build.math("face_vectors", 'SUBTRACT', now[c], now[0]) for c in (1, 2)]
    edges_rest = [build.math("face_vectors", 'SUBTRACT', rest[c], rest[0]) for c in (1, 2)]
    face = _scaled_normal_change(build, edges_rest, edges_now)
    # Exactly 0 while the triangle's corners are where they were at Bind.
    still = build.compare("face_normals", 'FLOAT', build.math("face_normals", 'ADD', build.math(
        "face_normals", 'ADD', build.math("face_normals", 'DISTANCE', now[0], rest[0]),
        build.math("face_normals", 'DISTANCE', now[1], rest[1]), vector=False),
        build.math("face_normals", 'DISTANCE', now[2], rest[2]), vector=False), 0.0)
    face = _switch(build, "face_store", 'VECTOR', still, face, (0.0, 0.0, 0.0))
    vertex = build.sample_index("face_store", cage, build.named_attribute("face_store", DISPLACEMENT), index)
    is_vertex = build.add('FunctionNodeCompare', "face_store", data_type='INT', operation='LESS_THAN')
    operands = compat.compare_operands(is_vertex)
    build.link(index, operands[0])
    operands[1].default_value = cage_vertex_count
    value = _switch(build, "face_store", 'VECTOR', is_vertex.outputs[0], face, vertex)
    cloud = build.store("face_store", cloud.outputs[0], DISPLACEMENT, value)
    return cloud, build.named_attribute("face_store", DISPLACEMENT)


def _scaled_normal_change(build, edges_rest, edges_now):
    """``s n' - n`` of a triangle from its edge vectors at rest (u, v) and now (u', v'):
    ``s = ||(u', v')|| / (sqrt(2) |u x v|)``, ``||(u', v')||^2 = |u'|^2 |v|^2
    - 2 (u'.v')(u.v) + |v'|^2 |u|^2`` (docs/MATH.md)."""
    (u, v), (u_now, v_now) = edges_rest, edges_now
    column = "face_normals"

    def dot(a, b):
        return build.math(column, 'DOT_PRODUCT', a, b)

    def times(a, b):
        return build.math(column, 'MULTIPLY', a, b, vector=False)

    doubled_rest = build.math(column, 'CROSS_PRODUCT', u, v)
    squared = build.math(column, 'ADD', build.math(column, 'SUBTRACT', times(dot(u_now, u_now), dot(v, v)),
                                                   times(2.0, times(dot(u_now, v_now), dot(u, v))), vector=False),
                         times(dot(v_now, v_now), dot(u, u)), vector=False)
    root = build.math(column, 'SQRT', build.math(column, 'MAXIMUM', squared, 0.0, vector=False), vector=False)
    stretch = build.math(column, 'DIVIDE', root, times(np.sqrt(2.0), build.math(column, 'LENGTH', doubled_rest)),
                         vector=False)
    normal_now = build.math(column, 'NORMALIZE', build.math(column, 'CROSS_PRODUCT', u_now, v_now))
    return build.math(column, 'SUBTRACT', build.scale(column, normal_now, stretch),
                      build.math(column, 'NORMALIZE', doubled_rest))


def _switch(build, column, input_type, condition, if_false, if_true):
    """``if_true`` where ``condition``, else ``if_false`` (sockets or constants)."""
    node = build.add('GeometryNodeSwitch', column, input_type=input_type)
    build.link(condition, node.inputs["Switch"])
    for socket, value in ((node.inputs["False"], if_false), (node.inputs["True"], if_true)):
        if isinstance(value, bpy.types.NodeSocket):
            build.link(value, socket)
        else:
            socket.default_value = value
    return node.outputs[0]


def _offset(build, accumulated):
    """Each mesh vertex's displacement: the sum of each axis' three partial sums."""
    offset = build.add('ShaderNodeCombineXYZ', "offset")
    for axis in range(3):
        total = build.add('ShaderNodeVectorMath', "offset", operation='DOT_PRODUCT')
        build.link(accumulated[axis], total.inputs[0])
        total.inputs[1].default_value = (1.0, 1.0, 1.0)
        build.link(total.outputs["Value"], offset.inputs[axis])
    return offset.outputs[0]


def _moved_mesh(build, group_input, offset):
    """P + strength * mask * offset, the mask inverted on request (1 - mask)."""
    mask = group_input.outputs[MASK]
    inverted = build.math("offset", 'SUBTRACT', 1.0, mask, vector=False)
    pick = build.add('GeometryNodeSwitch', "offset", input_type='FLOAT')
    build.link(group_input.outputs[INVERT], pick.inputs["Switch"])
    build.link(mask, pick.inputs["False"])
    build.link(inverted, pick.inputs["True"])
    factor = build.math("apply", 'MULTIPLY', group_input.outputs[STRENGTH], pick.outputs[0],
                        vector=False)
    moved = build.add('GeometryNodeSetPosition', "apply")
    build.link(group_input.outputs[GEOMETRY], moved.inputs["Geometry"])
    build.link(build.scale("apply", offset, factor), moved.inputs["Offset"])
    return moved.outputs[0]


def _usable(build, mesh, cage, moving, cage_vertex_count, mesh_vertex_count):
    """Whether deforming is meaningful: the cage and the mesh have their bind-time
    vertex counts and the displacements (``moving``: geometry, field) are finite."""
    cage_size = build.add('GeometryNodeAttributeDomainSize', "offset", component='MESH')
    build.link(cage, cage_size.inputs[0])
    mesh_size = build.add('GeometryNodeAttributeDomainSize', "offset", component='MESH')
    build.link(mesh, mesh_size.inputs[0])
    total = build.statistic_sum("offset", *moving)
    # NaN and infinity are the only values for which x - x is not zero.
    difference = build.math("guard_compare", 'SUBTRACT', total, total)
    finite = build.compare("guard_compare", 'FLOAT',
                           build.math("guard_compare", 'LENGTH', difference), 0.0)
    counts = build.both("guard_and",
                        build.compare("guard_compare", 'INT', cage_size.outputs[0],
                                      cage_vertex_count),
                        build.compare("guard_compare", 'INT', mesh_size.outputs[0],
                                      mesh_vertex_count))
    return build.both("guard_and", counts, finite)


def _strip_attributes(build, geometry, key, names):
    """``geometry`` without the binding's attributes (``names``, or by wildcard)."""
    remove = build.add('GeometryNodeRemoveAttribute', "strip")
    build.link(geometry, remove.inputs["Geometry"])
    if compat.set_wildcard_removal(remove, attribute_prefix(key) + "*"):
        return remove.outputs[0]
    build.group.nodes.remove(remove)  # no wildcard: one removal per attribute
    for name in names:
        remove = build.add('GeometryNodeRemoveAttribute', "strip")
        remove.inputs["Name"].default_value = name
        build.link(geometry, remove.inputs["Geometry"])
        geometry = remove.outputs[0]
    return geometry


def remove_slots(mesh, key):
    """Delete every attribute of the binding ``key`` from ``mesh``."""
    prefix = attribute_prefix(key)
    for name in [a.name for a in mesh.attributes if a.name.startswith(prefix)]:
        mesh.attributes.remove(mesh.attributes[name])


def park_slots(mesh, key):
    """Take the binding ``key``'s attributes out of the deformer's reach, all or none,
    by renaming them (no copy of the bind data): the first step of an Unbind that can
    still be undone (:func:`put_back_slots`) or finished (:func:`drop_parked_slots`).

    Returns
    -------
    parked : dict of str -> str
        Parked name -> original name.
    """
    prefix = attribute_prefix(key)
    parked = {}
    try:
        for name in [a.name for a in mesh.attributes if a.name.startswith(prefix)]:
            attribute = mesh.attributes[name]
            attribute.name = PARKED_PREFIX + name
            parked[attribute.name] = name  # as Blender made it unique
    except Exception:
        put_back_slots(mesh, parked)
        raise
    return parked


def put_back_slots(mesh, parked):
    """Undo :func:`park_slots`."""
    for parked_name, name in parked.items():
        attribute = mesh.attributes.get(parked_name)
        if attribute is not None:
            attribute.name = name


def drop_parked_slots(mesh, parked):
    """Finish an Unbind: delete what :func:`park_slots` parked."""
    for parked_name in parked:
        attribute = mesh.attributes.get(parked_name)
        if attribute is not None:
            mesh.attributes.remove(attribute)


def remove_unused_helpers():
    """Delete the shared helper groups once no binding uses them."""
    for name in HELPER_GROUPS:
        group = bpy.data.node_groups.get(name)
        if group is not None and group.users == 0:
            bpy.data.node_groups.remove(group)


def read_rest_cage(group, count):
    """The bind-time cage ``build_group`` keeps in ``group`` ((count, 3) float32, the
    mesh's local space, as its Object Info node gives it), or None when it is not there."""
    switches = [node for node in group.nodes
                if node.bl_idname == 'GeometryNodeIndexSwitch' and node.data_type == 'VECTOR']
    if len(switches) != 1 or len(switches[0].inputs) < count + 1:
        return None
    return np.array([socket.default_value[:] for socket in switches[0].inputs[1:count + 1]],
                    dtype=np.float32).reshape(count, 3)
