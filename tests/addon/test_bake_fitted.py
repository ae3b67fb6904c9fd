"""Bake to Bones, Fitted (game engines), issue 26: through a pipeline script's
temp_override, and through a game engine's door (the exported .glb, default glTF
options, skinned by our own numpy reader that reads only JOINTS_0/WEIGHTS_0)."""

import importlib
import json
import time

import bpy
import numpy as np
import pytest

from fresh_process import PACKAGE, report_of, run_blender_script
from scene_helpers import add_icosphere_cage, add_sphere, bind, make_active, read_positions
from test_bake_bones import (animate_cage, apply_matrix, binding_motion, pose_at_time, read_accessor,
                              read_glb, skinned_positions, validate, y_up)

WORST, RMS = 0.02, 0.005  # the targets, fractions of the mesh's diagonal
FRAMES = range(1, 11)


def fitted_module():
    return importlib.import_module(f"{PACKAGE}.gencoords_addon.bake.fitted")


def bound_animated_scene(gc, kind="MEAN_VALUE", radius=2.0):
    """A sphere in an icosphere cage, bound at frame 1, the cage bent and turned over
    frames 1 to 10 (``animate_cage``); returns the mesh and its motion as bound."""
    cage = add_icosphere_cage(radius=radius)
    obj = add_sphere()
    obj.rotation_euler = (0.3, 0.0, 0.7)
    bpy.context.view_layer.update()
    animate_cage(gc, cage)
    assert bind(obj, cage, kind=kind) == {'FINISHED'}
    return obj, binding_motion(obj, FRAMES)


def mesh_diagonal(obj):
    rest = apply_matrix(obj.matrix_world, read_positions(obj.data).astype(np.float64))
    return float(np.linalg.norm(np.ptp(rest, axis=0)))


def bake_fitted(obj, **options):
    """Bake Fitted as a pipeline script does: the mesh in a temp_override."""
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_bake_bones(mode='FITTED', **options)


def deviations(obj, expected, diagonal):
    """Worst and RMS distance of the mesh as Blender plays it from ``expected`` (frame ->
    world positions), fractions of ``diagonal``."""
    played = binding_motion(obj, list(expected))
    gaps = np.array([np.linalg.norm(played[f] - expected[f], axis=1) for f in expected]) / diagonal
    return gaps.max(), np.sqrt(np.mean(gaps ** 2))


def written_weights(obj):
    """(n, groups) weights as the vertex groups hold them."""
    weights = np.zeros((len(obj.data.vertices), len(obj.vertex_groups)))
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            weights[vertex.index, element.group] = element.weight
    return weights


@pytest.mark.parametrize("kind, radius", [("MEAN_VALUE", 2.0), ("GREEN", 2.0),
                                          ("DISCRETE_HARMONIC", 1.3)])
def test_a_fitted_bake_plays_like_the_binding_with_4_weights(gc, kind, radius, capfd):
    """Every kind, Green and negative coordinates included: at most 4 non-negative weights
    summing to one per vertex, the rig alone (keyframes) within the targets at every
    frame, and the figures reported are what Blender plays."""
    obj, expected = bound_animated_scene(gc, kind, radius)
    if kind == "DISCRETE_HARMONIC":
        assert gc.binding.binding(obj).coordinates(obj.data).min() < -1e-5
    assert bake_fitted(obj, bones=24) == {'FINISHED'}
    assert [m.type for m in obj.modifiers] == ['ARMATURE'] and not gc.binding.bindings(obj)
    rig = obj.parent
    assert rig.type == 'ARMATURE' and rig.animation_data.action is not None
    assert all(not bone.constraints for bone in rig.pose.bones)  # keyframes alone
    weights = written_weights(obj)
    assert (np.count_nonzero(weights, axis=1) <= 4).all() and weights.min() >= 0.0
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-6)

    worst, rms = deviations(obj, expected, mesh_diagonal(obj))
    assert worst < WORST and rms < RMS
    info = rig.data["gencoords_bake"].to_dict()
    assert info["worst"] == pytest.approx(worst, rel=1e-3, abs=1e-7)
    assert info["rms"] == pytest.approx(rms, rel=1e-3, abs=1e-7)
    assert info["frames"] == [1, 10] and info["max_influences"] == 4 and info["bones"] <= 24
    out = capfd.readouterr().out
    assert "fitted bones, at most 4 per vertex, keyframed over frames 1 to 10" in out
    assert f"worst {100 * info['worst']:.2f} %, RMS {100 * info['rms']:.3f} %" in out


