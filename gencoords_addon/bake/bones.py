"""Bake to bones: turn a binding into an armature that game engines and exporters know.

One bone per cage vertex, resting where that vertex was at Bind (the binding keeps the
bind-time cage) and held on its vertex by a Copy Location constraint (so the cage still
drives the rig in Blender), the coordinates as the mesh's vertex groups, and an Armature
modifier in place of the GenCoords one. Linear blend skinning with bones that only
translate and weights that sum to one is the same displacement form,
``P + sum_j w_j (C_j - R_j)`` (``core.skinning.skinning``), so keeping every weight is exact;
game engines take 4 or 8 influences per vertex, and then the largest are kept and
renormalised. Vertex groups hold weights from 0 to 1 only, so negative coordinates are
refused. The deviation reported is measured on the weights and bone positions read back
from what was written, under the standard smooth cage motion.

Exporters do not evaluate constraints (Blender's glTF exporter writes no animation for
a rig driven only by them), so the bones' motion is also keyframed over the scene's
frame range.
"""

import bpy
import numpy as np

from ...core.skinning import skinning
from ...core.storage import Storage, compact
from .. import bind_layout
from ..bind import bindings as bindings_module
from ..blender_io import compat, mesh_arrays, mesh_io
from ..enums import is_green, kind_label
from ..errors import BakeError

BONE_PREFIX = "GenCoords "
BAKE_INFO = bind_layout.BAKE_INFO  # the rig's armature's ID property: the bake's figures
# Bones on their cage vertices (float32 positions, constraint evaluation), per cage diagonal.
FOLLOW_TOLERANCE = 1e-5


def bone_names(count):
    return [f"{BONE_PREFIX}{j}" for j in range(count)]


def negative_message(obj, found, count, smallest):
    kind = kind_label(found.data.kind)
    compact_note = (" (this binding uses Compact storage, which reproduces coordinates "
                    "approximately: Storage Exact may help)"
                    if found.data.storage == Storage.COMPACT else "")
    return (f"Cannot bake '{obj.name}' to bones: {count} of its {kind} coordinates are "
            f"negative (down to {smallest:.3g}){compact_note}, and vertex-group weights "
            "cannot be (Blender clamps them to 0 to 1). Bind with Type Wachspress, or Mean "
            "Value with a convex cage (Make Cage makes one): these are never negative "
            "inside the cage; then Bake to Bones")


def evaluated_world_positions(obj, depsgraph):
    """``obj``'s evaluated vertices in world space ((n, 3) float64)."""
    with mesh_io.evaluated_mesh(obj, depsgraph) as mesh:
        local = mesh_io.read_positions(mesh).astype(np.float64)
    world = np.array(obj.evaluated_get(depsgraph).matrix_world, dtype=np.float64)
    return local @ world[:3, :3].T + world[:3, 3]


def _mode_set(rig, mode):
    # object.mode_set acts on the context's object (which a script's temp_override may
    # have made the mesh) and Edit Mode's toggle on the view layer's active object: both
    # are the rig for the call, the caller's active object afterwards.
    view_layer = bpy.context.view_layer
    previous = view_layer.objects.active
    view_layer.objects.active = rig
    try:
        with bpy.context.temp_override(object=rig, active_object=rig, selected_objects=[rig],
                                       selected_editable_objects=[rig]):
            bpy.ops.object.mode_set(mode=mode)
    finally:
        view_layer.objects.active = previous


# Blender deletes bones of (near) zero length on leaving Edit Mode (4.2 did so for the bones
# of a 1e-6 cage): each bone is at least 1e-5 long, and 16 float32 steps of where it is (a
# 3e-3 cage 3e4 from the origin, where a step is 2e-3, lost every bone and its mesh went to
# the origin). A bone's length changes nothing here: the bones translate.
MIN_BONE_LENGTH, MIN_BONE_STEPS = 1e-5, 16


