"""A Bind's steps without Blender: planning on what the Blender side read, computing then
writing with the progress and the cancel between steps, the fallback from worker
processes to one process, and the report. The Blender side comes in as a ``tool`` whose
methods are declared (:class:`PlanTool` for the planning, :class:`BindTool` for the whole
Bind): the add-on's ``bind.job.BindJob`` and ``bind.service.BlenderSide`` are those, tests
pass stand-ins (``tests/core/test_bind_steps.py``).

Steps are generators yielding the fraction done (0 to 1) and returning their result:
closing one early (Esc) cancels it and what it runs.
"""

import time
import warnings
from typing import Protocol

import numpy as np

from ..base.errors import WorkerError, WorkerWarning
from . import bind_plan

__all__ = ["BindTool", "COMPUTING", "PlanTool", "WorkerFallback", "bind", "bind_report", "bind_steps",
           "computing_frame", "advance", "slice_seconds", "in_workers_or_here", "plan_steps", "run_to_end", "scaled", "zero_scale_axes"]

COMPUTING = 0.9  # of a Bind's progress, the computing's share; the writing takes the rest


class PlanTool(Protocol):
    """What the planning (:func:`plan_steps`) asks of the Blender side."""

    def read_input(self):
        """The mesh and the cage as read and checked: ``points`` (k, 3), ``cage_vertices``
        (n, 3) float64 and ``triangles`` (m, 3) int attributes, in the frame the coordinates
        are computed in."""

    def plan_request(self, run):
        """The settings as a ``bind_plan.BindRequest`` whose ``run`` is ``run``."""

    def record(self, plan):
        """Keep ``plan`` (a ``bind_plan.BindPlan``) as what will be written."""


class BindTool(Protocol):
    """What the whole Bind (:func:`bind_steps`, :func:`bind`) asks of the Blender side."""

    def compute_steps(self):
        """The computing (:func:`plan_steps` with the Blender side's errors): steps."""

    def write_binding(self):
        """The writing of what was recorded: steps returning the binding; closed early,
        nothing written stays."""

    def report_progress(self, fraction):
        """Show the fraction done (a progress bar, a line in background mode)."""


def scaled(steps, start, span):
    """``steps``' fractions as ``start + span * fraction`` (one part of a longer job);
    returns ``steps``' result. Closing it closes ``steps``.

    >>> list(scaled((fraction for fraction in (0.0, 0.5, 1.0)), 0.5, 0.5))
    [0.5, 0.75, 1.0]
    """
    try:
        while True:
            try:
                fraction = next(steps)
            except StopIteration as done:
                return done.value
            yield start + span * fraction
    finally:
        steps.close()


def run_to_end(steps, report=None):
    """``steps``' result, computed to the end; ``report(fraction)`` on the way.

    >>> def steps():
    ...     yield 0.5
    ...     return "done"
    >>> run_to_end(steps(), print)
    0.5
    'done'
    """
    while True:
        try:
            fraction = next(steps)
        except StopIteration as done:
            return done.value
        if report is not None:
            report(fraction)


# Work a window does between two of its redraws (progress, Esc): at least a tenth of a
# second (a step per timer event left the window idle for the timer's interval after each
# short step), and 9 times what the window took between two slices, so that the window's
# share stays under a tenth, but never over a second (Esc takes effect within about that).
# In a software-rendered window a 43k-vertex character's viewport took 0.2 to 0.45 s to
# redraw (scripts/release/gui_bind_timing.py).
SLICE_SECONDS, MAX_SLICE_SECONDS, WINDOW_SHARE = 0.1, 1.0, 0.1
# A slice goes on past its time while the rest looks this short at the slice's pace: the
# character's Bind ended its first second a step before the end, then waited 0.5 to 1.3 s
# for a redraw before a last step of 0.01 s.
TAIL_SECONDS = 0.5