def test_a_fitted_bake_samples_a_chosen_frame_range(gc):
    obj, expected = bound_animated_scene(gc)
    assert bake_fitted(obj, bones=8, max_influences=2, use_scene_range=False,
                       frame_start=3, frame_end=6) == {'FINISHED'}
    info = obj.parent.data["gencoords_bake"].to_dict()
    assert info["frames"] == [3, 6] and info["max_influences"] == 2
    assert (np.count_nonzero(written_weights(obj), axis=1) <= 2).all()
    action = obj.parent.animation_data.action
    assert tuple(action.frame_range) == (3.0, 6.0)


def test_a_bad_frame_range_is_refused_and_changes_nothing(gc):
    obj, _ = bound_animated_scene(gc)
    objects = set(bpy.data.objects.keys())
    with pytest.raises(RuntimeError, match="The frame range 6 to 3 is empty"):
        bake_fitted(obj, use_scene_range=False, frame_start=6, frame_end=3)
    assert set(bpy.data.objects.keys()) == objects and gc.binding.binding(obj) is not None


class Cancelled(Exception):
    pass


@pytest.mark.parametrize("fault", ["progress", "remove"])
def test_a_cancelled_or_failing_fitted_bake_changes_nothing(gc, fault, monkeypatch):
    """Esc during the fit (the progress callback raises), or a failure at the last step:
    the binding, the modifiers and the data are as before."""
    obj, _ = bound_animated_scene(gc)
    objects, armatures = set(bpy.data.objects.keys()), set(bpy.data.armatures.keys())
    actions, modifiers = set(bpy.data.actions.keys()), [(m.name, m.show_viewport) for m in obj.modifiers]

    def cancel(fraction):
        raise Cancelled

    def broken(obj, bindings):
        raise Cancelled
    if fault == "remove":
        monkeypatch.setattr(gc.binding, "remove", broken)
    with pytest.raises(Cancelled):
        fitted_module().bake(obj, bpy.context, 8, progress=cancel if fault == "progress" else None)
    assert set(bpy.data.objects.keys()) == objects and set(bpy.data.armatures.keys()) == armatures
    assert set(bpy.data.actions.keys()) == actions and obj.parent is None
    assert [(m.name, m.show_viewport) for m in obj.modifiers] == modifiers
    assert not obj.vertex_groups and gc.binding.binding(obj) is not None


def test_the_exported_glb_plays_the_fit_for_a_4_influence_reader(gc, tmp_path):
    """Exported with Blender's glTF exporter, its defaults and the selected objects only:
    valid, one JOINTS_0/WEIGHTS_0 set, and skinned by our reader at every frame's time,
    within the targets of GenCoords' deformation."""
    obj, expected = bound_animated_scene(gc)
    assert bake_fitted(obj, bones=24) == {'FINISHED'}
    rig = obj.parent
    for other in bpy.context.view_layer.objects:
        other.select_set(other in (obj, rig))
    blend, glb = tmp_path / "fitted.blend", tmp_path / "fitted.glb"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    report = report_of(run_blender_script("blender_gltf_export.py", blend, glb,
                                          json.dumps({"use_selection": True}), survive_exit_bug=True))
    assert report == {"exported": ["FINISHED"]}
    validation = validate(glb)
    assert validation["issues"]["numErrors"] == 0, validation["issues"]["messages"]

    document, binary = read_glb(glb)
    assert len(document["animations"]) == 1 and len(document["skins"][0]["joints"]) <= 24
    rest = y_up(apply_matrix(obj.matrix_world, read_positions(obj.data).astype(np.float64)))
    exported_rest, _, sets = skinned_positions(document, binary, max_sets=1)
    assert sets == 1
    match = np.linalg.norm(exported_rest[:, None] - rest[None], axis=2).argmin(axis=1)
    assert np.linalg.norm(exported_rest - rest[match], axis=1).max() < 1e-5
    first = min(read_accessor(document, binary, sampler["input"])[0, 0]
                for sampler in document["animations"][0]["samplers"])
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    diagonal = mesh_diagonal(obj)
    gaps = []
    for frame in FRAMES:
        nodes = pose_at_time(document, binary, first + (frame - FRAMES[0]) / fps)
        _, skinned, _ = skinned_positions(document, binary, nodes, max_sets=1)
        gaps.append(np.linalg.norm(skinned - y_up(expected[frame])[match], axis=1) / diagonal)
    gaps = np.array(gaps)
    assert gaps.max() < WORST and np.sqrt(np.mean(gaps ** 2)) < RMS
    # the file plays what Blender plays: the figures the bake measured on its rig
    info = rig.data["gencoords_bake"].to_dict()
    assert gaps.max() == pytest.approx(info["worst"], abs=1e-4)
    assert np.sqrt(np.mean(gaps ** 2)) == pytest.approx(info["rms"], abs=1e-4)


