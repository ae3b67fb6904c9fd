"""Bake to Bones, through the doors people use: a pipeline script's temp_override, the
GUI's invoke path and menus, and a game developer's glTF reader (here: our own numpy
skinning of the exported file, and the Khronos glTF-Validator)."""

import importlib
import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Matrix

from fresh_process import PACKAGE, REPO, report_of, run_blender_script
from scene_helpers import (make_active, add_cube_cage, add_icosphere_cage, add_sphere, bind, evaluated_positions,
                           mesh_state, read_positions, write_positions, write_shape_key)

VALIDATOR = REPO / "tests" / "tools" / "node_modules" / "gltf-validator"


def apply_matrix(matrix, points):
    affine = np.array(matrix)
    return points @ affine[:3, :3].T + affine[:3, 3]


def coordinates_of(gc, obj):
    return gc.binding.binding(obj).coordinates(obj.data).astype(np.float64)


def world_positions(obj):
    return apply_matrix(obj.matrix_world, evaluated_positions(obj).astype(np.float64))


def diagonal_of(cage):
    rest = read_positions(cage.data).astype(np.float64)
    return np.linalg.norm(np.ptp(rest, axis=0))


def bake_info(obj):
    return obj.parent.data["gencoords_bake"].to_dict()


def animate_cage(gc, cage, last_frame=10):
    """A shape key (the standard smooth motion, not affine) and a turn of the cage object,
    keyed from frame 1 to ``last_frame``; the scene plays frames 1 to ``last_frame``."""
    rest = read_positions(cage.data).astype(np.float64)
    cage.shape_key_add(name="Basis")
    bent = cage.shape_key_add(name="Bent")
    write_shape_key(bent, gc.core.storage.deviations.smooth_test_motion(rest))
    for frame, value, turn in ((1, 0.0, 0.0), (last_frame, 1.0, 0.4)):
        bent.value = value
        bent.keyframe_insert("value", frame=frame)
        cage.rotation_euler = (0.0, turn, 0.5 * turn)
        cage.keyframe_insert("rotation_euler", frame=frame)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, last_frame
    scene.frame_set(1)


def posed_scene(gc):
    """A mesh turned and moved inside a moved cage, bound at frame 1 with the cage
    animated (so the rig's space, the mesh's and the cage's all differ)."""
    cage = add_icosphere_cage()
    cage.location = (0.1, -0.05, 0.0)
    obj = add_sphere(location=(0.05, 0.1, 0.0))
    obj.rotation_euler = (0.3, 0.0, 0.7)
    bpy.context.view_layer.update()
    animate_cage(gc, cage)
    assert bind(obj, cage) == {'FINISHED'}
    return obj, cage


def binding_motion(obj, frames):
    """The bound mesh's world positions at ``frames``, as the binding deforms it."""
    scene = bpy.context.scene
    current = scene.frame_current
    positions = {}
    for frame in frames:
        scene.frame_set(frame)
        positions[frame] = world_positions(obj)
    scene.frame_set(current)
    return positions


def assert_follows(obj, expected, tolerance):
    scene = bpy.context.scene
    for frame, positions in expected.items():
        scene.frame_set(frame)
        gap = np.linalg.norm(world_positions(obj) - positions, axis=1).max()
        assert gap < tolerance, f"frame {frame}: {gap}"


