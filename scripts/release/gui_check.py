"""An artist's session in a real Blender window, driven by real key presses: run by
``scripts/chroot/panel_screenshots.sh --check`` (Blender under Xvfb, keys sent with ``xdotool``) as
``blender --python scripts/release/gui_check.py -- <scene folder> <output folder>``.

Opens ``bound.blend`` of ``panel_screenshot_scene.py`` (Suzanne bound to its cage) and,
one step per timer tick so that the window handles each key before the next check:
edits the cage (the mesh follows), deletes the cage with the Delete key (the mesh
passes through, the panel says why, the cage can be purged), undoes with Ctrl+Z (the
cage is back and drives the mesh), rebinds through the Replace Binding confirmation
(Return), finds Bake to Bones with the F3 menu search (typed) and runs it, undoes that,
then, with Auto Rebind on, deletes a vertex in Edit Mode (Tab, a click on the vertex, X >
Vertices, Tab): the Bind operator's invoke path binds again; last, Type Green, Bind
through the window (Return to replace), Ctrl+Z of that Bind and the Bind again, and a 1.6x
stretch of the cage; then Type Harmonic,
Bind through the window, a move of the cage, then a turn and scale of it; last, the cage keyed,
Tab and Tab on it, Delete and Ctrl+Z (the binding has its cage back). After the Rebind:
Unbind and a first Bind as the button makes it (it ends in its own call). Each check
prints ``PASS``/``FAIL`` with what was measured, screenshots go to the output folder,
and Blender exits non-zero when a check failed.
"""

import os
import subprocess
import sys
import traceback
from pathlib import Path

import bmesh
import bpy
import numpy as np
from bpy_extras import view3d_utils

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository (or its staged copy)
from scripts.common.blender_objects import arrays  # noqa: E402  (the add-on's mesh_arrays.py)
from scripts.pictures import panel_screenshots as shots  # noqa: E402  (window helpers, xwd capture)

SCENES, OUTPUT = map(Path, sys.argv[sys.argv.index("--") + 1:][:2])
shots.SCENES, shots.OUTPUT = SCENES, OUTPUT
EXTENSION = "bl_ext.user_default.gencoords"
STEP_SECONDS = 1.5
# The F3 key, by its X keycode (evdev, as Xvfb's default keymap has it): xdotool's keysym
# "F3" arrives in Blender as Alt+F3 (xdotool adds Alt for a level of that key in Xvfb's
# keymap), which opens no search; the keycode is the plain key, as an artist presses it.
F3_KEYCODE = "69"
FAILURES = []


def addon(name):
    return sys.modules[f"{EXTENSION}.gencoords_addon.{name}"]


def check(name, ok, measured):
    print(f"gui_check: {'PASS' if ok else 'FAIL'} {name}: {measured}", flush=True)
    if not ok:
        FAILURES.append(name)


