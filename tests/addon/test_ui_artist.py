"""The artist's own doors: Delete (X) on the cage, Ctrl+Z, Rebind through the UI's
invoke path, Apply, and the panel's hints; and the cages an artist or a script makes by
accident (no faces, scaled to zero)."""

import re

import bpy
import numpy as np
import pytest

from scene_helpers import (make_active, add_cube_cage, add_icosphere_cage, add_sphere, bind,
                           edit_mesh, evaluated_positions, mesh_state, read_positions, update,
                           write_positions)
from test_bind_errors import assert_bind_refused, bound, fault_text

DELETED = "The cage 'Cage' was deleted: the mesh is not deformed; pick another cage and Bind, or Unbind"


def delete_as_the_artist(obj):
    """Select only ``obj`` and press X (``object.delete``), in the window's context."""
    make_active(obj)
    window = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=window, selected_objects=[obj], active_object=obj,
                                   object=obj):
        assert bpy.ops.object.delete() == {'FINISHED'}
    update()  # the depsgraph update after an operator, which runs the add-on's handler


def assert_follows(obj, cage, factor=1.2):
    """Scaling the cage scales the mesh (about the origin, where both are centred)."""
    rest = read_positions(obj.data).copy()
    write_positions(cage.data, read_positions(cage.data) * factor)
    np.testing.assert_allclose(evaluated_positions(obj), rest * factor, atol=1e-5)


def test_deleting_the_cage_with_x_passes_the_mesh_through_and_the_cage_can_be_purged(gc, tmp_path):
    obj, cage = bound(gc)
    write_positions(cage.data, read_positions(cage.data) * 1.2)
    assert not np.array_equal(evaluated_positions(obj), read_positions(obj.data))
    delete_as_the_artist(cage)
    assert "Cage" not in bpy.context.scene.objects
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))
    assert fault_text(gc, obj) == DELETED
    assert ("Was bound to 'Cage' (deleted) (modifier 'GenCoords')", 'LINKED') in \
        gc.status.status_lines(obj)
    assert obj.gencoords.cage is None  # nothing of ours holds the cage any more
    assert bpy.data.objects["Cage"].users == 0

    path = tmp_path / "deleted cage.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert "Cage" not in bpy.data.objects  # nothing held it: not even written
    bpy.data.orphans_purge(do_recursive=True)
    assert "Cage" not in bpy.data.objects and "Icosphere" not in bpy.data.meshes
    obj = bpy.data.objects["Mesh"]
    assert fault_text(gc, obj) == DELETED
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))
    make_active(obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    assert not obj.modifiers and not gc.binding.bindings(obj)


def test_deleting_the_cage_of_a_baked_rig_lets_its_bones_rest_as_the_saved_file_does(gc, tmp_path):
    """Found by the fuzz (seed 242 of scripts/fuzz): the rig's bones followed the deleted
    cage until the file was saved and reopened (a deleted object is not written), then
    rested: the mesh jumped on reopening."""
    obj, cage = bound(gc)
    make_active(obj)
    assert bpy.ops.object.gencoords_bake_bones(max_influences=0, keyframes=False) == {'FINISHED'}
    rest = read_positions(obj.data).copy()
    write_positions(cage.data, read_positions(cage.data) * 1.2)
    update()
    assert np.abs(evaluated_positions(obj) - rest).max() > 0.1  # the rig follows the cage
    delete_as_the_artist(cage)
    np.testing.assert_allclose(evaluated_positions(obj), rest, atol=1e-6)
    path = tmp_path / "deleted cage of a rig.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    np.testing.assert_allclose(evaluated_positions(bpy.data.objects["Mesh"]), rest, atol=1e-6)


def test_undo_of_deleting_the_cage_brings_it_back_driving_the_mesh(gc):
    """Ctrl+Z as in the UI (see test_undo_and_redo_of_bind_and_unbind): the step the UI
    pushes after Delete is pushed here explicitly."""
    preferences = bpy.context.preferences.edit
    preferences.use_global_undo, preferences.undo_steps = True, 32
    with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
        obj, cage = bound(gc)
        bpy.ops.ed.undo_push(message="Bind")
        delete_as_the_artist(cage)
        bpy.ops.ed.undo_push(message="Delete")
        assert fault_text(gc, obj) == DELETED

        assert bpy.ops.ed.undo() == {'FINISHED'}
        update()
        obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]  # undo rebuilds IDs
        assert cage.name in bpy.context.scene.objects
        assert obj.gencoords.cage == cage and gc.binding.binding(obj).cage == cage
        assert fault_text(gc, obj) == ""
        assert_follows(obj, cage)

        assert bpy.ops.ed.redo() == {'FINISHED'}
        update()
        obj = bpy.data.objects["Mesh"]
        assert fault_text(gc, obj) == DELETED
        np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


