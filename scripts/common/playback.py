"""Timing a live update the same way for every deformer the benchmarks compare: move one
cage vertex, then time ``view_layer.update()`` (repeated until the evaluated mesh
changes) plus reading the evaluated positions; the median of ``UPDATE_REPEATS`` moves.
Import after ``session.prepare()``."""

import time

import bpy
import numpy as np

from .blender_objects import arrays

UPDATE_REPEATS = 7


def update_until_changed(mesh, previous, buffer=None, max_passes=4):
    """``view_layer.update()`` until the evaluated mesh differs from ``previous``.

    Returns ``(positions, passes)``. GenCoords writes the deformed shape from a
    depsgraph handler; Blender evaluates such writes within the same update, so one
    pass normally suffices for both methods, and the loop is what makes the timing
    "until the evaluated mesh shows the move" whatever a method needs.
    """
    for passes in range(1, max_passes + 1):
        bpy.context.view_layer.update()
        now = arrays.evaluated_positions(mesh, out=buffer)
        if not np.array_equal(now, previous):
            break
    return now, passes


def settle(mesh):
    """The evaluated mesh after a cage change (made outside any timing)."""
    return update_until_changed(mesh, arrays.evaluated_positions(mesh).copy())[0].copy()


def time_update(mesh, cage, rest_cage, repeat, previous, buffer=None, moved_vertex=0):
    """One live update: cage vertex ``moved_vertex`` moved by an offset that changes with
    ``repeat``; returns (wall seconds, passes, positions now, CPU seconds).

    The CPU seconds are the process's, all threads together: on a shared machine they
    vary far less than the wall time, and compare the work each method does."""
    offset = 0.05 * (repeat + 1) * (1 if repeat % 2 else -1)
    cage.data.vertices[moved_vertex].co = rest_cage[moved_vertex] + np.array([0.0, 0.0, offset])
    cage.data.update()  # only tags the cage: evaluation happens inside the timing
    cpu, start = time.process_time(), time.perf_counter()
    now, passes = update_until_changed(mesh, previous, buffer)
    return time.perf_counter() - start, passes, now.copy(), time.process_time() - cpu


def time_updates(mesh, cage, rest_cage, moved_vertex=0):
    """Median seconds of one live update after moving cage vertex ``moved_vertex``, and
    the passes used; the cage is put back at rest afterwards."""
    buffer = np.empty(len(mesh.data.vertices) * 3, dtype=np.float32)
    previous = arrays.evaluated_positions(mesh).copy()
    times, passes_used = [], []
    for repeat in range(UPDATE_REPEATS):
        seconds, passes, previous, _ = time_update(mesh, cage, rest_cage, repeat, previous, buffer,
                                                moved_vertex)
        times.append(seconds)
        passes_used.append(passes)
    arrays.write_positions(cage.data, rest_cage)
    settle(mesh)
    return float(np.median(times)), max(passes_used)
