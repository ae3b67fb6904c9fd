"""The one Bind path: the Bind operator (run to the end or modal), Auto Rebind and scripts
all bind through here, with the same Edit Mode handling, progress, worker fallback and
reports.

``begin(obj, context)`` reads and checks (``BindJob``, out of Edit Mode), the caller runs
``steps(job, context)``, computing then writing (between events, or to the end), and
``finish(job, context)`` returns the report; ``bind(obj, context)`` does all three.
Failures are ``BindError``. The decisions that need no Blender (the order and shares of
the steps, the workers' fallback, the report's level) are the core's
(``core.planning.bind_steps``); this module hands it the Blender side.
"""

import contextlib
import time
from dataclasses import dataclass

import bpy

from ...core.planning import bind_steps
from .. import messages
from . import bindings
from . import job as bind_job


# Meshes (Object.session_uid) a modal Bind is computing for: Auto Rebind waits for it
# rather than start a second one (tabbing in and out of Edit Mode meanwhile).
MODAL_BINDS = set()


@dataclass(frozen=True)
class BindReport:
    """What a finished Bind tells the artist: ``level`` 'INFO', or 'WARNING' where the
    worker processes failed and Blender computed instead."""

    level: str
    message: str


@contextlib.contextmanager
def object_mode(context, obj):
    """Leave Edit Mode for the block (bind data are written to the mesh, which Edit Mode
    would overwrite on exit), and return to it afterwards."""
    editing = obj.mode == 'EDIT'
    if editing:
        bpy.ops.object.mode_set(mode='OBJECT')  # also writes the edit into the mesh
    try:
        yield
    finally:
        if editing and context.view_layer.objects.active == obj:
            bpy.ops.object.mode_set(mode='EDIT')


def in_workers_or_blender(compute, workers):
    """``compute(workers)``; where the worker processes cannot start or fail, ``compute(1)``
    in Blender's process instead (``core.planning.bind_steps.in_workers_or_here``): (its
    result, None or the message saying so).

    The message is also printed to the system console with the full cause.
    """
    result, failure = bind_steps.in_workers_or_here(compute, workers)
    return result, _fallback_message(failure)


def steps_in_workers_or_blender(make_steps, workers):
    """:func:`in_workers_or_blender` for work in steps (``make_steps(workers)``, a
    generator of fractions, see ``steps.py``): yields its fractions and returns (its
    result, None or the message saying the workers failed); where they fail, the steps
    start again in Blender's process."""
    result, failure = yield from bind_steps.steps_in_workers_or_here(make_steps, workers)
    return result, _fallback_message(failure)


def _fallback_message(failure):
    """None for no failure, else the panel's words for it, printed to the system console
    with the full cause."""
    if failure is None:
        return None
    message = messages.worker_fallback()
    print(f"GenCoords: {message}\n  cause: {failure}", flush=True)
    return message


def begin(obj, context):
    """A ``BindJob`` for ``obj`` and its chosen cage, read out of Edit Mode; BindError
    when it cannot bind."""
    started = time.perf_counter()  # the artist's wait starts here
    with object_mode(context, obj):
        return bind_job.BindJob(obj, context, in_workers_or_blender, started)


# Of a Bind's progress, the computing's share; the writing takes the rest.
COMPUTING = bind_steps.COMPUTING


class BlenderSide:
    """A ``BindJob`` as the core's ``BindTool`` (the whole Bind): it writes out of Edit
    Mode and reports progress in background mode."""

    def __init__(self, job, context):
        self.job, self.context = job, context
        self.report_progress = print_progress(job)

    def compute_steps(self):
        return self.job.steps()

    def write_binding(self):
        with object_mode(self.context, self.job.obj):
            return (yield from self.job.commit_steps())


def steps(job, context):
    """The whole Bind of ``job``: computing, then writing (out of Edit Mode), a generator
    yielding the fraction done (``core.planning.bind_steps.bind_steps``). Closed early
    (Esc), it leaves the file as it was."""
    return bind_steps.bind_steps(BlenderSide(job, context))


def finish(job, context):
    """The written ``job``'s ``BindReport``: a warning where the worker processes failed,
    or where the mesh already follows the cage through a rig baked from it."""
    data = job.result.data
    headline = (f"Bound '{job.obj.name}' ({data.mesh_vertex_count} vertices) to "
                f"'{job.cage.name}' in {data.bind_seconds:.2f} s ({data.storage.lower()} storage)")
    notes = [] if job.worker_failure is None else [job.worker_failure]
    notes += [messages.follows_twice(job.obj.name, job.cage.name, modifier, rig)
              for modifier, rig in bindings.armatures_following(job.obj, job.cage)]
    return BindReport(*bind_steps.bind_report(headline, notes))


def print_progress(job):
    """A ``report(fraction)`` printing every tenth in background mode (no progress bar)."""
    printed = [0.0]

    def report(fraction):
        if bpy.app.background and fraction - printed[0] >= 0.1 and fraction < 1.0:
            printed[0] = fraction
            print(f"GenCoords: binding '{job.obj.name}' {fraction:.0%}", flush=True)
    return report


def bind(obj, context):
    """Bind ``obj`` to its chosen cage, to the end (scripts, background mode, Auto Rebind
    there); its ``BindReport``. BindError when it cannot bind; nothing is changed then."""
    job = begin(obj, context)
    bind_steps.bind(BlenderSide(job, context))
    return finish(job, context)