def fitted_operator_stand_in(operators, **options):
    """The Bake to Bones operator's methods on a plain object (Blender operators cannot
    be made outside a call), with Fitted options and its reports."""
    cls = operators.OBJECT_OT_gencoords_bake_bones
    methods = {name: vars(cls)[name] for name in (
        "execute", "invoke", "modal", "_fitted_options", "_guarded", "_fitted_job", "_commit_fitted",
        "_bake_fitted", "_start_fitted", "_step", "_end_modal", "_finished", "_cancel")}
    stand_in = type("BakeStandIn", (), methods)()
    defaults = {"mode": 'FITTED', "bones": 8, "max_influences": 0, "use_scene_range": True,
                "frame_start": 1, "frame_end": 250, "fitted_confirmed": False}
    for name, value in {**defaults, **options}.items():
        setattr(stand_in, name, value)
    stand_in.reports = []
    stand_in.report = lambda kind, text: stand_in.reports.append(text)
    return stand_in


def run_modal(operator, context, timer):
    result = {'PASS_THROUGH'}  # a timer event passed on: still running
    while result == {'PASS_THROUGH'}:
        time.sleep(0.02)
        result = operator.modal(context, timer)
    return result


def test_in_a_window_the_fit_runs_modal_with_progress_and_esc(gc, monkeypatch):
    """OK in the options dialog -> execute hands over -> a modal bake whose fit runs in a
    thread: nothing is written until it ends, Esc changes nothing, other events are held."""
    from types import SimpleNamespace

    from test_ui_artist import ContextStandIn, WindowStandIn
    operators = importlib.import_module(f"{PACKAGE}.gencoords_addon.ui.bake_operator")
    obj, expected = bound_animated_scene(gc)
    make_active(obj)
    monkeypatch.setattr(operators, "interactive", lambda context: True)
    window_manager = WindowStandIn()
    context = ContextStandIn(window_manager)

    asking = fitted_operator_stand_in(operators)
    handed_over = []
    fake_ops = SimpleNamespace(object=SimpleNamespace(
        gencoords_bake_bones=lambda *args, **kwargs: handed_over.append((args, kwargs))))
    with monkeypatch.context() as patch:
        patch.setattr(operators.bpy, "ops", fake_ops)
        assert asking.execute(context) == {'CANCELLED'}
    ((args, kwargs),) = handed_over
    assert args == ('INVOKE_DEFAULT',) and kwargs["fitted_confirmed"] and kwargs["bones"] == 8
    assert kwargs["mode"] == 'FITTED' and obj.parent is None

    escaped = fitted_operator_stand_in(operators, fitted_confirmed=True)
    assert escaped.invoke(context, None) == {'RUNNING_MODAL'}
    assert escaped.modal(context, SimpleNamespace(type='ESC')) == {'CANCELLED'}
    assert escaped.reports == ["Bake to Bones cancelled: nothing was changed"]
    assert gc.binding.binding(obj) is not None and obj.parent is None and not obj.vertex_groups

    # Issue 37 item 7: the frames are sampled a frame a step, with progress, and Esc among
    # them puts the scene's frame and the modifiers back (a step a timer event here: a
    # window runs a tenth of a second of steps an event).
    monkeypatch.setattr(gc.core.planning.bind_steps, "MAX_SLICE_SECONDS", 0.0)
    monkeypatch.setattr(gc.core.planning.bind_steps, "TAIL_SECONDS", 0.0)  # no short rest run on
    scene, shown = bpy.context.scene, [m.show_viewport for m in obj.modifiers]
    frame = scene.frame_current
    sampling = fitted_operator_stand_in(operators, fitted_confirmed=True)
    assert sampling.invoke(context, None) == {'RUNNING_MODAL'}
    updates = window_manager.calls.count("progress_update")
    for _ in range(2 + 3):  # the checks and the mesh read (2 steps), then 3 frames
        assert sampling.modal(context, SimpleNamespace(type='TIMER')) == {'PASS_THROUGH'}
    assert window_manager.calls.count("progress_update") == updates + 5 and scene.frame_current == 3
    assert sampling.modal(context, SimpleNamespace(type='ESC')) == {'CANCELLED'}
    assert scene.frame_current == frame and [m.show_viewport for m in obj.modifiers] == shown
    assert sampling.reports == ["Bake to Bones cancelled: nothing was changed"] and obj.parent is None

    running = fitted_operator_stand_in(operators, fitted_confirmed=True)
    assert running.invoke(context, None) == {'RUNNING_MODAL'}
    assert {"event_timer_add", "progress_begin", "modal_handler_add"} <= set(window_manager.calls)
    assert running.modal(context, SimpleNamespace(type='LEFTMOUSE')) == {'RUNNING_MODAL'}
    assert run_modal(running, context, SimpleNamespace(type='TIMER')) == {'FINISHED'}
    assert "progress_end" in window_manager.calls and obj.parent.type == 'ARMATURE'
    assert running.reports[-1].startswith("Baked 'Mesh' to 'Mesh fitted rig' (")
    worst, _ = deviations(obj, expected, mesh_diagonal(obj))
    assert worst < WORST