def as_the_ui(operator, obj):
    """Run ``operator`` on ``obj`` alone as a click does: its undo step pushed as it
    finishes (``undo=True``), before the depsgraph update that runs the add-on's handler."""
    make_active(obj)
    window = bpy.context.window_manager.windows[0]
    with bpy.context.temp_override(window=window, selected_objects=[obj], active_object=obj,
                                   object=obj):
        assert operator('EXEC_DEFAULT', True) == {'FINISHED'}
    update()


def test_undo_of_deleting_an_animated_cage_after_edit_mode_gives_the_binding_its_cage(gc):
    """Issue 37 item 1: an animated cage, Tab, Tab, X, Ctrl+Z: the cage came back and
    animated while the mesh stayed undeformed and the panel said it was deleted. The
    undo kept in memory the mesh and node group as the housekeeping had left them after
    the Delete's undo step was saved (identical saved states are not read again)."""
    preferences = bpy.context.preferences.edit
    preferences.use_global_undo, preferences.undo_steps = True, 32
    with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
        obj, cage = bound(gc)
        cage.keyframe_insert("location", frame=1)
        cage.location.x = 0.3
        cage.keyframe_insert("location", frame=10)
        bpy.ops.ed.undo_push(message="Bind")
        as_the_ui(bpy.ops.object.editmode_toggle, cage)
        as_the_ui(bpy.ops.object.editmode_toggle, cage)
        as_the_ui(bpy.ops.object.delete, cage)
        assert fault_text(gc, obj) == DELETED

        assert bpy.ops.ed.undo() == {'FINISHED'}
        update()
        obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]
        assert cage.name in bpy.context.scene.objects
        assert obj.gencoords.cage == cage and gc.binding.binding(obj).cage == cage
        assert fault_text(gc, obj) == ""
        bpy.context.scene.frame_set(10)
        rest = read_positions(obj.data)
        np.testing.assert_allclose(evaluated_positions(obj), rest + (0.3, 0.0, 0.0), atol=1e-5)

        assert bpy.ops.ed.redo() == {'FINISHED'}
        update()
        obj = bpy.data.objects["Mesh"]
        assert fault_text(gc, obj) == DELETED
        np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


def test_a_cage_unlinked_from_every_collection_is_let_go_of(gc):
    """Where Delete only unlinks the cage (Blender does when the object has other real
    users) it would live on through the modifier and the Cage setting."""
    obj, cage = bound(gc)
    extra = bpy.data.collections.new("Extra")
    bpy.context.scene.collection.children.link(extra)
    extra.objects.link(cage)
    bpy.context.collection.objects.unlink(cage)  # still in "Extra": not deleted
    update()
    assert gc.binding.binding(obj).cage == cage and fault_text(gc, obj) == ""
    assert_follows(obj, cage)
    extra.objects.unlink(cage)
    update()
    assert fault_text(gc, obj) == DELETED
    assert gc.binding.binding(obj).cage is None and obj.gencoords.cage is None
    assert cage.users == 0
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