def keys(*sequence, over='VIEW_3D'):
    """Real key presses (xdotool) with the pointer over the largest area of ``over``."""
    window, area = shots.window_and_area(over)
    x = area.x + area.width // 2
    y = window.height - (area.y + area.height // 2)
    subprocess.run(["xdotool", "mousemove", str(x), str(y)], check=True)
    for item in sequence:
        if item.startswith("type:"):
            subprocess.run(["xdotool", "type", "--delay", "30", item[5:]], check=True)
        else:
            subprocess.run(["xdotool", "key", "--delay", "80", item], check=True)


def mesh_and_cage():
    return bpy.data.objects["Suzanne"], bpy.data.objects.get("Cage")


def moved_by(obj):
    """The largest move of ``obj``'s evaluated vertices from its own (rest) positions."""
    evaluated = arrays.evaluated_positions(obj).astype(np.float64)
    return float(np.abs(evaluated - arrays.read_positions(obj.data)).max())


def status_text(obj):
    return " | ".join(text for text, _ in addon("ui.status").status_lines(obj))


def select_only(obj):
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    bpy.context.view_layer.objects.active = obj


# The steps -------------------------------------------------------------------------

def open_bound():
    shots.open_scene("bound")


def edit_cage():
    shots.set_up_views()
    mesh, cage = mesh_and_cage()
    check("at rest after opening", moved_by(mesh) < 1e-6, f"max move {moved_by(mesh):.2e}")
    positions = arrays.read_positions(cage.data).astype(np.float64)
    positions[7, 2] += 0.3  # as a user's edit: in double, stored as float32
    arrays.write_positions(cage.data, positions)
    bpy.ops.ed.undo_push(message="Move cage vertex")


def delete_cage():
    mesh, cage = mesh_and_cage()
    check("mesh follows the cage edit", moved_by(mesh) > 1e-2, f"max move {moved_by(mesh):.3f}")
    select_only(cage)
    keys("Delete")


def after_delete():
    mesh, cage = mesh_and_cage()
    in_scene = cage is not None and bpy.context.scene.objects.get(cage.name) is not None
    check("Delete removes the cage from the scene", not in_scene,
          f"cage users {cage.users if cage else 0}, in scene {in_scene}")
    check("mesh passes through after Delete", moved_by(mesh) < 1e-6, f"max move {moved_by(mesh):.2e}")
    text = status_text(mesh)
    check("panel says the cage was deleted", "delete" in text.lower(), text)
    select_only(mesh)
    shots.shoot('PROPERTIES', "deleted_cage")
    keys("ctrl+z")


def after_undo():
    mesh, cage = mesh_and_cage()
    in_scene = cage is not None and bpy.context.scene.objects.get(cage.name) is not None
    check("Ctrl+Z brings the cage back", in_scene, f"cage {cage.name if cage else None}")
    check("the mesh follows the restored cage", moved_by(mesh) > 1e-2, f"max move {moved_by(mesh):.3f}")
    select_only(mesh)
    with shots.in_area('PROPERTIES'):
        bpy.ops.object.gencoords_bind('INVOKE_DEFAULT')  # already bound: Replace Binding?
    keys("Return", over='PROPERTIES')


def after_rebind():
    mesh, _ = mesh_and_cage()
    names = [m.name for m in mesh.modifiers if m.type == 'NODES']
    check("Rebind through the confirmation binds once, named GenCoords", names == ["GenCoords"],
          f"modifiers {names}")
    check("rebound mesh at rest equals the mesh", moved_by(mesh) < 1e-5, f"max move {moved_by(mesh):.2e}")
    shots.shoot('PROPERTIES', "rebound")
    keys(F3_KEYCODE, over='VIEW_3D')  # the menu search


def screen(name):
    """The whole screen as X has it (popups included), without asking Blender to draw."""
    pixels = shots.read_xwd(subprocess.run(["xwd", "-root", "-silent"], check=True,
                                           capture_output=True).stdout)
    shots.write_png(OUTPUT / f"{name}.png", pixels)


def search_bake():
    screen("search_open")
    keys("type:Bake to Bones", over='VIEW_3D')


def run_bake():
    screen("search")
    keys("Return", over='VIEW_3D')  # the search result


def confirm_bake():
    screen("bake_options")
    keys("Return", over='VIEW_3D')  # the operator's options dialog


def after_bake():
    mesh, _ = mesh_and_cage()
    rigs = [o.name for o in bpy.data.objects if o.type == 'ARMATURE']
    kinds = [m.type for m in mesh.modifiers]
    check("F3 finds and runs Bake to Bones", bool(rigs) and 'ARMATURE' in kinds,
          f"armatures {rigs}, modifiers {kinds}")
    shots.shoot('VIEW_3D', "baked")
    keys("ctrl+z")


def after_bake_undo():
    mesh, _ = mesh_and_cage()
    kinds = [m.type for m in mesh.modifiers]
    check("Ctrl+Z undoes Bake to Bones", 'NODES' in kinds and 'ARMATURE' not in kinds,
          f"modifiers {kinds}")
    mesh.gencoords.auto_rebind = True
    select_only(mesh)
    keys("Tab")


VERTEX_COUNT = []  # Suzanne's, before the vertex is deleted


def edit_vertices():
    mesh, _ = mesh_and_cage()
    check("Tab enters Edit Mode", mesh.mode == 'EDIT', f"mode {mesh.mode}")
    VERTEX_COUNT.append(len(bmesh.from_edit_mesh(mesh.data).verts))
    keys("alt+a")


def click_vertex():
    """A left click on the vertex nearest the viewer (nothing can hide it)."""
    mesh, _ = mesh_and_cage()
    window, area = shots.window_and_area('VIEW_3D')
    region, view = shots.region(area), area.spaces.active.region_3d
    world = [mesh.matrix_world @ vertex.co for vertex in bmesh.from_edit_mesh(mesh.data).verts]
    nearest = min(world, key=lambda co: -(view.view_matrix @ co).z)
    x, y = view3d_utils.location_3d_to_region_2d(region, view, nearest)
    subprocess.run(["xdotool", "mousemove", str(round(region.x + x)),
                    str(round(window.height - (region.y + y))), "click", "1"], check=True)


def delete_vertex():
    mesh, _ = mesh_and_cage()
    selected = sum(vertex.select for vertex in bmesh.from_edit_mesh(mesh.data).verts)
    check("a click selects one vertex", selected == 1, f"{selected} selected")
    keys("x")


def pick_vertices():
    screen("delete_menu")
    keys("v")  # the menu's accelerator for Vertices (underlined)


def leave_edit_mode():
    mesh, _ = mesh_and_cage()
    count = len(bmesh.from_edit_mesh(mesh.data).verts)
    check("X > Vertices deletes the vertex", count == VERTEX_COUNT[0] - 1,
          f"{VERTEX_COUNT[0]} -> {count} vertices")
    keys("Tab")


def after_auto_rebind():
    mesh, _ = mesh_and_cage()
    found = addon("bind.bindings").binding(mesh)
    bound = found.data.mesh_vertex_count if found else None
    check("Tab out of Edit Mode rebinds (Auto Rebind)",
          mesh.mode == 'OBJECT' and bound == len(mesh.data.vertices) == VERTEX_COUNT[0] - 1,
          f"mode {mesh.mode}, bound {bound} of {len(mesh.data.vertices)} vertices")
    check("auto-rebound mesh at rest equals the mesh", moved_by(mesh) < 1e-5,
          f"max move {moved_by(mesh):.2e}")
    # Only a modal operator finishing in the event loop is registered here (the handler's
    # synchronous bind is none); replace_confirmed is what only Auto Rebind's timer passes.
    last = bpy.context.window_manager.operators[-1]
    confirmed = last.bl_idname == "OBJECT_OT_gencoords_bind" and last.properties.replace_confirmed
    check("Auto Rebind went through the Bind operator's invoke path (progress, Esc)", confirmed,
          f"last operator {last.bl_idname}, replace_confirmed "
          f"{getattr(last.properties, 'replace_confirmed', None)}")
    shots.shoot('VIEW_3D', "auto_rebound")


def green_rebind():
    """Type Green in the panel, then Bind through the window (Replace Binding: Return)."""
    mesh, _ = mesh_and_cage()
    select_only(mesh)
    mesh.gencoords.kind = addon("enums").GREEN.upper()
    bpy.ops.ed.undo_push(message="Type")  # as the panel's Type field does when clicked
    shots.shoot('PROPERTIES', "green_type")
    bind_in_window()


def bind_in_window():
    """The panel's Bind button, its Replace Binding question answered with Return."""
    with shots.in_area('PROPERTIES'):
        bpy.ops.object.gencoords_bind('INVOKE_DEFAULT')
    keys("Return", over='PROPERTIES')


def undo_green_bind():
    """Ctrl+Z right after the panel's Bind (a short Bind ends in the button's own call)."""
    mesh, _ = mesh_and_cage()
    found = addon("bind.bindings").binding(mesh)
    GUI_STATE["green bound"] = found.data.kind if found else None
    keys("ctrl+z")


def after_green_undo():
    mesh, _ = mesh_and_cage()
    found = addon("bind.bindings").binding(mesh)
    kind = found.data.kind if found else None
    check("Ctrl+Z after the panel's Bind gives the earlier binding back",
          GUI_STATE["green bound"] == addon("enums").GREEN and kind not in (None, addon("enums").GREEN)
          and moved_by(mesh) < 1e-5, f"kind {GUI_STATE['green bound']} -> {kind}, max move {moved_by(mesh):.2e}")
    bind_in_window()  # Type is still Green: Bind again (checked next)


def after_green_bind():
    mesh, cage = mesh_and_cage()
    found = addon("bind.bindings").binding(mesh)
    kind = found.data.kind if found else None
    check("Bind with Type Green binds Green coordinates (again after Ctrl+Z)", kind == addon("enums").GREEN,
          f"kind {kind}")
    check("Green binding at rest equals the mesh", moved_by(mesh) < 1e-5, f"max move {moved_by(mesh):.2e}")
    text = status_text(mesh)
    check("the panel names Green", "Coordinates: Green" in text, text)
    positions = arrays.read_positions(cage.data).astype(np.float64)
    centre = positions.mean(axis=0)
    arrays.write_positions(cage.data, centre + (positions - centre) * (1.6, 1.0, 1.0))
    bpy.ops.ed.undo_push(message="Stretch cage")


def after_green_stretch():
    mesh, _ = mesh_and_cage()
    evaluated = arrays.evaluated_positions(mesh).astype(np.float64)
    rest = arrays.read_positions(mesh.data)
    widths = np.ptp(evaluated, axis=0) / np.ptp(rest, axis=0)
    check("the mesh follows the stretched cage with Green coordinates",
          np.isfinite(evaluated).all() and 1.1 < widths[0] < 1.6,
          f"width ratios {np.round(widths, 3).tolist()}")
    shots.shoot('VIEW_3D', "green_stretched")
    shots.shoot('PROPERTIES', "green_bound")


def harmonic_rebind():
    """Type Harmonic in the panel, then Bind through the window (Replace Binding: Return)."""
    mesh, _ = mesh_and_cage()
    select_only(mesh)
    mesh.gencoords.kind = addon("enums").HARMONIC.upper()
    bind_in_window()


HARMONIC_SHIFT = np.array([0.3, -0.2, 0.1])


def after_harmonic_bind():
    mesh, cage = mesh_and_cage()
    found = addon("bind.bindings").binding(mesh)
    data = found.data if found else None
    check("Bind with Type Harmonic binds harmonic coordinates, stored sparse",
          data is not None and data.kind == addon("enums").HARMONIC and data.storage == 'SPARSE',
          f"kind {data and data.kind}, storage {data and data.storage}")
    check("harmonic weights are never negative", data is not None and data.min_coordinate >= 0.0,
          f"smallest {data and data.min_coordinate}")
    check("Harmonic binding at rest equals the mesh", moved_by(mesh) < 1e-5, f"max move {moved_by(mesh):.2e}")
    text = status_text(mesh)
    check("the panel names Harmonic", "Coordinates: Harmonic" in text, text)
    shots.shoot('PROPERTIES', "harmonic_bound")
    arrays.write_positions(cage.data, arrays.read_positions(cage.data).astype(np.float64) + HARMONIC_SHIFT)
    bpy.ops.ed.undo_push(message="Move cage")


def after_harmonic_move():
    mesh, _ = mesh_and_cage()
    moved = arrays.evaluated_positions(mesh).astype(np.float64) - arrays.read_positions(mesh.data)
    error = np.abs(moved - HARMONIC_SHIFT).max()
    check("the mesh follows the cage's translation with harmonic coordinates", error < 1e-5,
          f"largest error {error:.1e}")
    shots.shoot('VIEW_3D', "harmonic_moved")
    mesh, cage = mesh_and_cage()
    cage_rest = arrays.read_positions(cage.data).astype(np.float64)
    centre = cage_rest.mean(axis=0)
    arrays.write_positions(cage.data, (cage_rest - centre) @ HARMONIC_TURN.T + centre)
    bpy.ops.ed.undo_push(message="Turn cage")


# A turn of 30 degrees about z and a scale of 1.2 (about the cage's centre): an affine map
# harmonic coordinates now follow exactly (they place every vertex: docs/MATH.md).
HARMONIC_TURN = 1.2 * np.array([[np.cos(np.pi / 6), -np.sin(np.pi / 6), 0.0],
                                [np.sin(np.pi / 6), np.cos(np.pi / 6), 0.0], [0.0, 0.0, 1.0]])


def after_harmonic_turn():
    """The cage (already moved by HARMONIC_SHIFT) turned and scaled: every mesh vertex
    lands where that affine map of the cage, seen from the mesh, puts it."""
    mesh, cage = mesh_and_cage()
    to_mesh = np.linalg.inv(np.array(mesh.matrix_world)) @ np.array(cage.matrix_world)
    cage_now = arrays.read_positions(cage.data).astype(np.float64)
    cage_before = (cage_now - cage_now.mean(axis=0)) @ np.linalg.inv(HARMONIC_TURN).T + cage_now.mean(axis=0)
    centre = cage_before.mean(axis=0)
    affine = np.eye(4)
    affine[:3, :3], affine[:3, 3] = HARMONIC_TURN, centre - HARMONIC_TURN @ centre
    in_mesh = to_mesh @ affine @ np.linalg.inv(to_mesh)  # the map, in the mesh's space
    shifted = arrays.read_positions(mesh.data).astype(np.float64) + HARMONIC_SHIFT
    expected = shifted @ in_mesh[:3, :3].T + in_mesh[:3, 3]
    evaluated = arrays.evaluated_positions(mesh).astype(np.float64)
    size = float(np.linalg.norm(np.ptp(cage_now, axis=0)))
    error = float(np.linalg.norm(evaluated - expected, axis=1).max()) / size
    check("the mesh follows a turned and scaled cage with harmonic coordinates (linear precision)",
          error < 1e-5, f"largest error {error:.1e} of the cage's size")
    shots.shoot('VIEW_3D', "harmonic_turned")


def key_the_cage_and_tab():
    """Issue 37 item 1: an animated cage, Tab and Tab on it (Edit Mode and back), then
    Delete and Ctrl+Z must give the binding its cage back."""
    mesh, cage = mesh_and_cage()
    cage.keyframe_insert("location", frame=bpy.context.scene.frame_current)
    bpy.ops.ed.undo_push(message="Insert keyframe")
    select_only(cage)
    keys("Tab")


def tab_back():
    _, cage = mesh_and_cage()
    check("Tab puts the cage in Edit Mode", cage.mode == 'EDIT', f"mode {cage.mode}")
    keys("Tab")


def delete_edited_cage():
    _, cage = mesh_and_cage()
    check("Tab again leaves Edit Mode", cage.mode == 'OBJECT', f"mode {cage.mode}")
    GUI_STATE["moved before delete"] = moved_by(mesh_and_cage()[0])
    select_only(cage)
    keys("Delete")


def undo_edited_cage_delete():
    mesh, cage = mesh_and_cage()
    in_scene = cage is not None and bpy.context.scene.objects.get(cage.name) is not None
    check("Delete after Tab, Tab removes the cage", not in_scene and moved_by(mesh) < 1e-6,
          f"in scene {in_scene}, max move {moved_by(mesh):.2e}")
    keys("ctrl+z")


def after_edited_cage_undo():
    mesh, cage = mesh_and_cage()
    in_scene = cage is not None and bpy.context.scene.objects.get(cage.name) is not None
    before, now = GUI_STATE["moved before delete"], moved_by(mesh)
    check("Ctrl+Z after Tab, Tab, Delete: the cage drives the mesh again", in_scene and abs(now - before) < 1e-5,
          f"in scene {in_scene}, max move {now:.3f} (before Delete {before:.3f})")
    text = status_text(mesh)
    check("the panel no longer says the cage was deleted", "delete" not in text.lower(), text)
    shots.shoot('PROPERTIES', "cage_undone_after_edit_mode")


def first_bind_in_one_call():
    """Unbind, then a first Bind as the button makes it (an undo-pushing call: a Python
    call pushes none): short, it ends in its own call, registered as the last operator."""
    mesh, _ = mesh_and_cage()
    select_only(mesh)
    with shots.in_area('PROPERTIES'):
        bpy.ops.object.gencoords_unbind()
        result = bpy.ops.object.gencoords_bind('INVOKE_DEFAULT', True)
    bound = addon("bind.bindings").binding(mesh) is not None
    last = bpy.context.window_manager.operators[-1].bl_idname
    check("a short first Bind from the panel ends in its own call", result == {'FINISHED'} and bound
          and not addon("bind.service").MODAL_BINDS and last == "OBJECT_OT_gencoords_bind",
          f"{result}, bound {bound}, last operator {last}")


GUI_STATE = {}


STEPS = [open_bound, edit_cage, delete_cage, after_delete, after_undo, after_rebind,
         first_bind_in_one_call,
         search_bake, run_bake, confirm_bake, after_bake, after_bake_undo,
         edit_vertices, click_vertex, delete_vertex, pick_vertices, leave_edit_mode,
         after_auto_rebind, green_rebind, undo_green_bind, after_green_undo, after_green_bind, after_green_stretch,
         harmonic_rebind, after_harmonic_bind, after_harmonic_move, after_harmonic_turn,
         key_the_cage_and_tab, tab_back, delete_edited_cage, undo_edited_cage_delete, after_edited_cage_undo]


def run_next_step():
    # A modal Bind (Rebind, Auto Rebind, Green) still computing: its step's checks wait
    # for it (a loaded machine can take longer than STEP_SECONDS).
    if addon("bind.service").MODAL_BINDS:
        return 0.25
    try:
        STEPS.pop(0)()
    except Exception:
        traceback.print_exc()
        FAILURES.append("exception")
        STEPS.clear()
    if STEPS:
        return STEP_SECONDS
    print(f"gui_check: {len(FAILURES)} failed", flush=True)
    os._exit(1 if FAILURES else 0)


OUTPUT.mkdir(parents=True, exist_ok=True)
bpy.app.timers.register(run_next_step, first_interval=3.0, persistent=True)