def add_bones(rig, names, heads, size):
    """Give the armature of ``rig`` a bone resting at each of ``heads``."""
    _mode_set(rig, 'EDIT')
    try:
        for name, head in zip(names, heads):
            bone = rig.data.edit_bones.new(name)
            step = float(np.spacing(np.float32(np.abs(np.asarray(head, dtype=np.float64)).max())))
            bone.head, bone.tail = head, head + (0.0, 0.0, max(0.05 * size, MIN_BONE_LENGTH, MIN_BONE_STEPS * step))
    finally:
        _mode_set(rig, 'OBJECT')


def cage_motion(cage, context):
    """The evaluated cage in world space at each frame of the scene's range.

    Returns
    -------
    frames : (f,) int
    positions : (f, n, 3) float64
    """
    scene = context.scene
    frames = np.arange(scene.frame_start, scene.frame_end + 1)
    current = scene.frame_current, scene.frame_subframe
    positions = []
    try:
        for frame in frames:
            scene.frame_set(int(frame))
            positions.append(evaluated_world_positions(cage, context.evaluated_depsgraph_get()))
    finally:
        scene.frame_set(current[0], subframe=current[1])
    return frames, np.array(positions)


def keyframe_motion(rig, names, frames, positions):
    """Keyframe every bone at ``positions`` (``cage_motion``, the rig's space: the rig sits
    at the world origin) at ``frames``, as the Copy Location constraints place it:
    exporters read keyframes, not constraints."""
    for name in names:  # creates the action and its curves, in all versions
        rig.pose.bones[name].keyframe_insert("location", frame=float(frames[0]), group=name)
    rig.animation_data.action.name = f"{rig.name} cage motion"
    curves = {(curve.data_path, curve.array_index): curve
              for curve in compat.action_fcurves(rig)}
    for j, name in enumerate(names):
        bone = rig.data.bones[name]
        axes = np.array(bone.matrix_local.to_3x3(), dtype=np.float64)
        # A pose bone's location is in its rest frame: head now = head + axes @ location.
        location = (positions[:, j] - np.array(bone.head_local)) @ axes
        for axis in range(3):
            key_linearly(curves[(f'pose.bones["{name}"].location', axis)], frames, location[:, axis])
    first_in_exports(rig)


def first_in_exports(rig):
    """Also lay the rig's action as a strip of an NLA track of its own name: Blender's FBX
    exporter, with its defaults (NLA Strips and All Actions), writes NLA strips first, then
    every action whose curves resolve on an object applied to it (the cage's own action
    applied to the rig among them); readers (ufbx, three.js) play the first take. Blender
    and the glTF exporter play and write the action once."""
    action = rig.animation_data.action
    track = rig.animation_data.nla_tracks.new()
    track.name = action.name
    track.strips.new(action.name, int(action.frame_range[0]), action)


def key_linearly(curve, frames, values):
    """Key ``curve`` (holding one key, at ``frames[0]``) at ``frames`` ((f,)) to ``values``
    ((f,)), LINEAR between keys: what game engines play between samples (glTF's and FBX's
    readers interpolate linearly), so Blender's preview at half frames is theirs."""
    curve.keyframe_points.add(len(frames) - 1)
    curve.keyframe_points.foreach_set("co", np.column_stack([frames, values]).astype(np.float32).ravel())
    for point in curve.keyframe_points:
        point.interpolation = 'LINEAR'
    curve.update()