def slice_seconds(between):
    """How long the next slice of steps runs, after the window took ``between`` seconds
    since the last one: float.

    >>> slice_seconds(0.005), slice_seconds(0.05), slice_seconds(0.4)
    (0.1, 0.45, 1.0)
    """
    return min(MAX_SLICE_SECONDS, max(SLICE_SECONDS, between * (1.0 - WINDOW_SHARE) / WINDOW_SHARE))


def rest_seconds(seconds, start, fraction):
    """How long the steps left after ``fraction`` take at the pace of a slice that went
    from ``start`` to ``fraction`` in ``seconds``: float (inf where it made no progress).

    >>> rest_seconds(1.0, 0.0, 0.5), rest_seconds(1.0, 0.5, 0.5)
    (1.0, inf)
    """
    done = fraction - start
    return seconds * max(0.0, 1.0 - fraction) / done if done > 0.0 else float("inf")


def advance(steps, seconds=None, start=0.0, tail=0.0):
    """Run ``steps`` for about ``seconds`` (default ``SLICE_SECONDS``; at least one step,
    then until one ends past that time and the rest does not look shorter than ``tail`` seconds at
    this slice's pace, :func:`rest_seconds` from ``start``, the fraction it began at): the
    last fraction yielded. Raises StopIteration (with the result) at the end.

    >>> def steps():
    ...     yield from (0.25, 0.5, 0.75, 0.99)
    ...     return "done"
    >>> running = steps()
    >>> advance(running, seconds=0.0)  # one step
    0.25
    >>> advance(running, seconds=0.0, start=0.25, tail=60.0)  # on: the rest looks short
    Traceback (most recent call last):
    ...
    StopIteration: done
    """
    clock = time.perf_counter
    began = clock()
    deadline = began + (SLICE_SECONDS if seconds is None else seconds)
    while True:
        fraction = next(steps)
        now = clock()
        if now >= deadline and not rest_seconds(now - began, start, fraction) < tail:
            return fraction


def zero_scale_axes(matrix, tolerance):
    """The local axes ('X', 'Y', 'Z') an object matrix ((4, 4)) scales to (nearly) nothing,
    at most ``tolerance`` of its longest axis, which flattens the object: a list, empty for
    a usable matrix.

    >>> zero_scale_axes(np.diag([2.0, 1e-9, 1.0, 1.0]), 1e-6)
    ['Y']
    """
    lengths = np.linalg.norm(np.array(matrix, dtype=np.float64)[:3, :3], axis=0)
    return [axis for axis, length in zip("XYZ", lengths) if not length > tolerance * lengths.max()]


def computing_frame(rest, rest_cage, triangles, world, cage_origin, local=False):
    """Where a Bind computes: in world space (coordinates are affine combinations, so they
    hold in the mesh's local space too), or with ``local`` (Green coordinates: similarity
    invariant, not affine) in the mesh's local space, where the deformer evaluates them; a
    mirroring object transform then turns the cage's triangles inside out: they are flipped.

    Parameters
    ----------
    rest, rest_cage : (k, 3), (n, 3) float64
        The mesh's and the cage's vertices in the mesh's local space.
    triangles : (m, 3) int
        The cage's triangles, outward in world space.
    world : (4, 4) float
        The mesh object's matrix.
    cage_origin : (3,) float
        The cage object's origin in world space.

    Returns
    -------
    points, cage_vertices : (k, 3), (n, 3) float64
    triangles : (m, 3) int
        Outward in that space.
    origins : (2, 3) float64
        The mesh's and the cage's origins there (float32 positions are rounded by their
        distance from these: the core's rounding check).

    >>> frame = computing_frame(np.zeros((1, 3)), np.eye(3), np.array([[0, 1, 2]]), np.diag([-1.0, 1, 1, 1]),
    ...                         np.zeros(3), local=True)
    >>> frame[2].tolist()
    [[2, 1, 0]]
    """
    world = np.asarray(world, dtype=np.float64)
    linear, origin = world[:3, :3], world[:3, 3]
    origins = np.array([origin, np.asarray(cage_origin, dtype=np.float64)[:3]])
    if not local:
        return rest @ linear.T + origin, rest_cage @ linear.T + origin, triangles, origins
    if np.linalg.det(linear) < 0.0:
        triangles = triangles[:, ::-1].copy()
    return rest, rest_cage, triangles, (origins - origin) @ np.linalg.inv(linear).T


