"""Commit a Bind: write a computed binding into the file in one step (node group, the
mesh's attributes, modifier), replacing an earlier binding of the mesh to the same cage;
all or nothing."""

import bpy

from ..blender_io import compat
from ..bind_layout import METADATA
from ..graph import deformer
from . import attributes
from .bindings import binding, bindings, remove

MODIFIER_NAME = "GenCoords"


def write(obj, cage, result):
    """Write the computed binding into the file; returns the new ``Binding``.

    An earlier binding of the mesh to the same cage is replaced (its place in the
    stack is kept); a binding to another cage is added after the mesh's other
    bindings (each changes nothing at rest, so they compose). On any failure
    everything this call added is removed again and the error raised.
    """
    # The binding to this cage, else one whose cage is gone: Bind after picking
    # another cage replaces it.
    earlier = binding(obj, cage) or binding(obj, missing_cage=True)
    others = bindings(obj)
    data = result.data
    key, basis_names, triangle_name = data.key, data.basis_names, data.triangle_name
    group = modifier = None
    try:
        group = deformer.build_group(f"GenCoords: {obj.name} in {cage.name}", key,
                                     result.rest_cage, data.mesh_vertex_count,
                                     data.slot_count, basis_names, triangle_name,
                                     0 if result.triangles is None else len(result.triangles))
        attributes.write(obj.data, data, result.slots, result.basis, result.triangles)
        modifier = obj.modifiers.new(MODIFIER_NAME, 'NODES')
        modifier.node_group = group
        modifier.show_in_editmode = True
        compat.set_modifier_input(modifier, deformer.CAGE, cage)
        stack = list(obj.modifiers)
        if earlier is not None:
            position = stack.index(earlier.modifier)
        else:
            position = stack.index(others[-1].modifier) + 1 if others else 0
        compat.move_modifier(obj, modifier, position)
        group[METADATA] = data.to_properties()
    except Exception:
        if modifier is not None:
            compat.remove_nodes_modifier(obj, modifier)
        if group is not None:
            bpy.data.node_groups.remove(group)
        attributes.remove_slots(obj.data, key)
        raise
    if earlier is not None:
        name = earlier.modifier.name
        remove(obj, [earlier])
        modifier.name = name  # the new one was "GenCoords.001" beside it: Rebind keeps the name
    return binding(obj, cage)