def bake(obj, context, max_influences=0, keyframes=True):
    """Replace the (first) binding of ``obj`` by an armature; returns (rig, deviation).

    ``deviation`` is the largest distance, per cage diagonal, between the skinned and the
    exact deformation under the standard smooth cage motion, measured with the weights
    and bone heads read back from the mesh's vertex groups and the rig.
    """
    found, coordinates, weights, rest = _bake_inputs(obj, max_influences)
    cage = found.cage
    names = bone_names(len(rest))
    # Read before anything is written: each frame then costs what playback does.
    motion = cage_motion(cage, context) if keyframes else None
    if motion is not None and not np.isfinite(motion[1]).all():
        frame = int(motion[0][np.flatnonzero(~np.isfinite(motion[1]).all(axis=(1, 2)))[0]])
        raise BakeError(
            f"Cannot bake '{obj.name}' to bones: the cage '{cage.name}' has undefined (NaN or "
            f"infinite) positions at frame {frame}: fix its animation, or untick Keyframe Cage Motion")

    # All or nothing: what this adds is removed again on a failure, and the binding goes
    # last (its removal is all or nothing itself).
    had = {"cage": {g.name for g in cage.vertex_groups}, "mesh": {g.name for g in obj.vertex_groups}}
    parent = obj.parent
    rig = skin = None
    try:
        for j, name in enumerate(names):  # the bones' targets: one cage vertex each
            group = cage.vertex_groups.get(name) or cage.vertex_groups.new(name=name)
            group.add([j], 1.0, 'REPLACE')
        rig = bpy.data.objects.new(f"{obj.name} cage rig",
                                   bpy.data.armatures.new(f"{obj.name} cage rig"))
        for collection in obj.users_collection:
            collection.objects.link(rig)
        _add_following_bones(rig, cage, names, rest)
        following = _following_error(rig, cage, names, rest, context)
        mesh_arrays.write_weights(obj, names, weights)
        position = list(obj.modifiers).index(found.modifier)
        skin = obj.modifiers.new("Armature", 'ARMATURE')
        skin.object = rig
        compat.move_modifier(obj, skin, position)
        if obj.parent is None:  # exporters (glTF) expect a skinned mesh under its armature
            obj.parent = rig  # the rig sits at the world origin: the mesh does not move
        if motion is not None:
            keyframe_motion(rig, names, *motion)

        written = mesh_arrays.read_weights(obj, names)
        heads = np.array([rig.data.bones[name].head_local for name in names], dtype=np.float64)
        deviation = skinning.deviation(coordinates, rest, written, heads,
                                       compact.smooth_test_motion(rest))
        rig.data[BAKE_INFO] = {"deviation": deviation, "following": following, "max_influences": int(max_influences),
                               "vertices_over_4": int(np.count_nonzero(
                                   np.count_nonzero(written, axis=1) > 4)),
                               **({"frames": [int(motion[0][0]), int(motion[0][-1])]}
                                  if motion is not None else {})}
        bindings_module.remove(obj, [found])
    except Exception:
        obj.parent = parent
        if skin is not None:
            obj.modifiers.remove(skin)
        _remove_rig(rig)
        for owner, kept in ((cage, had["cage"]), (obj, had["mesh"])):
            for group in [g for g in owner.vertex_groups if g.name in names and g.name not in kept]:
                owner.vertex_groups.remove(group)
        raise
    return rig, deviation


