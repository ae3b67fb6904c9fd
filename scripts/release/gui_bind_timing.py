"""Bind from the panel against Bind from a script, in a real Blender window (issue 35,
item 6: the panel's Bind within 1.1 times a script's): run by
``scripts/chroot/panel_screenshots.sh --timing`` as
``blender --python scripts/release/gui_bind_timing.py -- <scene folder> <output folder>``.

The character of ``tests/fixtures/character.py`` (about 43,000 vertices) in its box-modelled
cage, bound Harmonic (the default Automatic grid) ``ROUNDS`` times each way, in turns:
from a script (the operator's execute, as ``blender -b`` pipelines call it) and through
the window (the operator's invoke: modal, with progress and Esc, the window redrawing
between its steps), each after a step in which the window drew the unbound mesh.
Measured: the wall time from the call to the binding written (the window's: to the end
of its last slice of steps), the time the binding reports (``bind_seconds``), and where
the window's time went (in the steps, between them, viewport redraws).
Prints ``PASS``/``FAIL`` with the medians and exits non-zero when the window's median
wall time is over ``LIMIT`` times the script's.
"""

import os
import statistics
import sys
import time
import traceback
from pathlib import Path

import bpy

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))  # the repository (or its staged copy): tests.fixtures
from scripts.common.blender_objects import add_mesh_object  # noqa: E402
from scripts.pictures import panel_screenshots as shots  # noqa: E402
from tests.fixtures import character  # noqa: E402

EXTENSION = "bl_ext.user_default.gencoords"
ROUNDS = 3
LIMIT = 1.1
TIMES = {"script": [], "window": [], "script reported": [], "window reported": []}
STATE = {}


def addon(name):
    return sys.modules[f"{EXTENSION}.gencoords_addon.{name}"]


def set_up():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    vertices, triangles, _ = character.body_mesh(1.0)
    body = add_mesh_object("Body", vertices, triangles)
    cage = add_mesh_object("Cage", *character.character_cage())
    cage.display_type = 'WIRE'
    bpy.context.view_layer.update()
    cage.select_set(False)
    body.select_set(True)
    bpy.context.view_layer.objects.active = body
    body.gencoords.cage, body.gencoords.kind = cage, addon("enums").HARMONIC.upper()
    print(f"gui_bind_timing: {len(body.data.vertices)} vertices in a {len(cage.data.vertices)}-vertex cage",
          flush=True)


def unbind(body):
    if addon("bind.bindings").binding(body) is not None:
        with shots.in_area('VIEW_3D'):
            bpy.ops.object.gencoords_unbind()


def reported(body):
    return addon("bind.bindings").binding(body).data.bind_seconds


def unbind_body():
    """Unbind a step before each Bind: the window redraws the unbound mesh before the
    clock starts, as an artist's window has long done before they click Bind."""
    unbind(bpy.data.objects["Body"])


def script_bind():
    body = bpy.data.objects["Body"]
    started = time.perf_counter()
    with shots.in_area('VIEW_3D'):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    TIMES["script"].append(time.perf_counter() - started)
    TIMES["script reported"].append(reported(body))


def timed_advance():
    """The window's slices of steps timed (``ui.modal.SlicedSteps.advance``, as the Bind
    operator runs them): where the window's wait goes, in the steps or between them."""
    sliced = addon("ui.modal").SlicedSteps
    advance = STATE.setdefault("advance", sliced.advance)
    slices = STATE["slices"] = []

    def timed(self, seconds=None):
        started = time.perf_counter()
        try:
            return advance(self, seconds)
        finally:
            slices.append((started, time.perf_counter()))
    sliced.advance = timed


def count_viewport_draws():
    STATE["draws"] = []
    if "handler" not in STATE:
        STATE["handler"] = bpy.types.SpaceView3D.draw_handler_add(
            lambda: STATE["draws"].append(time.perf_counter()), (), 'WINDOW', 'POST_PIXEL')


def window_bind(kind='PROPERTIES', region='WINDOW'):
    """The Bind button clicked: in the Properties editor's panel (default) or in the 3D
    View's sidebar (``'VIEW_3D', 'UI'``)."""
    timed_advance()
    count_viewport_draws()
    STATE["door"] = f"{kind} {region}"
    window, area = shots.window_and_area(kind)
    STATE["started"] = time.perf_counter()
    with bpy.context.temp_override(window=window, screen=window.screen, area=area, region=shots.region(area, region)):
        # The first slice runs in invoke: a Bind shorter than that slice ends there.
        assert bpy.ops.object.gencoords_bind('INVOKE_DEFAULT') in ({'RUNNING_MODAL'}, {'FINISHED'})


def sidebar_bind():
    window_bind('VIEW_3D', 'UI')