def test_opening_a_file_with_a_deleted_cage_kept_alive_lets_go_of_it(gc, tmp_path):
    """Issue 19 item 3: a file saved by an older GenCoords, where Delete left the cage
    alive (in no collection, held by the modifier input and the Cage setting), is
    cleaned on opening (load_post), not at the first update touching a scene."""
    obj, cage = bound(gc)
    path = tmp_path / "old deleted cage.blend"
    handlers = bpy.app.handlers.depsgraph_update_post
    ours = gc.handlers.on_depsgraph_update
    handlers.remove(ours)  # as an older version: nothing lets go of the cage
    try:
        for collection in list(cage.users_collection):
            collection.objects.unlink(cage)
        update()
        assert gc.binding.binding(obj).cage == cage and obj.gencoords.cage == cage
        write_positions(cage.data, read_positions(cage.data) * 1.2)
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
    finally:
        handlers.append(ours)

    bpy.ops.wm.open_mainfile(filepath=str(path))
    obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]  # saved: it had users
    assert gc.binding.binding(obj).cage is None and obj.gencoords.cage is None
    assert cage.users == 0
    assert fault_text(gc, obj) == DELETED
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


def test_bind_to_another_cage_replaces_the_binding_whose_cage_was_deleted(gc):
    obj, cage = bound(gc)
    delete_as_the_artist(cage)
    other = add_icosphere_cage(radius=2.5, name="Other")
    assert bind(obj, other) == {'FINISHED'}
    assert [m.name for m in obj.modifiers] == ["GenCoords"]
    assert len(gc.binding.bindings(obj)) == 1 and fault_text(gc, obj) == ""
    assert_follows(obj, other)


def test_renaming_the_cage_then_deleting_it_names_it(gc):
    obj, cage = bound(gc)
    cage.name = "Renamed"
    update()
    bpy.data.objects.remove(cage)  # a script's removal: every pointer cleared at once
    update()
    assert fault_text(gc, obj) == DELETED.replace("'Cage'", "'Renamed'")
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


def empty_object(name, vertices=(), edges=()):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(list(vertices), list(edges), [])
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.collection.objects.link(obj)
    return obj


@pytest.mark.parametrize("what", ["vertices", "edges", "nothing"])
def test_a_cage_made_without_faces_by_from_pydata_is_refused(gc, what):
    corners = [(x, y, z) for x in (-3, 3) for y in (-3, 3) for z in (-3, 3)]
    vertices = corners if what != "nothing" else []
    edges = [(0, 1), (1, 3), (3, 2), (2, 0)] if what == "edges" else []
    cage = empty_object("Loose", vertices, edges)
    assert_bind_refused(add_sphere(), cage, re.escape(
        "The cage 'Loose' has no faces: it must be a closed surface around the mesh"))


def test_a_bound_cage_losing_all_its_faces_is_reported(gc):
    obj, cage = bound(gc)
    cage.data.clear_geometry()
    update()
    assert "The cage 'Cage' now has 0 vertices (bound with 12)" in fault_text(gc, obj)
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))


@pytest.mark.parametrize(("axes", "said"), [((2,), "Z axis"), ((0, 1), "X and Y axes")])
def test_a_cage_object_scaled_to_zero_is_told_so(gc, axes, said):
    cage = add_cube_cage()
    cage.rotation_euler = (0.3, 0.2, 0.1)  # the axes are the object's own
    for axis in axes:
        cage.scale[axis] = 0.0
    assert_bind_refused(add_sphere(), cage, re.escape(
        f"The cage object 'Cage' is scaled to zero on its {said} (or its parent is): give "
        "it a non-zero Scale (Object Properties > Transform), then Bind"))