def file_state(obj):
    """What a cancelled bake must leave as it was: the data-blocks, the mesh's modifiers,
    vertex groups, attributes and parent, and the scene's frame."""
    return {"objects": sorted(bpy.data.objects.keys()), "armatures": sorted(bpy.data.armatures.keys()),
            "actions": sorted(bpy.data.actions.keys()), "parent": obj.parent,
            "modifiers": [(m.name, m.type, m.show_viewport) for m in obj.modifiers],
            "groups": obj.vertex_groups.keys(), "attributes": sorted(obj.data.attributes.keys()),
            "frame": bpy.context.scene.frame_current}


def test_in_a_window_the_writing_shows_progress_and_esc_leaves_the_file_as_it_was(gc, monkeypatch):
    """Issue 37 item 7: the checks at the start and the writing and measuring of the rig at
    the end are steps of the modal bake too: the progress rises through them, and Esc while
    the rig is being measured (armature, keys, vertex groups and Armature modifier written)
    removes all of it at once; the binding deforms as before. A script's call (the other
    tests) still runs to the end."""
    from types import SimpleNamespace

    from test_ui_artist import ContextStandIn, WindowStandIn
    operators = importlib.import_module(f"{PACKAGE}.gencoords_addon.ui.bake_operator")
    obj, expected = bound_animated_scene(gc)
    make_active(obj)
    monkeypatch.setattr(operators, "interactive", lambda context: True)
    before = file_state(obj)

    class ProgressStandIn(WindowStandIn):
        def __init__(self):
            super().__init__()
            self.fractions = []

        def progress_update(self, fraction):
            self.fractions.append(fraction)
    window_manager = ProgressStandIn()
    context = ContextStandIn(window_manager)
    timer = SimpleNamespace(type='TIMER')
    monkeypatch.setattr(gc.core.planning.bind_steps, "MAX_SLICE_SECONDS", 0.0)  # a step an event
    monkeypatch.setattr(gc.core.planning.bind_steps, "TAIL_SECONDS", 0.0)  # no short rest run on

    escaped = fitted_operator_stand_in(operators, fitted_confirmed=True)
    assert escaped.invoke(context, None) == {'RUNNING_MODAL'}
    while not (obj.vertex_groups and obj.modifiers[0].type == 'ARMATURE'):  # into the measuring
        time.sleep(0.02)
        assert escaped.modal(context, timer) == {'PASS_THROUGH'}
    assert obj.parent is not None and len(bpy.data.armatures) == len(before["armatures"]) + 1
    assert 0.9 < window_manager.fractions[-1] < 1.0
    start = time.perf_counter()
    assert escaped.modal(context, SimpleNamespace(type='ESC')) == {'CANCELLED'}
    assert time.perf_counter() - start < 1.0
    assert escaped.reports == ["Bake to Bones cancelled: nothing was changed"]
    assert file_state(obj) == before and gc.binding.binding(obj) is not None
    played = binding_motion(obj, list(expected))
    assert all(np.array_equal(played[frame], expected[frame]) for frame in expected)

    window_manager.fractions.clear()
    running = fitted_operator_stand_in(operators, fitted_confirmed=True)
    assert running.invoke(context, None) == {'RUNNING_MODAL'}
    assert run_modal(running, context, timer) == {'FINISHED'}
    fractions = np.array(window_manager.fractions)
    assert (np.diff(fractions) >= 0.0).all() and fractions[0] < 0.02
    writing = fractions[fractions > 0.9]  # the rig written, keyed, then measured a frame a step
    assert len(writing) >= 2 + len(FRAMES) and (np.diff(writing) > 0.0).all() and writing[-1] == 1.0
    assert obj.parent.type == 'ARMATURE' and running.reports[-1].startswith("Baked 'Mesh' to ")


