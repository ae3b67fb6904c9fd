"""Bake to bones: turn a binding into an armature that game engines and exporters know.

One bone per cage vertex, held on its vertex by a Copy Location constraint (so the cage
still drives the rig), the coordinates as the mesh's vertex groups, and an Armature
modifier in place of the GenCoords one. Linear blend skinning with bones that only
translate and weights that sum to one is the same displacement form,
``P + sum_j w_j (C_j - R_j)``, so keeping every weight is exact; game engines take 4 or
8 influences per vertex, and then the largest are kept and renormalised, and the
deviation for the standard smooth cage motion is measured and reported.
"""

import bmesh
import bpy
import numpy as np

from ..core import compact
from . import binding as bindings_module

BONE_PREFIX = "GenCoords "


def truncate(coordinates, max_influences):
    """The ``max_influences`` largest weights of each row, renormalised (0: all kept).

    Parameters
    ----------
    coordinates : (k, n) float
    max_influences : int

    Returns
    -------
    weights : (k, n) float64
        Zero outside each row's kept columns; rows sum to one.
    """
    weights = np.asarray(coordinates, dtype=np.float64)
    if not max_influences or max_influences >= weights.shape[1]:
        return weights.copy()
    kept = np.argpartition(-weights, max_influences - 1, axis=1)[:, :max_influences]
    rows = np.arange(len(weights))[:, None]
    truncated = np.zeros_like(weights)
    truncated[rows, kept] = weights[rows, kept]
    return truncated / truncated.sum(axis=1, keepdims=True)


def bake(obj, context, max_influences=0):
    """Replace the (first) binding of ``obj`` by an armature; returns (rig, deviation).

    ``deviation`` is the largest distance, per cage diagonal, between the baked and the
    exact deformation under the standard smooth cage motion (0 when every weight is kept).
    """
    found = bindings_module.binding(obj)
    cage = found.cage
    if cage is None:
        raise bindings_module.BindError("The binding's cage is missing: Bind again first")
    coordinates = found.coordinates(obj.data)
    weights = truncate(coordinates, max_influences)
    cage_world = np.array(cage.matrix_world, dtype=np.float64)
    rest_cage = np.array([cage_world[:3, :3] @ v.co + cage_world[:3, 3]
                          for v in cage.data.vertices])
    moved = compact.smooth_test_motion(rest_cage)
    deviation = compact.deviation(coordinates, weights, np.eye(len(rest_cage)), rest_cage, moved)
    size = float(np.linalg.norm(np.ptp(rest_cage, axis=0)))

    names = [f"{BONE_PREFIX}{j}" for j in range(len(rest_cage))]
    # All or nothing: what this adds is removed again on a failure, and the binding goes
    # last (its removal is all or nothing itself).
    had = {"cage": {g.name for g in cage.vertex_groups}, "mesh": {g.name for g in obj.vertex_groups}}
    previous, parent = context.view_layer.objects.active, obj.parent
    armature = rig = skin = None
    try:
        for j, name in enumerate(names):  # the bones' targets: one cage vertex each
            group = cage.vertex_groups.get(name) or cage.vertex_groups.new(name=name)
            group.add([j], 1.0, 'REPLACE')
        armature = bpy.data.armatures.new(f"{obj.name} cage rig")
        rig = bpy.data.objects.new(f"{obj.name} cage rig", armature)
        for collection in obj.users_collection:
            collection.objects.link(rig)
        context.view_layer.objects.active = rig
        bpy.ops.object.mode_set(mode='EDIT')
        for name, head in zip(names, rest_cage):
            bone = armature.edit_bones.new(name)
            bone.head, bone.tail = head, head + (0.0, 0.0, 0.05 * size)
        bpy.ops.object.mode_set(mode='OBJECT')
        for name in names:
            follow = rig.pose.bones[name].constraints.new('COPY_LOCATION')
            follow.target, follow.subtarget = cage, name

        bm = bmesh.new()
        bm.from_mesh(obj.data)
        layer = bm.verts.layers.deform.verify()
        groups = [obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name) for name in names]
        for vert, row in zip(bm.verts, weights):
            for j in np.flatnonzero(row):
                vert[layer][groups[j].index] = float(row[j])
        bm.to_mesh(obj.data)
        bm.free()

        position = list(obj.modifiers).index(found.modifier)
        skin = obj.modifiers.new("Armature", 'ARMATURE')
        skin.object = rig
        obj.modifiers.move(len(obj.modifiers) - 1, position)
        if obj.parent is None:  # exporters (glTF) expect a skinned mesh under its armature
            obj.parent = rig  # the rig sits at the world origin: the mesh does not move
        bindings_module.remove(obj, [found])
    except Exception:
        obj.parent = parent
        if skin is not None:
            obj.modifiers.remove(skin)
        if rig is not None:
            if rig.mode == 'EDIT':
                bpy.ops.object.mode_set(mode='OBJECT')
            bpy.data.objects.remove(rig)
        if armature is not None:
            bpy.data.armatures.remove(armature)
        for owner, kept in ((cage, had["cage"]), (obj, had["mesh"])):
            for group in [g for g in owner.vertex_groups if g.name in names and g.name not in kept]:
                owner.vertex_groups.remove(group)
        raise
    finally:
        context.view_layer.objects.active = previous
    return rig, deviation