@pytest.mark.parametrize("kind", ["MEAN_VALUE", "HARMONIC", "GREEN"])
@pytest.mark.parametrize(("scaled", "scale", "said"), [("mesh", (1.0, 1.0, 0.0), " on its Z axis"),
                                                       ("mesh", (1.0, 0.0, 1.0), " on its Y axis"),
                                                       ("parent", (1.0, 1.0, 0.0), "")])
def test_a_mesh_object_scaled_to_zero_after_bind_stays_at_rest_and_is_told_so(gc, kind, scaled, scale, said):
    """Issue 37 item 9: the mesh object (turned, away from the cage's origin) scaled to
    zero after Bind was displaced at rest (up to 0.57 here): Invert Matrix gives the
    identity for it, so the cage landed elsewhere in the mesh's space. The deformer now
    passes the mesh through and the panel says why; a scale again deforms it again."""
    cage, obj = add_icosphere_cage(), add_sphere()
    obj.location, obj.rotation_euler, obj.scale = (0.3, 0.2, 0.1), (0.3, 0.2, 0.1), (1.1, 0.9, 1.2)
    parent = bpy.data.objects.new("Parent", None)
    bpy.context.collection.objects.link(parent)
    obj.parent = parent
    obj.gencoords.cage, obj.gencoords.kind = cage, kind
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    rest = read_positions(obj.data).copy()
    (obj if scaled == "mesh" else parent).scale = scale
    update()
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    assert fault_text(gc, obj) == (
        f"The mesh object 'Mesh' is scaled to zero{said} (or its parent is): the mesh is not deformed; give it a "
        "non-zero Scale (Object Properties > Transform), then it deforms again")
    (obj if scaled == "mesh" else parent).scale = (1.0, 1.0, 1.0)
    update()
    assert fault_text(gc, obj) == ""
    write_positions(cage.data, read_positions(cage.data) + (0.0, 0.0, 0.1))
    assert np.abs(evaluated_positions(obj) - rest).max() > 0.05


def test_a_flat_cage_mesh_is_told_it_encloses_no_volume(gc):
    cage = add_icosphere_cage()
    write_positions(cage.data, read_positions(cage.data) * (1.0, 1.0, 0.0))
    assert_bind_refused(add_sphere(), cage, re.escape(
        "Cage 'Cage' is flat (all its vertices lie in one plane) and encloses no volume"))


def test_rebind_keeps_the_modifier_name_and_the_invoke_path_binds(gc):
    """Headless, 'INVOKE_DEFAULT' runs execute (no window to confirm in or to show
    progress): the Replace Binding question and the modal job need a real window."""
    obj, cage = bound(gc)
    keys = {gc.binding.binding(obj).key}
    for _ in range(3):
        make_active(obj)
        assert bpy.ops.object.gencoords_bind('INVOKE_DEFAULT') == {'FINISHED'}
        keys.add(gc.binding.binding(obj).key)
        assert [m.name for m in obj.modifiers] == ["GenCoords"]
    assert len(keys) == 4  # each Rebind replaced the binding
    assert_follows(obj, cage)


def test_apply_leaves_no_node_group_behind(gc):
    obj, cage = bound(gc)
    assert any(group.get("gencoords") for group in bpy.data.node_groups)
    make_active(obj)
    assert bpy.ops.object.modifier_apply(modifier="GenCoords") == {'FINISHED'}
    update()
    assert not bpy.data.node_groups  # the binding's group and the helpers it used
    assert mesh_state(obj)[1] == sorted(a.name for a in obj.data.attributes)


def test_object_settings_are_described(gc):
    prop = bpy.types.Object.bl_rna.properties["gencoords"]
    assert prop.description and "GenCoords" in prop.description
    for prop in bpy.types.Object.bl_rna.properties["gencoords"].fixed_type.properties:
        if prop.identifier != "rna_type":
            assert prop.description, prop.identifier


def drawn_panel(obj):
    import importlib

    from test_addon_package import RecordingLayout

    panel = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.panel")
    drawn = []
    panel.draw_settings(RecordingLayout(drawn), obj)
    return drawn


