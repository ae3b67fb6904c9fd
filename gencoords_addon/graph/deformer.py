"""The deformer: a Geometry Nodes group that moves a bound mesh with its cage, natively.
What every binding's group shares is built here (:func:`group_steps`); each storage's
own part, the offset from its attributes, is its module's (``gencoords_addon.storage``).

For exact and compact storage's mesh vertex i with slot values ``u_i`` (s numbers, stored on the mesh as point
attributes) and the cage's vertices now (``C``) and at bind time (``R``), both in the
mesh's local space, the group outputs

    P_i + sum_l u_il E_l,        E_l = sum_j basis_jl (C_j - R_j)

where ``P`` is the incoming position (shape keys, edits and earlier modifiers pass
through). Exact storage has ``basis = I`` and ``u = coordinates``; compact storage a
basis of s cage motions (``core.storage.compact``); sparse storage gathers pairs instead
(``graph.gather``). At rest ``C == R`` bitwise (``R`` is read
back from this same Object Info node, see ``bind.scene.capture_rest_cage``), so the mesh
is unchanged bitwise.

Evaluation cost is in the per-vertex part: Blender's field evaluator streams whole
arrays through each node, so the slots are packed three to a vector attribute and
accumulated with one Multiply Add per output axis (``acc_x += u_t * (E_a.x, E_b.x,
E_c.x)``): one node per slot (Transform Direction would do the same in one node per
three slots but costs five times as much per vertex). The small per-cage part (the
``E`` lanes) is single values: for exact storage, lanes gathered once onto a point
cloud of s/3 points; for compact storage, one Attribute Statistic sum per lane. Both
happen inside shared chunk groups (``graph.chunks``) that take up to 16 triples of slots
each, their attribute names set as values on the chunk's node: the binding's group holds
a node per 16 triples and a few links per node, so Bind builds it in a fraction of a
second whatever the cage.

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

from ..bind_layout import attribute_prefix
from ..blender_io.compat import set_wildcard_removal
from ..steps import scaled
from . import chunks
from .builder import Builder
from .green import green_displacements
from .helpers import CAGE, DISPLACEMENT, GEOMETRY, REST, SUMS, cage_info

STRENGTH = "Strength"
REST_SWITCH = "GenCoords rest cage"  # the node keeping the bind-time cage (read_rest_cage)
MASK = "Mask"
INVERT = "Invert Mask"
DESCRIPTION = "GenCoords cage deformation: moves the mesh with its cage (bind data in the mesh's point attributes)"

# The binding's group reads left to right, one column per stage (``group_steps``).
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
    "accumulate",  # slots times lanes, a chunk node per 16 triples (graph.chunks), in chains
    "chain_sum",  # the chains added up pairwise
    "offset",  # each mesh vertex's displacement, the mask, the guard's sizes
    "apply",  # strength and Set Position
    "guard_compare",  # is the result meaningful?
    "guard_and",
    "guard_switch",  # ... else pass the mesh through
    "strip",  # remove the bind data's attributes from the output
    "output",
)


# Chunks chained into one sum while they hold at most this many triples, then added up
# pairwise: Blender gathers the attributes a field depends on at every node, so one chain
# over all slots costs time quadratic in their number at every evaluation (measured:
# 100 ms for 642 slots on a 2k-vertex mesh, against 4 ms in chains of 16).
CHAIN = 16
# Chunk nodes placed between two steps of a Bind's writing (progress, Esc).
STEP_CHUNKS = 8


def chunk_offset_steps(build, storage, sources, slot_names, lane_entries):
    """Each mesh vertex's displacement from slot attributes (exact and compact storage,
    ``graph.chunks``): the weighted sums of :func:`_weighted_sums`, a generator yielding
    the fraction built (0.1 to 0.9 of the group) and returning the offset's socket."""
    yield 0.1
    accumulated = yield from scaled(_weighted_sums(build, storage, sources, slot_names, lane_entries), 0.1, 0.8)
    return _offset(build, accumulated)


def _weighted_sums(build, storage, sources, slot_names, lane_entries):
    """The three axes' sums over triples t of ``slots_t * lanes_t[axis]``, a chunk node
    (``graph.chunks``) per up to 16 triples: ``sources`` its geometry inputs by name,
    ``lane_entries[t]`` where triple t's lanes come from (its cloud index or basis name).
    A generator yielding the fraction of chunks placed, returning the sums' sockets."""
    partial, start, chained = [], 0, CHAIN
    plan = chunks.chunk_plan(len(slot_names))
    for done, size in enumerate(plan):
        if done % STEP_CHUNKS == 0:
            yield done / len(plan)
        node = build.add('GeometryNodeGroup', "accumulate", node_tree=chunks.chunk_group(storage, size))
        for name, geometry in sources.items():
            build.link(geometry, node.inputs[name])
        slots_entry, lanes_entry = chunks.ENTRIES[storage]
        for k in range(size):
            node.inputs[f"{slots_entry} {k}"].default_value = slot_names[start + k]
            node.inputs[f"{lanes_entry} {k}"].default_value = lane_entries[start + k]
        if chained + size <= CHAIN:
            for socket, value in zip(SUMS, partial[-1]):
                build.link(value, node.inputs[socket])
            partial[-1], chained = [node.outputs[socket] for socket in SUMS], chained + size
        else:
            partial.append([node.outputs[socket] for socket in SUMS])
            chained = size
        start += size
    while len(partial) > 1:
        pairs = [[build.math("chain_sum", 'ADD', a, b) for a, b in zip(left, right)]
                 for left, right in zip(partial[::2], partial[1::2])]
        partial = pairs + partial[len(pairs) * 2:]
    return partial[0]