@pytest.mark.parametrize("influences", [0, 4])
def test_bake_to_bones_deforms_like_the_binding(gc, influences, capfd):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    coordinates = coordinates_of(gc, obj)
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones(max_influences=influences) == {'FINISHED'}
    assert [m.type for m in obj.modifiers] == ['ARMATURE'] and not gc.binding.bindings(obj)
    rest_cage = read_positions(cage.data).astype(np.float64)
    moved = gc.core.storage.deviations.smooth_test_motion(rest_cage)
    write_positions(cage.data, moved)
    exact = read_positions(obj.data) + coordinates @ (moved - rest_cage)
    gap = np.linalg.norm(evaluated_positions(obj) - exact, axis=1).max()
    diagonal = np.linalg.norm(np.ptp(rest_cage, axis=0))
    reported = bake_info(obj)["deviation"]
    assert f"to 'Mesh cage rig' (12 bones, keyframed over frames 1 to 250): deviation " \
           f"{reported:.2e} of the cage size" in capfd.readouterr().out
    over = bake_info(obj)["vertices_over_4"]
    assert over == int(np.count_nonzero(np.count_nonzero(coordinates, axis=1) > 4)
                       if influences == 0 else 0)
    if influences == 0:
        assert gap < 1e-5 * diagonal and reported < 1e-6 and over > 0
    else:
        # The largest weights, reweighted to place each vertex where the binding does.
        truncated = gc.core.skinning.skinning.truncate(coordinates, influences, rest_cage)
        expected = gc.core.storage.deviations.deviation(coordinates, truncated, np.eye(12), rest_cage, moved)
        assert gap / diagonal == pytest.approx(expected, rel=1e-3, abs=1e-6)
        plain = gc.core.skinning.skinning.truncate(coordinates, influences)
        assert expected < gc.core.storage.deviations.deviation(coordinates, plain, np.eye(12), rest_cage, moved)
        assert reported == pytest.approx(gap / diagonal, rel=1e-3, abs=1e-6)
        assert (np.count_nonzero(truncated, axis=1) <= 4).all()


def test_bake_to_bones_uses_the_bind_time_cage_after_a_cage_edit(gc):
    """Issue 19 item 1: the cage edited after Bind; the rig rests on the cage as it was."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    rest_cage = read_positions(cage.data).astype(np.float64)
    write_positions(cage.data, gc.core.storage.deviations.smooth_test_motion(rest_cage))
    bound = world_positions(obj)
    assert np.linalg.norm(bound - read_positions(obj.data), axis=1).max() > 0.1  # it moved
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones() == {'FINISHED'}
    rig = obj.parent
    heads = np.array([bone.head_local for bone in rig.data.bones])
    np.testing.assert_allclose(heads, rest_cage, atol=1e-6)
    diagonal = diagonal_of(cage)
    assert np.linalg.norm(world_positions(obj) - bound, axis=1).max() < 1e-5 * diagonal
    assert bake_info(obj)["deviation"] < 1e-6


def test_bake_to_bones_at_a_later_frame_follows_the_animation_like_the_binding(gc):
    """Issue 19 items 1 and 7: baked at frame 10 of a cage animation, the rig deforms the
    mesh like the binding at every frame, by its constraints and by its keyframes alone."""
    obj, cage = posed_scene(gc)
    expected = binding_motion(obj, [1, 4, 10])
    bpy.context.scene.frame_set(10)
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones() == {'FINISHED'}
    rig, tolerance = obj.parent, 1e-5 * diagonal_of(cage)
    assert bake_info(obj)["frames"] == [1, 10] and rig.animation_data.action is not None
    assert_follows(obj, expected, tolerance)
    for bone in rig.pose.bones:  # what exporters see: the keyframes
        bone.constraints[0].mute = True
    assert_follows(obj, expected, tolerance)


def test_bake_to_bones_from_a_script_in_a_temp_override(gc):
    """Issue 19 item 5: a pipeline script overrides the context to the mesh while the
    view layer's active object is another one."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    coordinates = coordinates_of(gc, obj)
    make_active(cage)  # the view layer's active object is not the mesh
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bake_bones(max_influences=0) == {'FINISHED'}
    assert obj.parent is not None and obj.parent.type == 'ARMATURE'
    assert obj.mode == 'OBJECT' and obj.parent.mode == 'OBJECT'
    rest_cage = read_positions(cage.data).astype(np.float64)
    moved = gc.core.storage.deviations.smooth_test_motion(rest_cage)
    write_positions(cage.data, moved)
    exact = read_positions(obj.data) + coordinates @ (moved - rest_cage)
    gap = np.linalg.norm(evaluated_positions(obj) - exact, axis=1).max()
    assert gap < 1e-5 * np.linalg.norm(np.ptp(rest_cage, axis=0))


