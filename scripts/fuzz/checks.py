"""What the fuzz reads from the file and the invariants it checks after every step.

Snapshots are plain values: ``file_state()`` digests every object, mesh (positions and
every attribute, bitwise) and binding, so "a refusal changes nothing" and "reload is
unchanged" are equalities; ``world_positions()`` is every mesh object's evaluated mesh in
world space (float64), for "no NaN", "rest is unchanged" and "a translated cage
translates the mesh".
"""

import hashlib
import traceback

import bpy
import numpy as np

from scripts.common import session
from scripts.common.blender_objects import arrays

METADATA = "gencoords"  # bind_layout.METADATA: a binding's node group carries it
# What Show Coordinate writes; Unbind's bitwise promise is about the bind data.
FIELD_NAMES = ("GenCoords Field", "_gencoords_field_range")
# Attribute data types -> (the item's property, numbers per item, numpy dtype).
ATTRIBUTE_LAYOUT = {
    'FLOAT': ("value", 1, np.float32), 'INT': ("value", 1, np.int32), 'INT8': ("value", 1, np.int8),
    'BOOLEAN': ("value", 1, bool), 'FLOAT_VECTOR': ("vector", 3, np.float32),
    'FLOAT2': ("vector", 2, np.float32), 'FLOAT_COLOR': ("color", 4, np.float32),
    'BYTE_COLOR': ("color", 4, np.float32), 'INT32_2D': ("value", 2, np.int32),
    'QUATERNION': ("value", 4, np.float32),
}


class Violation(Exception):
    """An invariant failed: ``invariant`` names it, the message says how."""

    def __init__(self, invariant, message):
        super().__init__(f"{invariant}: {message}")
        self.invariant = invariant


def _digest(*arrays_or_bytes):
    hasher = hashlib.sha1()
    for item in arrays_or_bytes:
        hasher.update(item if isinstance(item, bytes) else np.ascontiguousarray(item).tobytes())
    return hasher.hexdigest()[:16]


def attribute_digest(attribute):
    layout = ATTRIBUTE_LAYOUT.get(attribute.data_type)
    if layout is None:
        return attribute.data_type
    name, width, dtype = layout
    flat = np.empty(len(attribute.data) * width, dtype=dtype)
    attribute.data.foreach_get(name, flat)
    return f"{attribute.data_type}/{attribute.domain}/{_digest(flat)}"


def mesh_digest(mesh, skip=()):
    """Everything of a mesh's data, bitwise: attributes (positions, topology, bind data),
    shape keys and custom properties; names in ``skip`` left out."""
    state = {f"attribute {a.name}": attribute_digest(a) for a in mesh.attributes if a.name not in skip}
    for key in (mesh.shape_keys.key_blocks if mesh.shape_keys else ()):
        flat = np.empty(len(key.data) * 3, dtype=np.float32)
        key.data.foreach_get("co", flat)
        state[f"shape key {key.name}"] = f"{_digest(flat)} {key.value!r}"
    for name in mesh.keys():
        if name not in skip:
            state[f"property {name}"] = repr(mesh[name])
    return state


def _object_state(obj):
    state = {"type": obj.type, "parent": obj.parent.name if obj.parent else None,
             "matrix": _digest(np.array(obj.matrix_world, dtype=np.float32)),
             "data": obj.data.name if obj.data else None,
             "modifiers": [(m.name, m.type, getattr(getattr(m, "node_group", None), "name", None))
                           for m in obj.modifiers],
             "vertex_groups": [g.name for g in obj.vertex_groups],
             "collections": sorted(c.name for c in obj.users_collection)}
    settings = getattr(obj, "gencoords", None)
    if settings is not None:
        state["settings"] = {name: (value.name if isinstance(value, bpy.types.ID) else value)
                             for name in ("cage", "kind", "outside", "storage", "sparse_size", "field_vertex")
                             for value in [getattr(settings, name)]}
    return state


def file_state(saved_only=False):
    """Every object, mesh, binding node group and datablock count of the file, as plain
    values; with ``saved_only``, only what a save keeps (objects in a scene, their meshes,
    node groups with users)."""
    objects = [o for o in bpy.data.objects if o.users_collection or not saved_only]
    meshes = [m for m in bpy.data.meshes if not saved_only or any(o.data == m for o in objects)]
    groups = [g for g in bpy.data.node_groups if g.users or not saved_only]
    counts = {name: len(getattr(bpy.data, name)) for name in ("armatures", "actions", "collections")}
    counts.update(objects=len(objects), meshes=len(meshes), node_groups=len(groups))
    return {
        "objects": {obj.name: _object_state(obj) for obj in objects},
        "meshes": {mesh.name: mesh_digest(mesh) for mesh in meshes},
        "bindings": {group.name: repr(group[METADATA].to_dict()) for group in groups if METADATA in group},
        "counts": counts if not saved_only else {"objects": len(objects), "meshes": len(meshes)},
    }


def differences(before, after, path=""):
    """Lines saying where two ``file_state`` values differ (empty: equal)."""
    if isinstance(before, dict) and isinstance(after, dict):
        lines = []
        for key in sorted(set(before) | set(after), key=str):
            if key not in after:
                lines.append(f"{path}/{key} removed")
            elif key not in before:
                lines.append(f"{path}/{key} added")
            else:
                lines += differences(before[key], after[key], f"{path}/{key}")
        return lines
    return [] if before == after else [f"{path}: {before!r} -> {after!r}"]


