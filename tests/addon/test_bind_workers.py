"""Bind and Make Cage in the core's worker processes: the Worker Processes preference,
and workers that cannot start (Bind then computes in Blender and says so)."""

import importlib.util
import gc as garbage
import os
from pathlib import Path
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from fresh_process import PACKAGE
from scene_helpers import make_active, add_icosphere_cage, add_subdivided_sphere, bind, mesh_state

# Windows' semantics and broken workers, simulated in every worker (tests/core).
_spec = importlib.util.spec_from_file_location(
    "simulated_os", Path(__file__).resolve().parents[1] / "core" / "simulated_os.py")
simulated_os = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(simulated_os)


def coordinates_of(gc, obj):
    return gc.binding.binding(obj).coordinates(obj.data).astype(np.float64)


@pytest.fixture
def workers_preference(gc):
    """``choose(None | 1 | n)`` sets Preferences > Add-ons > GenCoords > Worker Processes
    as an artist would; restored afterwards."""
    preferences = bpy.context.preferences.addons[PACKAGE].preferences
    saved = preferences.workers, preferences.worker_count

    def choose(workers):
        if workers is None or workers == 1:
            preferences.workers = 'AUTO' if workers is None else 'BLENDER'
        else:
            preferences.workers, preferences.worker_count = 'FIXED', workers

    yield choose
    preferences.workers, preferences.worker_count = saved


@pytest.fixture
def worker_processes(gc, monkeypatch):
    """``.started``: the worker processes started during the test; ``.live()``: those
    still running (no /proc)."""
    started = []
    start = gc.core.evaluation.parallel.WorkerPool.__init__

    def recording(pool, *args, **kwargs):
        try:
            start(pool, *args, **kwargs)
        finally:
            started.extend(pool._processes)

    monkeypatch.setattr(gc.core.evaluation.parallel.WorkerPool, "__init__", recording)
    return SimpleNamespace(started=started,
                           live=lambda: [process for process in started if process.poll() is None])


def test_the_preference_is_registered_under_the_extensions_name(gc):
    addon = bpy.context.preferences.addons[PACKAGE]
    assert addon.preferences.workers == 'AUTO'
    assert {item.identifier for item in addon.preferences.bl_rna.properties["workers"].enum_items} \
        == {'AUTO', 'BLENDER', 'FIXED'}


@pytest.mark.parametrize("workers", [1, 2])
def test_bind_computes_in_chunks_and_a_cancel_changes_nothing(gc, monkeypatch, workers_preference,
                                                              worker_processes, workers):
    cage = add_icosphere_cage()
    obj = add_subdivided_sphere(levels=2)
    obj.gencoords.cage = cage
    before = mesh_state(obj)
    monkeypatch.setattr(gc.core.planning.figures, "CHUNK_ENTRIES", 3000)  # 250 points a chunk per worker
    workers_preference(workers)
    make_active(obj)
    job = gc.job.BindJob(obj, bpy.context)
    steps = job.steps()
    fractions = [next(steps) for _ in range(3)]
    assert fractions == sorted(fractions) and fractions[-1] < 1.0
    assert len(worker_processes.live()) == (workers if workers > 1 else 0)
    steps.close()  # what Esc does
    assert not worker_processes.live()
    assert mesh_state(obj)[1] == before[1] and not obj.modifiers
    assert not [g for g in bpy.data.node_groups if "GenCoords" in g.name]
    job = gc.job.BindJob(obj, bpy.context)
    assert list(job.steps())[-1] == 1.0
    job.commit()
    assert gc.binding.binding(obj) is not None


def test_bind_in_worker_processes_stores_what_one_process_computes(gc, monkeypatch, workers_preference,
                                                                    worker_processes):
    # The workers run the installed extension's core (not bpy) in fresh interpreters.
    # One mesh bound twice: two meshes could differ in vertex order (threaded mesh
    # operators in 5.2 give no order guarantee).
    cage = add_icosphere_cage()
    obj = add_subdivided_sphere(levels=2)
    monkeypatch.setattr(gc.core.planning.figures, "CHUNK_ENTRIES", 5000)
    workers_preference(1)
    bind(obj, cage)
    alone = coordinates_of(gc, obj)
    assert not worker_processes.started  # "1: Compute in Blender"
    workers_preference(2)
    bind(obj, cage)
    # Calls of twice the rows (a chunk per worker): equal to rounding, not bitwise (the
    # core's own tests hold the same chunks bitwise).
    np.testing.assert_allclose(coordinates_of(gc, obj), alone, rtol=0, atol=1e-6)
    assert len(worker_processes.started) == 2 and not worker_processes.live()