def test_bake_to_bones_keeps_every_bone_of_a_small_cage_far_from_the_origin(gc):
    """Fuzz seed 629: a 6 mm cage whose vertices lie 30 km out (in its data), where
    float32 steps are 2 mm, had bones of 0.5 mm, their tails rounded onto their heads (4.2
    deletes such bones), and the mesh went to the origin. Baked from a script, every cage
    vertex keeps a bone, and the mesh stays and follows."""
    cage, obj = add_cube_cage(size=0.006), add_sphere(radius=0.0015)
    for each in (cage, obj):
        write_positions(each.data, read_positions(each.data) + np.float32(3.0e4))
    bind(obj, cage)
    before = world_positions(obj)
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bake_bones(max_influences=0) == {'FINISHED'}
    bones = obj.parent.data.bones
    assert len(bones) == len(cage.data.vertices) and min(bone.length for bone in bones) > 0.0
    step = np.spacing(np.float32(3.0e4))  # each vertex is rounded where it is, 2e-3
    assert np.abs(world_positions(obj) - before).max() <= 2 * step
    cage.location.z += 0.5
    bpy.context.view_layer.update()
    assert np.abs(world_positions(obj) - before - (0.0, 0.0, 0.5)).max() <= 2 * step


def test_bake_to_bones_refuses_negative_coordinates_and_changes_nothing(gc):
    """Issue 19 item 2: vertex groups clamp weights to [0, 1]; discrete harmonic
    coordinates are negative in places."""
    cage = add_icosphere_cage(radius=1.3)
    obj = add_sphere()
    bind(obj, cage, kind="DISCRETE_HARMONIC")
    coordinates = coordinates_of(gc, obj)
    count = int(np.count_nonzero(coordinates < -gc.core.skinning.skinning.NEGATIVE_TOLERANCE))
    assert count > 0
    state, objects = mesh_state(obj), set(bpy.data.objects.keys())
    make_active(obj)
    with pytest.raises(RuntimeError, match=rf"{count} of its Discrete Harmonic coordinates are "
                                           rf"negative \(down to -.*Wachspress"):
        bpy.ops.object.gencoords_bake_bones()
    assert set(bpy.data.objects.keys()) == objects and gc.binding.binding(obj) is not None
    assert not obj.vertex_groups and not cage.vertex_groups and obj.parent is None
    assert mesh_state(obj)[1] == state[1]


@pytest.mark.parametrize("max_influences", [1, 4])
def test_bake_to_bones_refuses_negative_coordinates_with_max_influences(gc, max_influences):
    """Issue 19 item 2: Max Influences keeps the largest weights, which would drop the
    negative ones silently; the refusal looks at every coordinate, as with all kept."""
    cage = add_icosphere_cage(radius=1.3)
    obj = add_sphere()
    bind(obj, cage, kind="DISCRETE_HARMONIC")
    coordinates = coordinates_of(gc, obj)
    tools = gc.core.skinning.skinning
    count = int(np.count_nonzero(coordinates < -tools.NEGATIVE_TOLERANCE))
    assert count > 0 and tools.negative_weights(tools.truncate(coordinates, max_influences))[0] == 0
    state, objects = mesh_state(obj), set(bpy.data.objects.keys())
    make_active(obj)
    with pytest.raises(RuntimeError, match=rf"{count} of its Discrete Harmonic coordinates are "
                                           r"negative"):
        bpy.ops.object.gencoords_bake_bones(max_influences=max_influences)
    assert set(bpy.data.objects.keys()) == objects and gc.binding.binding(obj) is not None
    assert not obj.vertex_groups and not cage.vertex_groups and obj.parent is None
    assert mesh_state(obj)[1] == state[1]