def own_data_finite(obj):
    """Whether the mesh object's own vertices and shape keys are all finite (a NaN put there
    by the case itself may travel on)."""
    if not np.isfinite(arrays.read_positions(obj.data)).all():
        return False
    for key in (obj.data.shape_keys.key_blocks if obj.data.shape_keys else ()):
        flat = np.empty(len(key.data) * 3, dtype=np.float32)
        key.data.foreach_get("co", flat)
        if not np.isfinite(flat).all():
            return False
    return True


def world_positions():
    """Each mesh object's evaluated vertices in world space ((k, 3) float64), by name."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    found = {}
    for obj in bpy.context.view_layer.objects:
        if obj.type != 'MESH':
            continue
        evaluated = obj.evaluated_get(depsgraph)
        local = arrays.read_positions(evaluated.data).astype(np.float64)
        world = np.array(evaluated.matrix_world, dtype=np.float64)
        found[obj.name] = local @ world[:3, :3].T + world[:3, 3]
    return found


def check_output(text):
    """No internal error and no traceback in what a step printed."""
    for marker in ("GenCoords internal error", "Traceback (most recent call last)"):
        if marker in text:
            start = text.index(marker)
            raise Violation("no internal error", text[max(0, start - 200):start + 1500])


RIG_CONSTRAINT = 'COPY_LOCATION'  # how a baked rig's bones follow the cage


def rig_cages(obj):
    """The cages the rigs of ``obj``'s Armature modifiers follow (Bake to Bones' rigs)."""
    return [cage for modifier in obj.modifiers if modifier.type == 'ARMATURE' for cage in rig_cages_of(modifier)]


def rig_cages_of(modifier):
    """The cage an Armature modifier's rig follows ([cage] or [])."""
    rig = modifier.object
    if rig is None or rig.pose is None:
        return []
    targets = [c.target for b in rig.pose.bones for c in b.constraints if c.type == RIG_CONSTRAINT]
    return [targets[0]] if targets and targets[0] is not None else []


def carries_a_cage_nan(obj):
    """Whether ``obj`` is deformed by a rig following a cage with a non-finite vertex (a
    NaN the case put in the cage): Bake to Bones' rig is Blender's own, and its Copy
    Location constraints carry the NaN to the bone and its vertices as any rig's would
    (the binding's deformer is what keeps a NaN cage vertex out of the mesh)."""
    return any(cage.type == 'MESH' and not np.isfinite(arrays.read_positions(cage.data)).all()
               for cage in rig_cages(obj))


def check_finite():
    """No NaN or infinity in an evaluated mesh whose own data is finite."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for obj in bpy.context.view_layer.objects:
        if obj.type != 'MESH' or not own_data_finite(obj) or carries_a_cage_nan(obj):
            continue
        positions = arrays.read_positions(obj.evaluated_get(depsgraph).data)
        bad = np.flatnonzero(~np.isfinite(positions).all(axis=1))
        if len(bad):
            raise Violation("no NaN", f"'{obj.name}' evaluates {len(bad)} of {len(positions)} "
                                      f"vertices to NaN or infinity (first {bad[0]})")


def check_panel():
    """The panel's status lines (what the artist reads; ``binding_results`` for scripts) can
    be drawn for every mesh object."""
    status, api = session.addon_module("ui.status"), session.addon_module("api")
    for obj in bpy.context.view_layer.objects:
        try:
            status.status_lines(obj)
            api.binding_results(obj)
        except Exception:
            raise Violation("the panel draws", f"'{obj.name}': {traceback.format_exc()}") from None


def check_unchanged(before, after, what):
    lines = differences(before, after)
    if lines:
        raise Violation(what, "; ".join(lines[:8]) + (f" (+{len(lines) - 8} more)" if len(lines) > 8 else ""))


def tolerance(*position_sets, steps=64):
    """Float32 rounding of the positions involved, with room for the arithmetic (``steps``
    float32 epsilons of their largest coordinate)."""
    extent = max((float(np.abs(p[np.isfinite(p)]).max(initial=0.0)) for p in position_sets), default=0.0)
    return steps * np.finfo(np.float32).eps * extent


def size_of(positions):
    finite = positions[np.isfinite(positions).all(axis=1)]
    return float(np.linalg.norm(np.ptp(finite, axis=0))) if len(finite) else 0.0


# A cage vertex read in float32 is off by up to an epsilon of its coordinate; the mesh
# moves by a combination of them whose weights' magnitudes sum to 8 at most, or else
# jitter within 1e-4 of the cage's size (Bind refuses more: ROUNDING_AMPLIFICATION).
CAGE_ROUNDING = 8


def check_moved(names, before, after, shift, scale, what, cage=None):
    """Objects ``names`` moved by ``shift`` ((3,), world) between two ``world_positions``,
    to 1e-4 of ``scale`` (the cage's size) beyond float32 rounding: of their positions, and
    of the ``cage``'s world positions (k, 3) as each object's deformer reads them, in the
    object's local space (a cage far from the object's origin is rounded there: 0.016 at
    1.7e5, as with Blender's Mesh Deform)."""
    for name in names:
        if name not in before or name not in after or before[name].shape != after[name].shape:
            continue
        if not np.isfinite(before[name]).all():
            continue
        error = np.abs(after[name] - before[name] - shift).max(initial=0.0)
        allowed = 1e-4 * scale + tolerance(before[name], after[name])
        if cage is not None:
            origin = np.array(bpy.data.objects[name].matrix_world, dtype=np.float64)[:3, 3]
            allowed += tolerance(cage - origin, steps=CAGE_ROUNDING)
        if not error <= allowed:
            raise Violation(what, f"'{name}' is off by {error:.3g} (allowed {allowed:.3g}, cage "
                                  f"size {scale:.3g}, moved by {np.linalg.norm(shift):.3g})")