@pytest.mark.parametrize("workers", [None, 2])
def test_bind_under_windows_semantics_leaves_nothing_behind(gc, monkeypatch, tmp_path, workers_preference,
                                                            worker_processes, workers):
    # Windows refuses to remove a file any process holds: the workers share tagged
    # memory (the paging file's, never a file), let go of it after every chunk of the Bind.
    cage = add_icosphere_cage()
    obj = add_subdivided_sphere(levels=2)
    monkeypatch.setattr(gc.core.planning.figures, "CHUNK_ENTRIES", 5000)
    workers_preference(1)
    bind(obj, cage)
    alone = coordinates_of(gc, obj)
    workers_preference(workers)
    monkeypatch.setattr(gc.core.evaluation.cage, "_PAIRS_PER_WORKER", 1)  # workers even for this small Bind
    monkeypatch.setattr(gc.core.evaluation.cage, "available_cores", lambda: 2)
    simulated_os.simulate(monkeypatch, "windows", tmp_path)
    assert gc.core.evaluation.shared_memory._WINDOWS  # the extension's core takes its Windows branches
    assert bind(obj, cage) == {'FINISHED'}
    assert len(worker_processes.started) == 2
    np.testing.assert_allclose(coordinates_of(gc, obj), alone, rtol=0, atol=1e-6)
    garbage.collect()
    assert not gc.core.evaluation.shared_memory.shared_files(os.getpid())
    assert not simulated_os.tagged_memory(tmp_path)  # the Bind keeps no view of the shared memory


@pytest.mark.parametrize("workers", [None, 2])
def test_bind_finishes_in_blender_when_workers_cannot_start(gc, monkeypatch, capfd, workers_preference,
                                                           workers):
    # An interpreter without numpy (or an antivirus blocking Blender's Python): the Bind
    # operator still binds, in Blender, warns in its report and prints the cause to the
    # console.
    cage = add_icosphere_cage()
    obj = add_subdivided_sphere(levels=2)
    monkeypatch.setattr(gc.core.planning.figures, "CHUNK_ENTRIES", 5000)
    workers_preference(1)
    bind(obj, cage)
    alone = coordinates_of(gc, obj)
    workers_preference(workers)
    monkeypatch.setattr(gc.core.evaluation.cage, "_PAIRS_PER_WORKER", 1)  # workers even for this small Bind
    monkeypatch.setattr(gc.core.evaluation.cage, "available_cores", lambda: 2)
    simulated_os.broken_start(monkeypatch)
    capfd.readouterr()
    assert bind(obj, cage) == {'FINISHED'}
    np.testing.assert_array_equal(coordinates_of(gc, obj), alone)  # all in Blender, the same chunks
    output = capfd.readouterr()
    said = output.out + output.err
    assert "worker processes failed, so GenCoords computed in Blender instead" in said
    assert "No module named 'numpy'" in said  # the cause, in the console
    assert said.count("No module named 'numpy'") == 1  # one try: the rest of the Bind in Blender
    assert "Bound 'Mesh'" in said and "1: Compute in Blender" in said
    assert not gc.core.evaluation.shared_memory.shared_files(os.getpid())


@pytest.mark.parametrize("shape", ["CONVEX", "TIGHT"])
def test_make_cage_finishes_in_blender_when_workers_cannot_start(gc, monkeypatch, capfd, workers_preference,
                                                                 shape):
    obj = add_subdivided_sphere(levels=1)
    make_active(obj)
    workers_preference(2)
    simulated_os.broken_start(monkeypatch)
    capfd.readouterr()
    assert bpy.ops.object.gencoords_make_cage(target_vertices=40, shape=shape) == {'FINISHED'}
    assert obj.gencoords.cage is not None
    output = capfd.readouterr()
    assert "computed in Blender instead" in output.out + output.err