def test_bake_to_bones_reports_the_deviation_of_the_weights_it_wrote(gc):
    """Issue 19 item 2: coordinates negative within rounding (discrete harmonic in this
    cage, down to about -2e-6) are clamped to 0 by the vertex groups; the deviation
    reported is what the clamped weights give, measured here on Blender's deformation."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage, kind="DISCRETE_HARMONIC")
    coordinates = coordinates_of(gc, obj)
    assert coordinates.min() < 0.0
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones() == {'FINISHED'}
    written = np.zeros_like(coordinates)
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            written[vertex.index, int(obj.vertex_groups[element.group].name.split()[-1])] = element.weight
    assert written.min() >= 0.0 and np.abs(written - np.clip(coordinates, 0.0, None)).max() < 1e-7
    rest_cage = read_positions(cage.data).astype(np.float64)
    moved = gc.core.storage.deviations.smooth_test_motion(rest_cage)
    write_positions(cage.data, moved)
    exact = read_positions(obj.data) + coordinates @ (moved - rest_cage)
    gap = np.linalg.norm(evaluated_positions(obj) - exact, axis=1).max() / diagonal_of(cage)
    assert bake_info(obj)["deviation"] == pytest.approx(gap, rel=0.05, abs=2e-7)


def test_a_failing_bake_to_bones_changes_nothing(gc, monkeypatch):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    state, modifiers = mesh_state(obj), [m.name for m in obj.modifiers]
    objects, armatures = set(bpy.data.objects.keys()), set(bpy.data.armatures.keys())
    actions = set(bpy.data.actions.keys())

    def broken(obj, bindings):
        raise RuntimeError("injected fault")
    monkeypatch.setattr(gc.binding, "remove", broken)  # the last step of the bake
    make_active(obj)
    with pytest.raises(RuntimeError, match="injected fault"):
        bpy.ops.object.gencoords_bake_bones()
    assert set(bpy.data.objects.keys()) == objects and set(bpy.data.armatures.keys()) == armatures
    assert set(bpy.data.actions.keys()) == actions
    assert [m.name for m in obj.modifiers] == modifiers and obj.parent is None
    assert not obj.vertex_groups and not cage.vertex_groups
    assert mesh_state(obj)[1] == state[1] and gc.binding.binding(obj) is not None


def test_undo_and_redo_of_bake_to_bones(gc):
    """Ctrl+Z as in the UI (the step the UI pushes after an undoable operator is pushed
    here explicitly): the binding is back and the rig gone; Ctrl+Shift+Z bakes again."""
    preferences = bpy.context.preferences.edit
    preferences.use_global_undo, preferences.undo_steps = True, 32
    with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
        cage = add_icosphere_cage()
        obj = add_sphere()
        bind(obj, cage)
        bpy.ops.ed.undo_push(message="Bind")
        make_active(obj)
        assert bpy.ops.object.gencoords_bake_bones() == {'FINISHED'}
        bpy.ops.ed.undo_push(message="Bake to Bones")
        assert bpy.ops.ed.undo() == {'FINISHED'}
        obj = bpy.data.objects["Mesh"]  # undo rebuilds IDs
        assert gc.binding.binding(obj) is not None and obj.parent is None
        assert "Mesh cage rig" not in bpy.data.objects and not obj.vertex_groups
        assert bpy.ops.ed.redo() == {'FINISHED'}
        obj = bpy.data.objects["Mesh"]
        assert gc.binding.binding(obj) is None and obj.parent.name == "Mesh cage rig"


class RecordingLayout:
    """Stands in for a menu's layout: records the operators drawn."""

    def __init__(self):
        self.operators, self.operator_context = [], 'EXEC_REGION_WIN'

    def separator(self):
        pass

    def operator(self, idname, **options):
        self.operators.append((idname, self.operator_context))


def test_bake_to_bones_is_in_the_object_animation_menu_and_the_panel(gc):
    """Issue 19 item 8: Object > Animation draws it (menus are what F3 searches), the
    panel shows it for a bound mesh, and the GUI's invoke path runs it."""
    operators = importlib.import_module(f"{PACKAGE}.gencoords_addon.ui.bake_operator")
    menu = bpy.types.VIEW3D_MT_object_animation
    assert operators.draw_menu in menu._dyn_ui_initialize()
    layout = RecordingLayout()
    operators.draw_menu(type("Menu", (), {"layout": layout})(), bpy.context)
    assert layout.operators == [("object.gencoords_bake_bones", 'INVOKE_REGION_WIN')]
    description = bpy.ops.object.gencoords_bake_bones.get_rna_type().description
    assert "armature" in description and "glTF" in description

    cage = add_icosphere_cage()
    obj = add_sphere()
    make_active(obj)
    assert not bpy.ops.object.gencoords_bake_bones.poll()  # not bound: greyed out
    with pytest.raises(RuntimeError, match="'Mesh' is not bound: Bind it first"):
        bpy.ops.object.gencoords_bake_bones()
    panel = importlib.import_module(f"{PACKAGE}.gencoords_addon.ui.panel")
    bind(obj, cage)
    drawn = []

    class PanelLayout:
        def __getattr__(self, name):
            if name == "operator":
                return lambda idname, **options: drawn.append(idname) or type("Props", (), {})()
            if name in ("row", "column", "box"):
                return lambda *args, **options: self
            if name == "panel":  # a layout panel: its header and body
                return lambda *args, **options: (self, self)
            return lambda *args, **options: None

    panel.draw_settings(PanelLayout(), obj)
    assert "object.gencoords_bake_bones" in drawn
    assert bpy.ops.object.gencoords_bake_bones('INVOKE_DEFAULT') == {'FINISHED'}
    assert obj.parent is not None and obj.parent.type == 'ARMATURE'