def test_the_panel_of_a_cage_says_whose_cage_it_is(gc):
    obj, cage = bound(gc)
    drawn = drawn_panel(cage)
    hint = drawn.index(("label", "This is the cage of 'Mesh'"))
    assert drawn[hint + 1] == ("operator", "object.gencoords_make_cage")
    assert not any("cage of" in str(item) for item in drawn_panel(add_sphere(name="Other")))


def test_slots_show_only_where_the_storage_is_compact(gc):
    obj, cage = bound(gc)
    assert gc.binding.binding(obj).data.storage == 'EXACT'
    assert obj.gencoords.storage == 'AUTO'  # resolved to exact: the Slots do nothing
    assert ("prop", "compact_size") not in drawn_panel(obj)
    obj.gencoords.storage = 'COMPACT'
    assert ("prop", "compact_size") in drawn_panel(obj)
    obj.gencoords.storage = 'EXACT'
    assert ("prop", "compact_size") not in drawn_panel(obj)
    obj.gencoords.storage = 'AUTO'
    obj.gencoords.cage = None  # Automatic measures and picks its own slots, bound or not
    assert ("prop", "compact_size") not in drawn_panel(obj)


class WindowStandIn:
    """What a window gives a modal operator (absent headless, where 'INVOKE_DEFAULT'
    runs execute: bpy's window has no event state), recording what the operator does."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        def record(*args, **kwargs):
            self.calls.append(name)
            return {'RUNNING_MODAL'} if name == "invoke_confirm" else name
        return record


class ContextStandIn:
    """``bpy.context`` with a window manager and workspace that record calls."""

    def __init__(self, window_manager):
        self.window_manager = self.workspace = window_manager
        self.window = "window"

    def __getattr__(self, name):
        return getattr(bpy.context, name)


def bind_operator_stand_in(operators):
    """The Bind operator's own methods on a plain object (Blender operators cannot be
    made outside a call), with its properties and reports."""
    methods = ("execute", "invoke", "modal", "_start", "_finish", "_stop", "_slice", "_show")
    cls = operators.OBJECT_OT_gencoords_bind
    stand_in = type("BindStandIn", (), {name: cls.__dict__[name] for name in methods})()
    stand_in.replace_asked = stand_in.replace_confirmed = False
    stand_in.reports = []
    stand_in.report = lambda kind, text: stand_in.reports.append(text)
    return stand_in


def test_rebind_after_the_replace_binding_question_runs_the_modal_job(gc, monkeypatch):
    """The invoke -> question -> OK -> execute -> modal chain, with stand-ins for the
    window (a real window is needed to see the question, the progress and Esc)."""
    import importlib

    from types import SimpleNamespace

    operators = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.operators")
    obj, cage = bound(gc)
    earlier = gc.binding.binding(obj).key
    make_active(obj)
    monkeypatch.setattr(operators, "interactive", lambda context: True)
    window_manager = WindowStandIn()
    context = ContextStandIn(window_manager)

    asking = bind_operator_stand_in(operators)
    assert asking.invoke(context, None) == {'RUNNING_MODAL'}  # the question is shown
    assert window_manager.calls == ["invoke_confirm"] and asking.replace_asked
    handed_over = []
    fake_ops = SimpleNamespace(object=SimpleNamespace(
        gencoords_bind=lambda *args, **kwargs: handed_over.append((args, kwargs))))
    with monkeypatch.context() as patch:  # bpy.ops itself: only for this call
        patch.setattr(operators.bpy, "ops", fake_ops)
        assert asking.execute(context) == {'CANCELLED'}  # OK: execute only hands over
    assert handed_over == [(('INVOKE_DEFAULT',), {"replace_confirmed": True})]
    assert gc.binding.binding(obj).key == earlier

    monkeypatch.setattr(gc.core.planning.bind_steps, "MAX_SLICE_SECONDS", 0.0)  # a step an event: progress shown
    monkeypatch.setattr(gc.core.planning.bind_steps, "TAIL_SECONDS", 0.0)  # no short rest run on
    running = bind_operator_stand_in(operators)
    running.replace_confirmed = True  # as the handed-over call is made
    assert running.invoke(context, None) == {'RUNNING_MODAL'}  # no second question
    assert "invoke_confirm" not in window_manager.calls[1:]
    assert {"event_timer_add", "progress_begin", "modal_handler_add"} <= set(window_manager.calls)
    assert gc.binding.binding(obj).key == earlier  # nothing written before the job ends
    timer = SimpleNamespace(type='TIMER')
    result = {'PASS_THROUGH'}  # a timer event passed on: still running
    while result == {'PASS_THROUGH'}:
        result = running.modal(context, timer)
    assert result == {'FINISHED'}
    assert "progress_update" in window_manager.calls and "progress_end" in window_manager.calls
    assert gc.binding.binding(obj).key != earlier
    assert [m.name for m in obj.modifiers] == ["GenCoords"]
    assert running.reports[-1].startswith("Bound 'Mesh' (114 vertices) to 'Cage'")

    escaped = bind_operator_stand_in(operators)  # Esc during a confirmed Rebind
    escaped.replace_confirmed = True
    latest = gc.binding.binding(obj).key
    assert escaped.invoke(context, None) == {'RUNNING_MODAL'}
    assert escaped.modal(context, SimpleNamespace(type='ESC')) == {'CANCELLED'}
    assert gc.binding.binding(obj).key == latest
    assert escaped.reports == ["Bind cancelled: nothing was changed"]


def test_a_short_bind_from_the_panel_ends_in_invoke_without_progress_or_a_redraw(gc, monkeypatch):
    """The panel's Bind runs its first slice (up to a second) before the window redraws:
    a short Bind is done when invoke returns, with no timer, progress bar or modal
    handler. A confirmed one (Rebind, Auto Rebind) runs between events, its own undo step
    pushed as it ends (Ctrl+Z after it: scripts/release/gui_check.py)."""
    import importlib

    from types import SimpleNamespace

    operators = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.operators")
    cage = add_icosphere_cage(subdivisions=2)
    obj = add_sphere()
    obj.gencoords.cage = cage
    make_active(obj)
    monkeypatch.setattr(operators, "interactive", lambda context: True)
    window_manager = WindowStandIn()
    short = bind_operator_stand_in(operators)
    assert short.invoke(ContextStandIn(window_manager), None) == {'FINISHED'}
    assert window_manager.calls == []  # no timer, progress or modal handler
    assert [m.name for m in obj.modifiers] == ["GenCoords"]
    assert short.reports[-1].startswith(f"Bound '{obj.name}'")
    assert obj.session_uid not in gc.service.MODAL_BINDS  # Auto Rebind may bind it again

    # A confirmed Bind (Rebind's question, Auto Rebind) is called from another call, which
    # pushes no undo step: however short, it runs between events and ends there.
    longer = bind_operator_stand_in(operators)
    longer.replace_confirmed = True
    assert longer.invoke(ContextStandIn(window_manager), None) == {'RUNNING_MODAL'}
    assert window_manager.calls[:3] == ["event_timer_add", "progress_begin", "modal_handler_add"]
    assert "progress_update" in window_manager.calls and "status_text_set" in window_manager.calls
    assert obj.session_uid in gc.service.MODAL_BINDS  # Auto Rebind waits for it
    longer.modal(ContextStandIn(window_manager), SimpleNamespace(type='ESC'))
    assert obj.session_uid not in gc.service.MODAL_BINDS


def test_editing_the_panel_during_a_modal_bind_changes_nothing_in_it(gc, monkeypatch):
    """The artist starts Bind (progress bar), then changes the settings before it ends:
    the binding is made with the settings of the moment Bind started."""
    import importlib

    from types import SimpleNamespace

    operators = importlib.import_module("bl_ext.user_default.gencoords.gencoords_addon.ui.operators")
    cage = add_icosphere_cage(subdivisions=2)
    other = add_cube_cage(size=5.0, name="Other")
    obj = add_sphere()
    settings = obj.gencoords
    settings.cage, settings.kind, settings.storage, settings.compact_size = cage, 'MEAN_VALUE', 'EXACT', 12
    make_active(obj)
    monkeypatch.setattr(operators, "interactive", lambda context: True)
    monkeypatch.setattr(operators.SlicedSteps, "first", lambda sliced: sliced.advance(0.0))  # invoke: a step
    monkeypatch.setattr(gc.core.planning.bind_steps, "TAIL_SECONDS", 0.0)  # no short rest run on
    context = ContextStandIn(WindowStandIn())
    running = bind_operator_stand_in(operators)
    assert running.invoke(context, None) == {'RUNNING_MODAL'}
    settings.cage, settings.kind, settings.gamma = other, 'POWER', 0.5
    settings.outside, settings.storage, settings.compact_size = 'PROJECT', 'COMPACT', 6
    result = {'PASS_THROUGH'}  # a timer event passed on: still running
    while result == {'PASS_THROUGH'}:
        result = running.modal(context, SimpleNamespace(type='TIMER'))
    assert result == {'FINISHED'}
    (found,) = gc.binding.bindings(obj)
    assert found.cage == cage and found.data.kind == "mean_value" and found.data.gamma is None
    assert found.data.outside == "raise" and found.data.storage == 'EXACT'
    assert found.data.slot_count == len(cage.data.vertices)


def test_bind_and_unbind_leave_the_cage_with_the_users_it_had(gc):
    """Blender 5.2 keeps a user of an object a removed modifier's input pointed at: the
    capture at Bind and Unbind clear the inputs first, so a deleted cage can go."""
    obj, cage = bound(gc)
    make_active(obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    obj.gencoords.cage = None
    update()
    assert cage.users == 1  # its collection alone


def test_the_panels_words_issue_37(gc):
    """Issue 37 item 8: "1e+02 %"; "turn on Auto Rebind" while it was on; "Rebind" with
    the Cage field empty; the status's figures pushing Bake to Bones below the window."""
    cage = add_icosphere_cage(radius=2.0)
    obj = add_sphere(radius=0.5, location=(4.0, 0.0, 0.0))  # wholly outside: every vertex extrapolated
    assert bind(obj, cage, outside="EXTRAPOLATE") == {'FINISHED'}
    texts = [text for text, _ in gc.status.status_lines(obj)]
    assert any(text.startswith("100 % of vertices have negative weights") for text in texts), texts

    drawn = drawn_panel(obj)
    bound_to, bake = drawn.index(("label", "Bound to 'Cage' (modifier 'GenCoords')")), \
        drawn.index(("operator", "object.gencoords_bake_bones"))
    assert bound_to < bake < drawn.index(("label", "Coordinates: Mean Value"))  # the figures below
    assert drawn[drawn.index(("operator", "object.gencoords_bind")) + 1] == ("text", "Rebind")
    obj.gencoords.cage = None
    drawn = drawn_panel(obj)
    assert drawn[drawn.index(("operator", "object.gencoords_bind")) + 1] == ("text", "Bind")

    obj.gencoords.cage, obj.gencoords.auto_rebind = cage, True
    edit_mesh(obj, lambda bm: bm.verts.new((4.0, 0.0, 0.0)))  # edited in its data, not in Edit Mode
    problem = fault_text(gc, obj)
    assert problem.startswith("Mesh edited since Bind: 1 vertices added") and "turn on" not in problem
    assert "Auto Rebind binds it on leaving Edit Mode, or Bind" in problem