def window_bound():
    """Polled: the modal Bind has ended (the binding written)."""
    if addon("bind.service").MODAL_BINDS:
        return False
    slices = STATE["slices"]
    # To the end of the last slice, as the script's call: the redraw of the bound mesh
    # after it is the same for both.
    TIMES["window"].append(slices[-1][1] - STATE["started"])
    inside = sum(end - start for start, end in slices)
    gaps = [later[0] - earlier[1] for earlier, later in zip(slices, slices[1:])]
    print(f"gui_bind_timing: window ({STATE['door']}): {len(slices)} slices, {inside:.2f} s in the steps, "
          f"{sum(gaps):.2f} s between them (largest {max(gaps, default=0.0):.3f} s), "
          f"{slices[0][0] - STATE['started']:.3f} s before the first; the viewport drawn "
          f"{len(STATE['draws'])} times", flush=True)
    marks = sorted([(start, "slice") for start, _ in slices] + [(end, "end") for _, end in slices]
                   + [(drawn, "DRAW") for drawn in STATE["draws"]])
    print("gui_bind_timing:   " + " ".join(f"{what}@{when - STATE['started']:.2f}" for when, what in marks), flush=True)
    TIMES["window reported"].append(reported(bpy.data.objects["Body"]))
    return True


class BareModal(bpy.types.Operator):
    """A modal operator doing nothing for ``TICKS`` timer events (a diagnosis: does the
    window redraw the viewport after each modal call of any operator?)."""

    bl_idname = "wm.gencoords_timing_bare_modal"
    bl_label = "Bare Modal"
    TICKS = 5

    def invoke(self, context, event):
        self._ticks, self._timer = 0, context.window_manager.event_timer_add(0.05, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        if event.type != 'TIMER':
            return {'PASS_THROUGH'}
        self._ticks += 1
        if STATE.get("bare status"):
            context.workspace.status_text_set(f"tick {self._ticks}")
            context.window_manager.progress_update(self._ticks / self.TICKS)
        if self._ticks < self.TICKS:
            return {STATE.get("bare answer", 'RUNNING_MODAL')}
        context.window_manager.event_timer_remove(self._timer)
        STATE["bare done"] = True
        return {'FINISHED'}


def bare_modal(answer='RUNNING_MODAL'):
    if not hasattr(bpy.types, "WM_OT_gencoords_timing_bare_modal"):
        bpy.utils.register_class(BareModal)
    STATE["bare answer"], STATE["bare done"] = answer, False
    count_viewport_draws()
    window, area = shots.window_and_area('PROPERTIES')
    with bpy.context.temp_override(window=window, screen=window.screen, area=area, region=shots.region(area)):
        bpy.ops.wm.gencoords_timing_bare_modal('INVOKE_DEFAULT')


def bare_modal_done():
    if not STATE.get("bare done"):
        return False
    print(f"gui_bind_timing: a bare modal operator answering {STATE['bare answer']}"
          f"{' with status text and progress' if STATE.get('bare status') else ''}, {BareModal.TICKS} timer "
          f"events: the viewport drawn "
          f"{len(STATE['draws'])} times", flush=True)
    return True


def bare_modal_passing():
    bare_modal('PASS_THROUGH')


def bare_modal_passing_with_status():
    STATE["bare status"] = True
    bare_modal('PASS_THROUGH')


def redraw_costs():
    """What the window pays each time it gets control back: a whole redraw, and each
    editor's region alone (``wm.redraw_timer``), with the mesh bound."""
    costs = {}
    for kind, what in (('VIEW_3D', 'DRAW_WIN'), ('VIEW_3D', 'DRAW'), ('PROPERTIES', 'DRAW')):
        with shots.in_area(kind):
            started = time.perf_counter()
            bpy.ops.wm.redraw_timer(type=what, iterations=3)
            costs[f"{what} {kind}"] = (time.perf_counter() - started) / 3
    started = time.perf_counter()
    addon("ui.status").status_lines(bpy.data.objects["Body"])
    costs["status_lines"] = time.perf_counter() - started
    print("gui_bind_timing: redraw costs " + ", ".join(f"{name} {seconds * 1e3:.0f} ms"
                                                      for name, seconds in costs.items()), flush=True)


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


STEPS = ([set_up] + [step for _ in range(ROUNDS)
                     for step in (unbind_body, script_bind, unbind_body, window_bind, window_bound)]
         + [unbind_body, sidebar_bind, window_bound, bare_modal, bare_modal_done, bare_modal_passing, bare_modal_done,
            bare_modal_passing_with_status, bare_modal_done, redraw_costs, finish])


def run_next_step():
    step = STEPS[0]
    try:
        polled = step()
    except Exception:  # a failed step ends the session: it never waits on
        traceback.print_exc()
        print(f"gui_bind_timing: FAIL {step.__name__} raised", flush=True)
        os._exit(1)
    if polled is False:  # a poll not yet done: again in 10 ms
        return 0.01
    STEPS.pop(0)
    return 0.01 if STEPS and STEPS[0] in (window_bound, bare_modal_done) else 1.0



bpy.app.timers.register(run_next_step, first_interval=3.0, persistent=True)