def test_other_modifiers_stay_and_the_fit_is_of_the_binding_alone(gc):
    """A Subdivision after the binding (it changes the vertex count) and a hidden
    binding modifier: the bake samples the binding's deformation alone, the Armature
    takes its place, the Subdivision stays after it and is shown as before."""
    obj, expected = bound_animated_scene(gc)
    subdivision = obj.modifiers.new("Subdivision", 'SUBSURF')
    gc.binding.binding(obj).modifier.show_viewport = False
    assert bake_fitted(obj, bones=16) == {'FINISHED'}
    assert [(m.type, m.show_viewport) for m in obj.modifiers] == [('ARMATURE', True), ('SUBSURF', True)]
    subdivision.show_viewport = False
    worst, rms = deviations(obj, expected, mesh_diagonal(obj))
    assert worst < WORST and rms < RMS
    assert obj.parent.data["gencoords_bake"]["worst"] == pytest.approx(worst, rel=1e-3, abs=1e-7)


def test_a_deformation_that_is_not_finite_is_refused_and_changes_nothing(gc, monkeypatch):
    """A cage keyed to infinity somewhere (or NaN) makes the binding's vertices not
    finite at those frames: the bake says which, and writes nothing."""
    obj, _ = bound_animated_scene(gc)
    module = fitted_module()
    finite = gc.bones.evaluated_world_positions

    def broken_at_frame_4(obj, depsgraph):
        positions = finite(obj, depsgraph)
        if bpy.context.scene.frame_current == 4:
            positions[3] = np.nan
        return positions
    monkeypatch.setattr(module.bones, "evaluated_world_positions", broken_at_frame_4)
    objects = set(bpy.data.objects.keys())
    with pytest.raises(RuntimeError, match=r"not finite at frame 4 \(1 of the 10 frames sampled\)"):
        bake_fitted(obj, bones=8)
    assert set(bpy.data.objects.keys()) == objects and gc.binding.binding(obj) is not None
    assert not obj.vertex_groups and obj.parent is None


def test_a_binding_whose_cage_was_deleted_is_refused_and_nothing_changes(gc):
    """Fuzz seed 6121: the cage deleted (X), then Bake to Bones, Fitted: an internal error
    (the rig's record names its cage). A binding that does not deform would be fitted as a
    still mesh: refused with the panel's words, as Follow refuses it."""
    from test_ui_artist import delete_as_the_artist

    obj, _ = bound_animated_scene(gc)
    delete_as_the_artist(obj.gencoords.cage)
    make_active(obj)
    objects, modifiers = set(bpy.data.objects.keys()), [m.name for m in obj.modifiers]
    with pytest.raises(RuntimeError, match=f"Cannot bake '{obj.name}' to fitted bones: The cage 'Cage' was deleted"):
        bake_fitted(obj, bones=8)
    assert set(bpy.data.objects.keys()) == objects and [m.name for m in obj.modifiers] == modifiers
    assert not obj.vertex_groups and obj.parent is None


def first_rig_alone(obj, armature, frames):
    """The mesh's world positions at ``frames`` deformed by ``armature`` (an Armature
    modifier) alone."""
    shown = [(m, m.show_viewport) for m in obj.modifiers]
    for modifier, _ in shown:
        modifier.show_viewport = modifier == armature
    try:
        return binding_motion(obj, frames)
    finally:
        for modifier, visible in shown:
            modifier.show_viewport = visible


def test_a_second_fitted_bake_leaves_the_first_rig_as_it_was(gc):
    """Issue 37 item 3: bake, bind the mesh to another cage, bake again (through the
    operator): the second bake's bones and vertex groups have names of their own, so the
    first rig reads its own weights and plays as before, to the float."""
    obj, _ = bound_animated_scene(gc)
    assert bake_fitted(obj, bones=8) == {'FINISHED'}
    first_rig, (first_armature,) = obj.parent, obj.modifiers
    before = first_rig_alone(obj, first_armature, FRAMES)
    other_cage = add_icosphere_cage(radius=2.3, name="Other cage")
    other_cage.location = (0.05, 0.0, 0.1)
    assert bind(obj, other_cage) == {'FINISHED'}
    assert bake_fitted(obj, bones=6) == {'FINISHED'}
    second = next(m for m in obj.modifiers if m != first_armature)
    assert second.type == 'ARMATURE' and second.object not in (None, first_rig)
    first_names = {bone.name for bone in first_rig.data.bones}
    second_names = {bone.name for bone in second.object.data.bones}
    assert first_names.isdisjoint(second_names) and second_names <= set(obj.vertex_groups.keys())
    after = first_rig_alone(obj, first_armature, FRAMES)
    for frame in FRAMES:
        np.testing.assert_array_equal(after[frame], before[frame])