def test_a_baked_rig_round_trips_through_gltf(gc, tmp_path):
    """Export with Blender's glTF exporter, import, pose the imported bones like the cage
    moves: the imported skin deforms like the original within the reported deviation."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    coordinates = coordinates_of(gc, obj)
    make_active(obj)
    # No keyframes: the imported action would pose the bones over what the test sets.
    assert bpy.ops.object.gencoords_bake_bones(max_influences=4, keyframes=False) == {'FINISHED'}
    rig = bpy.data.objects["Mesh cage rig"]
    rest_cage = read_positions(cage.data).astype(np.float64)
    displacement = gc.core.storage.deviations.smooth_test_motion(rest_cage) - rest_cage
    truncated = gc.core.skinning.skinning.truncate(coordinates, 4, rest_cage)  # as Bake to Bones writes them
    rest = read_positions(obj.data).astype(np.float64)
    expected = rest + truncated @ displacement
    for other in bpy.context.view_layer.objects:
        other.select_set(other in (obj, rig))
    blend, imported_blend = str(tmp_path / "baked.blend"), str(tmp_path / "imported.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    # In a fresh process: after Blender's glTF exporter or importer has run, bpy 4.2.x
    # (pip module, Linux; 4.2.0 after the import, 4.2.23 after the export) dies with
    # SIGSEGV at interpreter exit, which would take the whole test run with it.
    report = report_of(run_blender_script("blender_gltf_round_trip.py", blend,
                                          tmp_path / "baked.glb", imported_blend,
                                          survive_exit_bug=True))
    assert report == {"exported": ["FINISHED"], "selected": ["Mesh", "Mesh cage rig"],
                      "imported": ["FINISHED"]}
    bpy.ops.wm.open_mainfile(filepath=imported_blend)
    imported_rig = bpy.data.objects["Mesh cage rig"]
    imported = bpy.data.objects["Mesh"]
    assert imported.parent == imported_rig
    # glTF splits vertices along seams: match each imported vertex to its original.
    imported_rest = apply_matrix(imported.matrix_world, evaluated_positions(imported))
    match = np.linalg.norm(imported_rest[:, None] - rest[None], axis=2).argmin(axis=1)
    assert np.linalg.norm(imported_rest - rest[match], axis=1).max() < 1e-5
    for j, move in enumerate(displacement):  # in armature space: whatever the bone axes
        bone = imported_rig.pose.bones[f"GenCoords {j}"]
        bone.matrix = Matrix.Translation(move) @ bone.bone.matrix_local
        bpy.context.view_layer.update()
    world = apply_matrix(imported.matrix_world, evaluated_positions(imported))
    np.testing.assert_allclose(world, expected[match], atol=1e-4)


# --- An independent reader of the exported file: glTF 2.0 as a game engine reads it. ---

COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
              5125: np.uint32, 5126: np.float32}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_glb(path):
    """The JSON and the binary chunk of a .glb."""
    data = Path(path).read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data)
    assert magic == b"glTF" and version == 2 and length == len(data)
    json_length, json_type = struct.unpack_from("<I4s", data, 12)
    assert json_type == b"JSON"
    document = json.loads(data[20:20 + json_length])
    start = 20 + json_length
    binary_length, binary_type = struct.unpack_from("<I4s", data, start)
    assert binary_type == b"BIN\0"
    return document, data[start + 8:start + 8 + binary_length]


def read_accessor(document, binary, index):
    """An accessor's values as float64, (count, width); normalised integers to [0, 1]."""
    accessor = document["accessors"][index]
    view = document["bufferViews"][accessor["bufferView"]]
    dtype = np.dtype(COMPONENTS[accessor["componentType"]])
    width = WIDTHS[accessor["type"]]
    stride = view.get("byteStride", dtype.itemsize * width)
    offset = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    rows = [np.frombuffer(binary, dtype, width, offset + i * stride)
            for i in range(accessor["count"])]
    values = np.array(rows, dtype=np.float64).reshape(accessor["count"], width)
    if accessor.get("normalized"):
        values /= np.iinfo(dtype).max
    return values