def plan_steps(tool, run):
    """Plan the Bind of what ``tool`` read (``bind_plan.plan_bind``, computing through
    ``run(compute, workers)``, e.g. a :class:`WorkerFallback`) and record the plan on
    ``tool``: steps returning the plan. The core's errors pass through."""
    scene = tool.read_input()
    plan = yield from bind_plan.plan_bind(scene.points, scene.cage_vertices, scene.triangles, tool.plan_request(run))
    tool.record(plan)
    return plan


def bind_steps(tool):
    """The whole Bind: ``tool``'s computing (``COMPUTING`` of the progress), then its
    writing, which starts only once the computing ended. Steps returning the binding;
    closed early, the step under way is closed and no writing starts after it."""
    yield from scaled(tool.compute_steps(), 0.0, COMPUTING)
    return (yield from scaled(tool.write_binding(), COMPUTING, 1.0 - COMPUTING))


def bind(tool):
    """:func:`bind_steps` to the end, reporting the progress through ``tool``; the binding."""
    return run_to_end(bind_steps(tool), tool.report_progress)


def in_workers_or_here(compute, workers):
    """``compute(workers)``; where the worker processes cannot start or fail, ``compute(1)``
    in this process instead: (its result, None or the failure: a ``WorkerError``, or a
    ``WorkerWarning``'s message where an automatic count fell back by itself). Other
    warnings are passed on.

    >>> in_workers_or_here(lambda workers: workers * 10, 1)
    (10, None)
    """
    def at_once(count):
        return compute(count)
        yield  # unreached: a generator of no steps

    return run_to_end(steps_in_workers_or_here(at_once, workers))


def steps_in_workers_or_here(make_steps, workers):
    """:func:`in_workers_or_here` for work in steps (``make_steps(workers)``, a generator
    of fractions): yields its fractions and returns (its result, None or the failure);
    where the workers fail, the steps start again in this process.

    >>> def steps(workers):
    ...     yield 0.5
    ...     return workers * 10
    >>> run_to_end(steps_in_workers_or_here(steps, 1))
    (10, None)
    """
    failure = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", WorkerWarning)  # automatic counts fall back here
        try:
            result = yield from make_steps(workers)
        except WorkerError as error:  # an explicit count
            failure = error
            result = yield from make_steps(1)
    for warning in caught:
        if issubclass(warning.category, WorkerWarning):
            failure = warning.message
        else:
            warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)
    return result, failure


class WorkerFallback:
    """One Bind's ``run(compute, workers)`` (``bind_plan.BindRequest.run``): through
    ``in_workers(compute, workers)`` -> (result, failure or None) (None: ``compute(workers)``
    as it is), and once the workers failed, the rest of the Bind in one process.
    ``failure`` is the last failure's (None while there is none).

    >>> fallback = WorkerFallback()
    >>> fallback(lambda workers: workers, 4), fallback.failure
    (4, None)
    """

    def __init__(self, in_workers=None):
        self.in_workers = in_workers
        self.failure = None

    def __call__(self, compute, workers):
        if self.failure is not None:  # they failed once: the rest in one process too
            workers = 1
        if self.in_workers is None:
            return compute(workers)
        result, failure = self.in_workers(compute, workers)
        if failure is not None:
            self.failure = failure
        return result


def bind_report(headline, notes=()):
    """What a finished Bind tells: ('INFO', ``headline``), or ('WARNING', the headline and
    ``notes`` joined) where there are notes (the workers failed, the mesh moves twice).

    >>> bind_report("Bound", ["workers failed"])
    ('WARNING', 'Bound; workers failed')
    """
    notes = list(notes)
    return ('WARNING', "; ".join([headline] + notes)) if notes else ('INFO', headline)