def group_steps(name, key, rest_cage, mesh_vertex_count, offset_steps, names, triangles=None,
                description=DESCRIPTION):
    """A new node group deforming a mesh of ``mesh_vertex_count`` vertices: a generator
    yielding the fraction built (a Bind's writing shows progress and takes Esc between
    stages) and returning the group; closed early or failing, it removes the group.

    Built in stages that pass sockets along, each in its own columns
    (``DEFORMER_COLUMNS``): the interface, the cage's displacement, the storage's offset
    (``offset_steps``), the masked move, the guard and the attribute stripping.

    Parameters
    ----------
    name : str
        Of the node group.
    key : str
        The binding's key: its attributes' names start with ``attribute_prefix(key)``.
    rest_cage : (n, 3) float32
        The cage at bind time in the mesh's local space, exactly as the group's Object
        Info node gives it.
    mesh_vertex_count : int
        The bound mesh's vertex count k (another count passes the mesh through).
    offset_steps : callable
        ``offset_steps(build, mesh, moving)``: the storage's part (``gencoords_addon.storage``),
        a generator yielding the fraction built and returning each mesh vertex's
        displacement (a vector field socket); ``moving`` is (geometry, displacement field)
        of what the coordinates weigh: the cage's vertices, for Green also its faces.
    names : list of str
        The binding's attributes, stripped from the output.
    triangles : (m, 3) int, optional
        Green coordinates: the cage's triangles, kept in the group (groups made before
        read them from an attribute on the mesh's first m points: the mesh needed as
        many vertices); None for the other kinds.
    description : str
        Of the node group.
    """
    rest_cage = np.asarray(rest_cage, dtype=np.float32)
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.description = description
    try:
        _deformer_interface(group.interface)
        build = Builder(group, DEFORMER_COLUMNS)
        group_input = build.add('NodeGroupInput', "input")
        mesh = group_input.outputs[GEOMETRY]
        cage, displacement = _cage_displacement(build, group_input, rest_cage, triangles is not None)
        # What the slots weigh: the cage's vertices, or for Green also its faces.
        moving = (cage, displacement) if triangles is None else green_displacements(
            build, cage, len(rest_cage), triangles)
        offset = yield from offset_steps(build, mesh, moving)
        _finish_group(build, group_input, (mesh, cage, moving), offset, key, names,
                      (len(rest_cage), mesh_vertex_count))
    except BaseException:  # a failure, or a cancel (GeneratorExit): nothing left behind
        bpy.data.node_groups.remove(group)
        raise
    return group


def _finish_group(build, group_input, geometries, offset, key, names, counts):
    """The stages after the offset: the masked move, the guard (``geometries``:
    the mesh, the cage and what moves; ``counts``: the cage's and the mesh's vertices),
    the stripping of the attributes ``names``."""
    mesh, cage, moving = geometries
    moved = _moved_mesh(build, group_input, offset)
    usable = _usable(build, mesh, cage, moving, *counts)
    switch = build.add('GeometryNodeSwitch', "guard_switch", input_type='GEOMETRY')
    build.link(usable, switch.inputs["Switch"])
    build.link(mesh, switch.inputs["False"])
    build.link(moved, switch.inputs["True"])
    output = _strip_attributes(build, switch.outputs[0], key, names)
    build.link(output, build.add('NodeGroupOutput', "output").inputs[GEOMETRY])


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
    cage = cage_info(build, group_input)
    cage_index = build.add('GeometryNodeInputIndex', "cage").outputs[0]
    position = build.add('GeometryNodeInputPosition', "cage").outputs[0]
    rest = build.index_switch("rest", cage_index, rest_cage.tolist(), name=REST_SWITCH)
    # Stored once: every consumer of a field evaluates it again, and the Index Switch
    # over n constants costs n^2 per evaluation.
    if keep_rest:
        cage = build.store("displacement", cage, REST, rest)
        rest = build.named_attribute("displacement", REST)
    cage = build.store("displacement", cage, DISPLACEMENT,
                       build.math("displacement", 'SUBTRACT', position, rest))
    return cage, build.named_attribute("displacement", DISPLACEMENT)


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
    if set_wildcard_removal(remove, attribute_prefix(key) + "*"):
        return remove.outputs[0]
    build.group.nodes.remove(remove)  # no wildcard: one removal per attribute
    for name in names:
        remove = build.add('GeometryNodeRemoveAttribute', "strip")
        remove.inputs["Name"].default_value = name
        build.link(geometry, remove.inputs["Geometry"])
        geometry = remove.outputs[0]
    return geometry


def read_rest_cage(group, count):
    """The bind-time cage ``group_steps`` keeps in ``group`` ((count, 3) float32, the
    mesh's local space, as its Object Info node gives it), or None when it is not there:
    the vector Index Switch named ``REST_SWITCH``, or in groups made before Green's
    triangles were kept in the group too, the only one."""
    switches = [node for node in group.nodes
                if node.bl_idname == 'GeometryNodeIndexSwitch' and node.data_type == 'VECTOR']
    named = [node for node in switches if node.name == REST_SWITCH]
    switches = named or switches
    if len(switches) != 1:
        return None
    values = _switch_values(switches[0])
    if len(values) < count:
        return None
    return np.array(values[:count], dtype=np.float32).reshape(count, 3)


def _switch_values(switch):
    """The constants an Index Switch gives by index, through the switches it chooses
    among (``Builder.index_switch``): a list of 3-tuples."""
    values = []
    for socket in switch.inputs[1:]:
        if socket.is_linked and socket.links[0].from_node.bl_idname == 'GeometryNodeIndexSwitch':
            values += _switch_values(socket.links[0].from_node)
        elif hasattr(socket, "default_value"):  # not the virtual socket that adds an item
            values.append(socket.default_value[:])
    return values