def quaternion_matrix(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    matrix = np.eye(4)
    scale = np.diag(node.get("scale", [1.0, 1.0, 1.0]))
    matrix[:3, :3] = quaternion_matrix(*node.get("rotation", [0.0, 0.0, 0.0, 1.0])) @ scale
    matrix[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    return matrix


def pose_at_last_keyframe(document, binary):
    """The nodes with every animation channel set to its value at its last keyframe;
    returns (nodes, the last keyframe's time)."""
    last = max((float(read_accessor(document, binary, sampler["input"])[-1, 0])
                for animation in document.get("animations", []) for sampler in animation["samplers"]),
               default=0.0)
    return pose_at_time(document, binary, last), last


def pose_at_time(document, binary, time):
    """The nodes with every animation channel at ``time`` (seconds; linear between
    keyframes, held beyond them: exact at keyframe times)."""
    nodes = [dict(node) for node in document["nodes"]]
    for animation in document.get("animations", []):
        for channel in animation["channels"]:
            sampler = animation["samplers"][channel["sampler"]]
            times = read_accessor(document, binary, sampler["input"])[:, 0]
            values = read_accessor(document, binary, sampler["output"])
            if sampler.get("interpolation") == "CUBICSPLINE":
                values = values[1::3]
            value = [np.interp(time, times, column) for column in values.T]
            nodes[channel["target"]["node"]][channel["target"]["path"]] = value
    return nodes


def world_matrices(nodes):
    parents = {child: index for index, node in enumerate(nodes) for child in node.get("children", [])}

    def world(index):
        local = node_matrix(nodes[index])
        return world(parents[index]) @ local if index in parents else local
    return [world(index) for index in range(len(nodes))]


def skinned_positions(document, binary, nodes=None, max_sets=None):
    """Linear blend skinning of the skinned mesh with the ``nodes`` posed (default: at the
    last keyframe), as the glTF 2.0 specification defines it (world joint matrices times
    inverse bind matrices, every JOINTS_n/WEIGHTS_n set, or the first ``max_sets``);
    returns (rest positions, skinned positions, sets used)."""
    if nodes is None:
        nodes, _ = pose_at_last_keyframe(document, binary)
    (node,) = [node for node in document["nodes"] if "skin" in node and "mesh" in node]
    skin = document["skins"][node["skin"]]
    inverse_binds = read_accessor(document, binary, skin["inverseBindMatrices"])
    worlds = world_matrices(nodes)
    joint_matrices = np.array([worlds[joint] @ inverse.reshape(4, 4).T
                               for joint, inverse in zip(skin["joints"], inverse_binds)])
    rests, skinned, sets = [], [], 0
    for primitive in document["meshes"][node["mesh"]]["primitives"]:
        attributes = primitive["attributes"]
        rest = read_accessor(document, binary, attributes["POSITION"])
        homogeneous = np.column_stack([rest, np.ones(len(rest))])
        moved = np.zeros_like(rest)
        sets = 0
        while f"JOINTS_{sets}" in attributes and (max_sets is None or sets < max_sets):
            joints = read_accessor(document, binary, attributes[f"JOINTS_{sets}"]).astype(int)
            weights = read_accessor(document, binary, attributes[f"WEIGHTS_{sets}"])
            for lane in range(4):
                transformed = np.einsum("kij,kj->ki", joint_matrices[joints[:, lane]], homogeneous)
                moved += weights[:, lane, None] * transformed[:, :3]
            sets += 1
        rests.append(rest)
        skinned.append(moved)
    return np.concatenate(rests), np.concatenate(skinned), sets


def y_up(points):
    """Blender's Z-up coordinates as the glTF exporter writes them (+Y up)."""
    return np.column_stack([points[:, 0], points[:, 2], -points[:, 1]])


def validate(path):
    """The Khronos glTF-Validator's report on ``path`` (``make test-tools`` installs it)."""
    node = shutil.which("node")
    if node is None or not VALIDATOR.is_dir():
        message = "glTF-Validator missing: run `make test-tools` (node and npm needed)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    result = subprocess.run([node, str(REPO / "tests" / "tools" / "validate_gltf.js"), str(path)],
                            capture_output=True, text=True, timeout=120, check=True)
    return json.loads(result.stdout)


@pytest.mark.parametrize("influences, export_options", [
    (4, {}),  # the exporter's defaults: 4 influences
    (0, {"export_all_influences": True}),  # every weight, as JOINTS_1/WEIGHTS_1 and on
])
def test_the_exported_glb_animates_and_skins_like_blender(gc, tmp_path, influences,
                                                          export_options):
    """Issue 19 item 7: exported with Blender's glTF exporter (all its defaults but the
    ones named), the file is valid and, skinned at its last keyframe by a reader of our
    own, matches Blender's deformation at that frame."""
    obj, cage = posed_scene(gc)
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones(max_influences=influences) == {'FINISHED'}
    scene = bpy.context.scene
    scene.frame_set(scene.frame_end)
    expected = y_up(world_positions(obj))
    # The exporter writes a skinned mesh's vertices in its armature's space (the rig's
    # is the world's).
    rest = y_up(apply_matrix(obj.matrix_world, read_positions(obj.data).astype(np.float64)))
    blend, glb = tmp_path / "baked.blend", tmp_path / "baked.glb"
    scene.frame_set(scene.frame_start)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    report = report_of(run_blender_script("blender_gltf_export.py", blend, glb,
                                          json.dumps(export_options), survive_exit_bug=True))
    assert report == {"exported": ["FINISHED"]}

    validation = validate(glb)
    assert validation["issues"]["numErrors"] == 0, validation["issues"]["messages"]

    document, binary = read_glb(glb)
    assert document.get("animations"), "no animation exported"
    exported_rest, skinned, sets = skinned_positions(document, binary)
    assert sets == (1 if influences == 4 else 3)  # 12 cage vertices: 3 sets of 4
    # glTF splits vertices along seams: match each exported vertex to its original.
    match = np.linalg.norm(exported_rest[:, None] - rest[None], axis=2).argmin(axis=1)
    assert np.linalg.norm(exported_rest - rest[match], axis=1).max() < 1e-5
    tolerance = 1e-4 * diagonal_of(cage)  # weights are written as float32 or 16 bits
    np.testing.assert_allclose(skinned, expected[match], atol=tolerance)


@pytest.mark.parametrize("mode", ["FOLLOW", "FITTED"])
def test_binding_again_to_the_cage_of_a_baked_rig_warns_that_the_mesh_moves_twice(gc, capfd, mode):
    """Fuzz seeds 2180 and 5090: Bake to Bones, then Bind to the same cage again: the rig
    (following the cage, or replaying its baked motion) and the binding both move the
    mesh. Bind says so, naming the modifier."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    make_active(obj)
    options = {} if mode == "FOLLOW" else {"mode": 'FITTED', "bones": 4, "frame_start": 1, "frame_end": 2}
    assert bpy.ops.object.gencoords_bake_bones(**options) == {'FINISHED'}
    capfd.readouterr()
    rest_cage = read_positions(cage.data).copy()
    assert bind(obj, cage) == {'FINISHED'}
    out = capfd.readouterr().out
    assert "Warning: Bound 'Mesh'" in out
    rig = "Mesh cage rig" if mode == "FOLLOW" else "Mesh fitted rig"
    assert f"also follows 'Cage' through the armature '{rig}' baked from it (modifier 'Armature')" in out
    if mode == "FOLLOW":  # what the warning is about: a translated cage moves the mesh twice as far
        rest = world_positions(obj)
        write_positions(cage.data, rest_cage + np.float32(0.1))
        np.testing.assert_allclose(world_positions(obj) - rest, 0.2, atol=1e-4)
    # A mesh with no such rig binds without it.
    other, other_cage = add_sphere(), add_icosphere_cage()
    capfd.readouterr()
    assert bind(other, other_cage) == {'FINISHED'}
    assert "also follows" not in capfd.readouterr().out
