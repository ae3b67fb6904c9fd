"""Commit a Bind: write a computed binding into the file (node group, the mesh's
attributes, modifier), replacing an earlier binding of the mesh to the same cage; all or
nothing, in steps (a modal Bind shows progress and takes Esc while writing)."""

import time
from dataclasses import replace

import bpy

from ..blender_io import compat
from ..bind_layout import METADATA
from ..graph import deformer, helpers
from ..steps import run_to_end, scaled
from .. import storage
from . import attributes
from .bindings import binding, bindings, remove

MODIFIER_NAME = "GenCoords"
# Of the writing's progress, the node group's share (the attributes take the rest).
WRITING_GROUP = 0.5


def write(obj, cage, result, started=None):
    """Write the computed binding into the file (:func:`steps`, to the end); returns the
    new ``Binding``."""
    return run_to_end(steps(obj, cage, result, started))


def steps(obj, cage, result, started=None):
    """Write the computed binding into the file, a generator yielding the fraction
    written and returning the new ``Binding``.

    An earlier binding of the mesh to the same cage is replaced (its place in the
    stack is kept); a binding to another cage is added after the mesh's other
    bindings (each changes nothing at rest, so they compose). On any failure, or when
    closed early (Esc), everything this call added is removed again. With ``started``
    (``time.perf_counter()`` when the artist asked for the Bind), the bind data's
    ``bind_seconds`` is the time since then, writing included: what the artist waited.
    """
    # The binding to this cage, else one whose cage is gone: Bind after picking
    # another cage replaces it.
    earlier = binding(obj, cage) or binding(obj, missing_cage=True)
    others = bindings(obj)
    data = result.data
    key = data.key
    group = modifier = None
    try:
        name = f"GenCoords: {obj.name} in {cage.name}"
        home = storage.of(data)
        group = yield from scaled(home.group_steps(name, data, result), 0.0, WRITING_GROUP)
        yield from scaled(home.write_steps(obj.data, data, result), WRITING_GROUP, 1.0 - WRITING_GROUP)
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
    except BaseException:  # a failure, or a cancel (GeneratorExit)
        if modifier is not None:
            compat.remove_nodes_modifier(obj, modifier)
        if group is not None:
            bpy.data.node_groups.remove(group)
        helpers.remove_unused_helpers()  # those this Bind made
        attributes.remove_slots(obj.data, key)
        raise
    if earlier is not None:
        name = earlier.modifier.name
        remove(obj, [earlier])
        modifier.name = name  # the new one was "GenCoords.001" beside it: Rebind keeps the name
    if started is not None:
        result.data = replace(data, bind_seconds=time.perf_counter() - started)
        group[METADATA] = result.data.to_properties()
    return binding(obj, cage)
