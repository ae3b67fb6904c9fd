"""Worker processes: the same numbers as one process, and nothing left behind."""

import os
import tempfile

import numpy as np
import pytest

import gencoords
import gencoords.evaluation.rows
import gencoords.evaluation.parallel
import gencoords.evaluation.interpreters
import gencoords.evaluation.shared_memory
import simulated_os
from tests.fixtures.polytopes import icosphere, random_convex_polytope, random_interior_points


def shared_files():
    """This process's shared files (other processes' runs may have theirs)."""
    return set(gencoords.evaluation.shared_memory.shared_files(os.getpid()))


@pytest.fixture
def mixed_points():
    """Interior points, cage vertices, facet midpoints and outside points of a 3D cage."""
    rng = np.random.default_rng(3)
    vertices, faces = random_convex_polytope(rng, 3, 30)
    points = np.concatenate([random_interior_points(rng, vertices, 700), vertices[:5],
                             vertices[faces[:5]].mean(axis=1),
                             vertices.mean(axis=0) + 3.0 * (vertices[:4] - vertices.mean(axis=0))])
    return vertices, faces, rng.permutation(points)


@pytest.fixture
def small_chunks(monkeypatch):
    # Many chunks and units even for few points, so that every worker gets several.
    monkeypatch.setattr(gencoords.evaluation.rows, "_CHUNK_PAIRS", 2000)


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_workers_give_bitwise_the_single_process_result(kind, mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    with gencoords.Cage(vertices, faces) as cage:
        for outside, dtype in (("project", np.float64), ("extrapolate", np.float32)):
            alone = cage.coordinates(points, kind=kind, outside=outside, dtype=dtype, workers=1)
            shared_locations = np.zeros(len(points), dtype=np.int8)
            together = cage.coordinates(points, kind=kind, outside=outside, dtype=dtype, workers=2,
                                        locations=shared_locations)
            assert together.dtype == dtype
            np.testing.assert_array_equal(together, alone)
            np.testing.assert_array_equal(shared_locations, cage.point_locations(points, workers=1))
    np.testing.assert_allclose(together.astype(np.float64) @ vertices, points, atol=1e-5)


def test_free_function_and_weights_with_workers(mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    np.testing.assert_array_equal(gencoords.weights(points, vertices, faces, kind="wachspress", workers=2),
                                  gencoords.weights(points, vertices, faces, kind="wachspress", workers=1))
    np.testing.assert_array_equal(gencoords.point_locations(points, vertices, faces, workers=2),
                                  gencoords.point_locations(points, vertices, faces, workers=1))


def test_outside_points_are_all_named_with_workers(mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    with pytest.raises(gencoords.OutsideCageError) as alone:
        gencoords.coordinates(points, vertices, faces, workers=1)
    with pytest.raises(gencoords.OutsideCageError) as together:
        gencoords.coordinates(points, vertices, faces, workers=2)
    assert len(alone.value.indices) == 4
    np.testing.assert_array_equal(together.value.indices, alone.value.indices)


def test_a_cage_keeps_its_workers_between_calls_and_stops_them(mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    inside = points[gencoords.point_locations(points, vertices, faces) == gencoords.INSIDE]
    cage = gencoords.Cage(vertices, faces)
    cage.coordinates(inside, workers=2)
    processes = list(cage._pool._processes)
    fractions = []
    cage.coordinates(inside, progress=fractions.append)  # workers=None: the pool it has
    assert cage._pool._processes == processes
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and len(fractions) > 2
    cage.close()
    assert all(process.poll() is not None for process in processes)
    # Still usable, in this process.
    np.testing.assert_allclose(cage.coordinates(inside[:5], workers=1) @ vertices, inside[:5], atol=1e-12)


def test_a_cancel_stops_the_workers_and_removes_the_shared_memory(mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    before = shared_files()
    cage = gencoords.Cage(vertices, faces)

    def cancel(fraction):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cage.coordinates(points, outside="project", workers=2, progress=cancel)
    assert cage._pool is None or cage._pool.closed
    assert shared_files() == before


def test_a_killed_worker_raises_a_clear_error_and_leaves_nothing(monkeypatch, mixed_points, small_chunks):
    vertices, faces, points = mixed_points
    before = shared_files()
    cage = gencoords.Cage(vertices, faces)
    cage.coordinates(points[:50], outside="project", workers=2)  # starts the pool
    processes = list(cage._pool._processes)
    sent = simulated_os.kill_mid_call(monkeypatch, cage._pool)  # with rows still to compute
    with pytest.raises(gencoords.WorkerError, match="ended unexpectedly"):
        cage.coordinates(points, outside="project", workers=2)
    assert len(sent) == 3  # killed mid-call, after computing some rows
    assert all(process.poll() is not None for process in processes)  # the other one stopped
    assert shared_files() == before
    # The next call starts fresh workers.
    np.testing.assert_array_equal(cage.coordinates(points, outside="project", workers=2),
                                  cage.coordinates(points, outside="project", workers=1))
    cage.close()


def test_a_worker_that_died_between_calls_raises_a_clear_error(mixed_points, small_chunks):
    # Sending it work meets a broken pipe: a WorkerError, not a BrokenPipeError.
    vertices, faces, points = mixed_points
    before = shared_files()
    cage = gencoords.Cage(vertices, faces)
    cage.coordinates(points[:50], outside="project", workers=2)  # starts the pool
    processes = list(cage._pool._processes)
    processes[0].kill()
    processes[0].wait()
    with pytest.raises(gencoords.WorkerError, match="ended unexpectedly"):
        cage.coordinates(points, outside="project", workers=2)
    assert all(process.poll() is not None for process in processes)
    assert shared_files() == before
    cage.close()


def test_default_stays_in_process_for_small_calls():
    vertices, faces = icosphere(1)
    with gencoords.Cage(vertices, faces) as cage:
        cage.coordinates(0.5 * vertices)
        assert cage._pool is None


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_bad_worker_counts_are_refused(workers):
    vertices, faces = icosphere(0)
    with pytest.raises(ValueError, match="workers must be a positive integer"):
        gencoords.coordinates(0.1 * vertices, vertices, faces, workers=workers)


@pytest.mark.parametrize("executable", [None, "", "/opt/blender/blender"])
def test_workers_start_the_prefix_python_when_sys_executable_is_not_one(monkeypatch, executable,
                                                                       mixed_points, small_chunks):
    # Embedding programs may leave sys.executable unset or point it at themselves.
    import sys

    vertices, faces, points = mixed_points
    expected = gencoords.coordinates(points, vertices, faces, outside="project", workers=1)
    monkeypatch.setattr(sys, "executable", executable)
    assert os.path.basename(gencoords.evaluation.interpreters.python_executable()).startswith("python")
    np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces, outside="project", workers=2),
                                  expected)


@pytest.mark.parametrize("count, chunk, workers", [(40000, 25, 2), (1000, 7, 16), (5, 10, 4), (1, 1, 1),
                                                   (123457, 300, 3)])
def test_dispatch_units_cover_the_rows_in_whole_chunks_and_shrink_towards_the_end(count, chunk, workers):
    units = gencoords.evaluation.parallel.dispatch_units(count, chunk, workers)
    starts, stops = np.array(units).T
    assert starts[0] == 0 and stops[-1] == count and (starts[1:] == stops[:-1]).all()
    assert (starts % chunk == 0).all()  # the same chunks as one process: bitwise the same rows
    sizes = stops - starts
    assert (np.diff(sizes[:-1]) <= 0).all()  # shrinking (the last one may be cut short)
    # No unit over 1/8 of a worker's share (progress and cancel between units) and the
    # last ones single chunks (the workers finish together).
    assert sizes.max() <= max(chunk, count // (workers * 8) + chunk)
    assert sizes[-1] <= chunk


def test_writers_reserve_their_rows_in_shared_memory(mixed_points, small_chunks):
    shared = gencoords.evaluation.shared_memory.SharedArrays({"points": ((10, 3), np.float64), "result": ((10, 4), np.float32)},
                                        reserved_by_writers=("result",))
    try:
        if not shared.path.startswith("/dev/shm"):
            pytest.skip("no /dev/shm here: the whole file is reserved up front")
        assert shared.reserved_by_writers == ("result",)
        # Only the points are reserved up front: the result's blocks come with its writers.
        assert os.stat(shared.path).st_blocks * 512 < shared.layout["result"][0] + 4096
        views, descriptor = gencoords.evaluation.shared_memory.attach(shared.address, shared.layout)
        gencoords.evaluation.shared_memory.reserve_rows(descriptor, shared.layout, ("result",), 0, 10)
        assert os.stat(shared.path).st_blocks * 512 >= shared.layout["result"][0] + 10 * 4 * 4
        read_only = os.open(shared.path, os.O_RDONLY)
        with pytest.raises(gencoords.WorkerError, match="could not reserve shared memory"):
            gencoords.evaluation.shared_memory.reserve_rows(read_only, shared.layout, ("result",), 0, 10)
        os.close(read_only)
        os.close(descriptor)
    finally:
        shared.remove()


def test_without_room_in_dev_shm_the_temporary_folder_serves(monkeypatch, mixed_points, small_chunks):
    # A container's 64 MB /dev/shm: the file goes to the temporary folder, reserved whole.
    vertices, faces, points = mixed_points
    monkeypatch.setattr(gencoords.evaluation.shared_memory, "_free_bytes", lambda folder: 0 if folder == "/dev/shm" else 1 << 40)
    shared = gencoords.evaluation.shared_memory.SharedArrays({"result": ((10, 4), np.float64)}, reserved_by_writers=("result",))
    assert shared.path.startswith(tempfile.gettempdir()) and shared.reserved_by_writers == ()
    shared.remove()
    before = shared_files()
    with gencoords.Cage(vertices, faces) as cage:
        np.testing.assert_array_equal(cage.coordinates(points, outside="project", workers=2),
                                      cage.coordinates(points, outside="project", workers=1))
    assert shared_files() == before


def test_without_a_usable_temporary_folder_dev_shm_serves(monkeypatch, mixed_points, small_chunks):
    if not os.access("/dev/shm", os.W_OK):
        pytest.skip("no /dev/shm here (tests/core/test_workers_on_other_systems.py covers that)")
    vertices, faces, points = mixed_points

    def no_temporary_folder():
        raise FileNotFoundError(2, "No usable temporary directory found")

    monkeypatch.setattr(tempfile, "gettempdir", no_temporary_folder)
    np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces, outside="project", workers=2),
                                  gencoords.coordinates(points, vertices, faces, outside="project", workers=1))