def test_the_bake_keys_what_engines_play_between_frames(gc):
    """Issue 37 item 11: the keys are LINEAR (engines interpolate samples linearly, and
    spherically for turns): at half frames the evaluated rig's bones hold the mean of
    their two keyed neighbours' values (Bezier keys overshoot it where the motion bends)."""
    obj, _ = bound_animated_scene(gc)
    assert bake_fitted(obj, bones=8) == {'FINISHED'}
    rig, scene = obj.parent, bpy.context.scene
    curves = list(rig.animation_data.action.layers[0].strips[0].channelbag(rig.animation_data.action_slot).fcurves) \
        if hasattr(rig.animation_data.action, "layers") else list(rig.animation_data.action.fcurves)
    assert curves and all(point.interpolation == 'LINEAR' for curve in curves for point in curve.keyframe_points)

    def pose(frame, subframe=0.0):
        scene.frame_set(frame, subframe=subframe)
        return np.array([list(bone.location) + list(bone.rotation_quaternion) for bone in rig.pose.bones])
    for frame in (2, 5, 8):
        np.testing.assert_allclose(pose(frame, 0.5), (pose(frame) + pose(frame + 1)) / 2, atol=1e-6)


@pytest.mark.parametrize("mode", ["FITTED", "CAGE_VERTICES"])
def test_the_default_fbx_export_plays_the_baked_motion_first(gc, tmp_path, mode):
    """Issue 37 item 10: with every option of Blender's FBX exporter at its default, the
    file's first take (what ufbx and three.js play) is the rig's motion, either bake's:
    the bones move in it and the rig object does not. Read by our own FBX reader
    (tests/addon/fbx_reader.py); before, the first take was the cage's own action (the
    rig still, or moved by it)."""
    from fbx_reader import animation_takes

    obj, _ = bound_animated_scene(gc)
    options = {"bones": 8} if mode == "FITTED" else {"mode": mode}
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bake_bones(**{"mode": 'FITTED', **options}) == {'FINISHED'}
    rig = obj.parent
    path = tmp_path / "fitted.fbx"
    assert bpy.ops.export_scene.fbx(filepath=str(path)) == {'FINISHED'}
    (name, models), *others = animation_takes(path)
    assert name == rig.animation_data.action.name and others
    bones = [bone.name for bone in rig.data.bones]
    assert models.get(rig.name, 0.0) == 0.0 and all(bone in models for bone in bones)
    assert max(models[bone] for bone in bones) > 0.0


@pytest.mark.parametrize("mode", ["FITTED", "CAGE_VERTICES"])
def test_the_default_gltf_export_holds_one_clip_for_the_rig(gc, tmp_path, mode):
    """Issue 37 item 8: exported with every glTF option at its default (the whole scene),
    one clip moves the rig's joints, its armature or its mesh: the rig's motion, either
    bake's (the cage keeps a clip of its own, which moves only the cage)."""
    obj, _ = bound_animated_scene(gc)
    options = {"bones": 8} if mode == "FITTED" else {"mode": mode}
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bake_bones(**{"mode": 'FITTED', **options}) == {'FINISHED'}
    rig = obj.parent
    blend, glb = tmp_path / "fitted.blend", tmp_path / "fitted.glb"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    report = report_of(run_blender_script("blender_gltf_export.py", blend, glb, json.dumps({}), survive_exit_bug=True))
    assert report == {"exported": ["FINISHED"]}
    document, _ = read_glb(glb)
    names = [node.get("name") for node in document["nodes"]]
    rig_nodes = {names.index(rig.name), names.index(obj.name), *document["skins"][0]["joints"]}
    moving_rig = [clip["name"] for clip in document["animations"]
                  if any(channel["target"].get("node") in rig_nodes for channel in clip["channels"])]
    assert moving_rig == [rig.animation_data.action.name]
