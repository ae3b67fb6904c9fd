"""The one Bind path: the Bind operator (run to the end or modal), Auto Rebind and scripts
all bind through here, with the same Edit Mode handling, progress, worker fallback and
reports.

``begin(obj, context)`` reads and checks (``BindJob``, out of Edit Mode), the caller runs
``steps(job, context)``, computing then writing (between events, or to the end), and
``finish(job, context)`` returns the report; ``bind(obj, context)`` does all three.
Failures are ``BindError``.
"""

import contextlib
import time
import warnings
from dataclasses import dataclass

import bpy

from ... import core
from .. import messages
from ..steps import run_to_end, scaled
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
    in Blender's process instead: (its result, None or the message saying so).

    The message is also printed to the system console with the full cause. Other
    warnings are passed on.
    """
    def at_once(count):
        return compute(count)
        yield  # unreached: a generator of no steps

    return run_to_end(steps_in_workers_or_blender(at_once, workers))


def steps_in_workers_or_blender(make_steps, workers):
    """:func:`in_workers_or_blender` for work in steps (``make_steps(workers)``, a
    generator of fractions, see ``steps.py``): yields its fractions and returns (its
    result, None or the message saying the workers failed); where they fail, the steps
    start again in Blender's process."""
    failure = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", core.WorkerWarning)  # automatic counts fall back here
        try:
            result = yield from make_steps(workers)
        except core.WorkerError as error:  # an explicit count
            failure = error
            result = yield from make_steps(1)
    for warning in caught:
        if issubclass(warning.category, core.WorkerWarning):
            failure = warning.message
        else:
            warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)
    if failure is None:
        return result, None
    message = messages.worker_fallback()
    print(f"GenCoords: {message}\n  cause: {failure}", flush=True)
    return result, message


def begin(obj, context):
    """A ``BindJob`` for ``obj`` and its chosen cage, read out of Edit Mode; BindError
    when it cannot bind."""
    started = time.perf_counter()  # the artist's wait starts here
    with object_mode(context, obj):
        return bind_job.BindJob(obj, context, in_workers_or_blender, started)


# Of a Bind's progress, the computing's share; the writing takes the rest.
COMPUTING = 0.9


def steps(job, context):
    """The whole Bind of ``job``: computing, then writing (out of Edit Mode), a generator
    yielding the fraction done. Closed early (Esc), it leaves the file as it was."""
    yield from scaled(job.steps(), 0.0, COMPUTING)
    with object_mode(context, job.obj):
        yield from scaled(job.commit_steps(), COMPUTING, 1.0 - COMPUTING)


def finish(job, context):
    """The written ``job``'s ``BindReport``: a warning where the worker processes failed,
    or where the mesh already follows the cage through a rig baked from it."""
    data = job.result.data
    headline = (f"Bound '{job.obj.name}' ({data.mesh_vertex_count} vertices) to "
                f"'{job.cage.name}' in {data.bind_seconds:.2f} s ({data.storage.lower()} storage)")
    notes = [] if job.worker_failure is None else [job.worker_failure]
    notes += [messages.follows_twice(job.obj.name, job.cage.name, modifier, rig)
              for modifier, rig in bindings.armatures_following(job.obj, job.cage)]
    return BindReport('WARNING', "; ".join([headline] + notes)) if notes else BindReport('INFO', headline)


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
    run_to_end(steps(job, context), print_progress(job))
    return finish(job, context)