def _bake_inputs(obj, max_influences):
    """The binding of ``obj`` a bake replaces, its coordinates ((k, n) float32), the
    bone weights ((k, n), truncated to ``max_influences``) and the rest cage ((n, 3)
    float64, world space as seen from the mesh now); BakeError when it cannot be baked."""
    found = bindings_module.binding(obj)
    if found.cage is None:
        raise BakeError("The binding's cage is missing: Bind again first")
    # Whatever stops the deformer (a NaN cage vertex, changed counts) would bake a rig
    # that does something else: the rig would follow what the binding does not.
    problem = bindings_module.deformation_problem(obj, found)
    if problem is not None:
        raise BakeError(f"Cannot bake '{obj.name}' to bones: {problem}")
    if is_green(found.data.kind):
        raise BakeError(
            f"Cannot bake '{obj.name}' to bones: it is bound with Green coordinates, which also "
            "follow the cage's face normals and stretch, and bones (linear blend skinning) "
            "cannot: Bind with another Type (Mean Value, say), then Bake to Bones")
    bound, own = found.data.cage_vertex_count, len(found.cage.data.vertices)
    if own != bound:
        raise BakeError(
            f"Cannot bake '{obj.name}' to bones: the cage '{found.cage.name}' has {bound} vertices "
            f"with its modifiers and {own} without: bones follow the cage's own vertices. Apply "
            "the cage's modifiers (or remove them), Bind again, then Bake to Bones")
    coordinates = found.coordinates(obj.data)
    rest_local = found.rest_cage
    if coordinates is None or rest_local is None \
            or len(obj.data.vertices) != found.data.mesh_vertex_count:
        raise BakeError(f"The bind data of '{obj.name}' is missing or no "
                                        "longer matches its vertices: Bind again")
    # On every coordinate, before Max Influences drops the smallest: a truncation would
    # otherwise drop negatives silently, and the kept weights would not be the binding.
    negative, smallest = skinning.negative_weights(coordinates)
    if negative:
        raise BakeError(negative_message(obj, found, negative, smallest))
    weights = skinning.truncate(coordinates, max_influences, found.rest_cage.astype(np.float64))
    # The rig sits at the world origin: the bones rest where the bind-time cage is seen
    # from the mesh now (the deformer reads the cage relative to the mesh too).
    world = np.array(obj.matrix_world, dtype=np.float64)
    rest = rest_local.astype(np.float64) @ world[:3, :3].T + world[:3, 3]
    return found, coordinates, weights, rest


def _add_following_bones(rig, cage, names, rest):
    """Bones ``names`` in ``rig`` at ``rest`` ((n, 3) float64), each following its cage
    vertex (the cage's vertex group of its name)."""
    add_bones(rig, names, rest, float(np.linalg.norm(np.ptp(rest, axis=0))))
    for name in names:
        follow = rig.pose.bones[name].constraints.new('COPY_LOCATION')
        follow.target, follow.subtarget = cage, name


def _following_error(rig, cage, names, rest, context):
    """How far (per cage diagonal) the rig's evaluated bones are from the evaluated cage
    vertices the binding follows; BakeError beyond FOLLOW_TOLERANCE (the rig would move
    the mesh otherwise than the binding did)."""
    depsgraph = context.evaluated_depsgraph_get()
    evaluated = rig.evaluated_get(depsgraph)
    world = np.array(evaluated.matrix_world, dtype=np.float64)
    heads = np.array([evaluated.pose.bones[name].head for name in names], dtype=np.float64)
    heads = heads @ world[:3, :3].T + world[:3, 3]
    cage_now = evaluated_world_positions(cage, depsgraph)
    diagonal = float(np.linalg.norm(np.ptp(rest, axis=0)))
    error = float(np.linalg.norm(heads - cage_now, axis=1).max()) / diagonal
    if not error <= FOLLOW_TOLERANCE:
        raise BakeError(
            f"Cannot bake to bones: the bones of '{rig.name}' would sit {error:.2g} of the cage's size away from "
            f"the cage vertices the binding follows (modifiers or constraints on '{cage.name}'?): "
            "apply them, Bind again, then Bake to Bones")
    return error


def let_go_of_deleted_cage(rig):
    """A baked rig whose cage the artist deleted lets go of it, as a binding does
    (``bindings.follow_cage``): its bones' Copy Location constraints lose their target, so
    the bones rest (or play their keyframes) now, as they do once the file is saved and
    reopened (a deleted object is not written). Returns whether it let go."""
    if rig.type != 'ARMATURE' or rig.pose is None or BAKE_INFO not in rig.data:
        return False
    held = [constraint for bone in rig.pose.bones for constraint in bone.constraints
            if constraint.type == 'COPY_LOCATION' and bindings_module.is_deleted(constraint.target)]
    for constraint in held:
        constraint.target = None
    return bool(held)


def _remove_rig(rig):
    """Delete ``rig`` (None: nothing), its armature and its action."""
    if rig is None:
        return
    armature, action = rig.data, rig.animation_data and rig.animation_data.action
    bpy.data.objects.remove(rig)
    bpy.data.armatures.remove(armature)
    if action is not None:
        bpy.data.actions.remove(action)
