"""Bind from the panel against Bind from a script, in a real Blender window (issue 35,
item 6: the panel's Bind within 1.1 times a script's): run by
``scripts/chroot/panel_screenshots.sh --timing`` as
``blender --python scripts/release/gui_bind_timing.py -- <scene folder> <output folder>``.

The character of ``tests/fixtures/character.py`` (about 43,000 vertices) in its box-modelled
cage, bound Harmonic (the default Automatic grid) ``ROUNDS`` times each way, in turns:
from a script (the operator's execute, as ``blender -b`` pipelines call it) and through
the window (the operator's invoke: modal, with progress and Esc, the window redrawing
between its steps). Measured: the wall time from the call to the binding written (the
window's: polled every 10 ms) and the time the binding reports (``bind_seconds``).
Prints ``PASS``/``FAIL`` with the medians and exits non-zero when the window's median
wall time is over ``LIMIT`` times the script's.
"""

import os
import statistics
import sys
import time
from pathlib import Path

import bpy

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))  # the repository (or its staged copy): tests.fixtures
from scripts.pictures import panel_screenshots as shots  # noqa: E402
from tests.fixtures import character  # noqa: E402

EXTENSION = "bl_ext.user_default.gencoords"
ROUNDS = 3
LIMIT = 1.1
TIMES = {"script": [], "window": [], "script reported": [], "window reported": []}
STATE = {}


def addon(name):
    return sys.modules[f"{EXTENSION}.gencoords_addon.{name}"]


def mesh_object(name, vertices, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), [], faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def set_up():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    vertices, triangles, _ = character.body_mesh(1.0)
    body = mesh_object("Body", vertices, triangles)
    cage = mesh_object("Cage", *character.character_cage())
    cage.display_type = 'WIRE'
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == body)
    bpy.context.view_layer.objects.active = body
    body.gencoords.cage, body.gencoords.kind = cage, 'HARMONIC'
    print(f"gui_bind_timing: {len(body.data.vertices)} vertices in a {len(cage.data.vertices)}-vertex cage",
          flush=True)


def unbind(body):
    if addon("bind.bindings").binding(body) is not None:
        with shots.in_area('VIEW_3D'):
            bpy.ops.object.gencoords_unbind()


def reported(body):
    return addon("bind.bindings").binding(body).data.bind_seconds


def script_bind():
    body = bpy.data.objects["Body"]
    unbind(body)
    started = time.perf_counter()
    with shots.in_area('VIEW_3D'):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    TIMES["script"].append(time.perf_counter() - started)
    TIMES["script reported"].append(reported(body))


def window_bind():
    body = bpy.data.objects["Body"]
    unbind(body)
    STATE["started"] = time.perf_counter()
    with shots.in_area('VIEW_3D'):
        assert bpy.ops.object.gencoords_bind('INVOKE_DEFAULT') == {'RUNNING_MODAL'}


def window_bound():
    """Polled: the modal Bind has ended (the binding written)."""
    if addon("bind.service").MODAL_BINDS:
        return False
    TIMES["window"].append(time.perf_counter() - STATE["started"])
    TIMES["window reported"].append(reported(bpy.data.objects["Body"]))
    return True


def finish():
    medians = {name: statistics.median(values) for name, values in TIMES.items()}
    ratio = medians["window"] / medians["script"]
    print("gui_bind_timing: " + ", ".join(f"{name} {', '.join(f'{v:.2f}' for v in values)} s"
                                          for name, values in TIMES.items()), flush=True)
    ok = ratio <= LIMIT
    print(f"gui_bind_timing: {'PASS' if ok else 'FAIL'} Bind from the window within {LIMIT}x a script's: "
          f"median {medians['window']:.2f} s against {medians['script']:.2f} s ({ratio:.2f}x; "
          f"reported {medians['window reported']:.2f} against {medians['script reported']:.2f} s)", flush=True)
    os._exit(0 if ok else 1)


STEPS = [set_up] + [step for _ in range(ROUNDS) for step in (script_bind, window_bind, window_bound)] + [finish]


def run_next_step():
    step = STEPS[0]
    if step() is False:  # a poll not yet done: again in 10 ms
        return 0.01
    STEPS.pop(0)
    return 0.01 if STEPS and STEPS[0] is window_bound else 1.0


bpy.app.timers.register(run_next_step, first_interval=3.0, persistent=True)
