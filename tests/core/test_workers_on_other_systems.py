"""Worker processes under Windows' and macOS' semantics (simulated on Linux, in the test
process and in every worker: ``simulated_os``), and workers that cannot start."""

import gc
import mmap
import os
import subprocess
import sys
import tempfile
import warnings

import numpy as np
import pytest

import gencoords
import gencoords.evaluation.cage
import gencoords.evaluation.rows
import gencoords.evaluation.interpreters
import gencoords.evaluation.shared_memory
import simulated_os
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


def shared_files():
    """This process's shared files (other processes' runs may have theirs)."""
    return set(gencoords.evaluation.shared_memory.shared_files(os.getpid()))


@pytest.fixture
def cage_and_points(monkeypatch):
    monkeypatch.setattr(gencoords.evaluation.rows, "_CHUNK_PAIRS", 2000)  # many units for few points
    rng = np.random.default_rng(5)
    vertices, faces = random_convex_polytope(rng, 3, 30)
    return vertices, faces, random_interior_points(rng, vertices, 800)


@pytest.fixture(params=["windows", "macos"])
def system(request, monkeypatch, tmp_path):
    assert not shared_files()
    simulated_os.simulate(monkeypatch, request.param, tmp_path)
    return request.param


@pytest.fixture
def automatic_two(monkeypatch):
    """``workers=None`` chooses two workers for these small calls."""
    monkeypatch.setattr(gencoords.evaluation.cage, "_PAIRS_PER_WORKER", 1)
    monkeypatch.setattr(gencoords.evaluation.cage, "available_cores", lambda: 2)


def test_the_simulation_refuses_what_windows_refuses(monkeypatch, tmp_path):
    simulated_os.simulate(monkeypatch, "windows", tmp_path)
    assert not hasattr(os, "posix_fallocate") and not hasattr(os, "statvfs")
    assert gencoords.evaluation.interpreters.available_cores() == os.cpu_count()  # no sched_getaffinity
    stale = os.path.join(tempfile.gettempdir(), f"gencoords-{os.getpid()}-old.shared")
    descriptor = os.open(stale, os.O_CREAT | os.O_RDWR)
    with pytest.raises(PermissionError):
        os.unlink(stale)  # open here
    os.close(descriptor)
    os.unlink(stale)
    # Tagged memory: nothing in the temporary folder; freed when the last view goes.
    shared = gencoords.evaluation.shared_memory.SharedArrays({"result": ((10, 4), np.float64)})
    assert shared.path is None and shared.address[0] == "tagname"
    assert simulated_os.tagged_memory(tmp_path) == [shared.address[1]]
    views = gencoords.evaluation.shared_memory.attach(shared.address, shared.layout)[0]  # as a worker
    views["result"][...] = 7.0
    assert (shared.arrays["result"] == 7.0).all()
    shared.remove()
    del shared, views
    gc.collect()
    assert not simulated_os.tagged_memory(tmp_path) and not os.listdir(tmp_path / "tagged")
    assert not os.listdir(tempfile.gettempdir())


def test_workers_leave_nothing_behind_and_give_the_same_numbers(system, tmp_path, cage_and_points):
    vertices, faces, points = cage_and_points
    expected = gencoords.coordinates(points, vertices, faces, workers=1)
    np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces, workers=2), expected)
    gc.collect()
    assert not shared_files()
    # A kept cage: its workers hold nothing between calls, so each call's memory goes as
    # soon as its result does (files piled up while the workers kept them mapped), and
    # no file is left while a result is kept (Windows could not remove it).
    with gencoords.Cage(vertices, faces) as cage:
        for _ in range(3):
            result = cage.coordinates(points, workers=2)
            np.testing.assert_array_equal(result, expected)
            assert not shared_files() and not os.listdir(tempfile.gettempdir())
            if system == "windows":  # the result's memory, held by this process only
                assert len(simulated_os.tagged_memory(tmp_path)) == 1
            del result
            gc.collect()
            assert not simulated_os.tagged_memory(tmp_path)
        assert not cage._pool.closed


def test_a_result_kept_until_exit_leaves_nothing_behind(system, tmp_path, cage_and_points):
    # The caller keeps the result (a view of the shared memory) until its interpreter
    # exits: Windows could not remove a file still mapped, so there must be none.
    vertices, faces, points = cage_and_points
    np.savez(tmp_path / "call.npz", vertices=vertices, faces=faces, points=points)
    script = (f"import sys, numpy as np, pytest; sys.path.insert(0, {os.path.dirname(__file__)!r}); "
              "import simulated_os, gencoords, gencoords.evaluation.rows as rows; "
              f"simulated_os.simulate(pytest.MonkeyPatch(), {system!r}, {str(tmp_path)!r}); "
              f"rows._CHUNK_PAIRS = 2000; call = np.load({str(tmp_path / 'call.npz')!r}); "
              "kept = gencoords.coordinates(call['points'], call['vertices'], call['faces'], workers=2); "
              "print(kept.sum())")
    child = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert child.returncode == 0, child.stderr
    assert not os.listdir(tmp_path / "temp")
    assert not simulated_os.tagged_memory(tmp_path)  # the OS freed a dead process's memory


def test_a_killed_worker_or_a_cancel_leaves_nothing_behind(system, monkeypatch, cage_and_points):
    vertices, faces, points = cage_and_points
    cage = gencoords.Cage(vertices, faces)
    cage.coordinates(points[:50], workers=2)
    processes = list(cage._pool._processes)
    sent = simulated_os.kill_mid_call(monkeypatch, cage._pool)
    with pytest.raises(gencoords.WorkerError, match="ended unexpectedly"):
        cage.coordinates(points, workers=2)
    assert len(sent) == 3 and all(process.poll() is not None for process in processes)

    def cancel(fraction):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        cage.coordinates(points, workers=2, progress=cancel)
    cage.close()
    gc.collect()
    assert not shared_files()


def test_space_is_reserved_before_the_workers_write(system):
    # No posix_fallocate: a sparse file would kill the writers with SIGBUS on a full disk
    # (Windows commits the whole tagged memory when it is made).
    specs = {"points": ((1000, 3), np.float64), "result": ((1000, 40), np.float32)}
    shared = gencoords.evaluation.shared_memory.SharedArrays(specs, reserved_by_writers=("result",))
    assert shared.reserved_by_writers == ()  # reserved whole, here
    if system == "macos":
        size = gencoords.evaluation.shared_memory.shared_layout(specs)[1]
        assert os.stat(shared.path).st_blocks * 512 >= size
    shared.remove()


def no_room(system, monkeypatch):
    """Make the shared memory fail for want of room: (what the error advises, its cause)."""
    if system == "windows":  # the paging file cannot commit the tagged memory
        real = mmap.mmap

        def refuse(fileno, length, *args, tagname=None, **options):
            if tagname is not None:
                raise OSError(22, "The paging file is too small for this operation to complete")
            return real(fileno, length, *args, **options)

        monkeypatch.setattr(mmap, "mmap", refuse)
        return "close other programs", "paging file is too small"

    def full(descriptor, offset, length):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(gencoords.evaluation.shared_memory, "_reserve", full)
    return "free some disk space", "No space left"


def test_a_full_disk_is_a_worker_error_and_leaves_nothing(system, monkeypatch, cage_and_points, automatic_two):
    vertices, faces, points = cage_and_points
    advice, cause = no_room(system, monkeypatch)
    with pytest.raises(gencoords.WorkerError, match=advice):
        gencoords.coordinates(points, vertices, faces, workers=2)
    assert not shared_files()
    with pytest.warns(gencoords.WorkerWarning, match=cause):
        result = gencoords.coordinates(points, vertices, faces)
    np.testing.assert_array_equal(result, gencoords.coordinates(points, vertices, faces, workers=1))
    if system == "windows":
        return
    monkeypatch.setattr(gencoords.evaluation.shared_memory, "_free_bytes", lambda folder: 0)
    with pytest.raises(gencoords.WorkerError, match="no room for"):
        gencoords.coordinates(points, vertices, faces, workers=2)
    assert not shared_files()


def no_temporary_folder():
    raise FileNotFoundError(2, "No usable temporary directory found in ['/tmp', '/var/tmp']")


def test_no_usable_temporary_folder_is_a_worker_error_that_says_what_to_do(system, monkeypatch, cage_and_points,
                                                                       automatic_two):
    vertices, faces, points = cage_and_points
    expected = gencoords.coordinates(points, vertices, faces, workers=1)
    monkeypatch.setattr(tempfile, "gettempdir", no_temporary_folder)
    if system == "windows":  # tagged memory needs no folder
        np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces, workers=2), expected)
        return
    with pytest.raises(gencoords.WorkerError, match="no usable temporary folder.*set TMPDIR.*workers=1"):
        gencoords.coordinates(points, vertices, faces, workers=2)
    with pytest.warns(gencoords.WorkerWarning, match="no usable temporary folder"):
        np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces), expected)


def test_workers_start_without_a_console_window_on_windows(monkeypatch, tmp_path, cage_and_points):
    vertices, faces, points = cage_and_points
    simulated_os.simulate(monkeypatch, "windows", tmp_path)
    with gencoords.Cage(vertices, faces) as cage:
        cage.coordinates(points, workers=2)
        create_no_window = 0x08000000  # subprocess.CREATE_NO_WINDOW on Windows
        assert [process.creationflags for process in cage._pool._processes] == [create_no_window] * 2


def test_the_windows_sweep_removes_every_stale_file_no_process_holds(monkeypatch, tmp_path):
    # Windows: no process id is asked (that could signal it); the OS refuses held files.
    simulated_os.simulate(monkeypatch, "windows", tmp_path)
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait()
    living = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    folder = tempfile.gettempdir()  # private to this test
    paths = {name: os.path.join(folder, f"gencoords-{owner}-{name}.shared") for name, owner in
             [("dead", ended.pid), ("unheld", living.pid), ("held", living.pid), ("mine", os.getpid()),
              ("old", "noowner")]}
    for path in paths.values():
        open(path, "wb").close()
    held = os.open(paths["held"], os.O_RDWR)  # in use: Windows refuses to remove it
    try:
        removed = gencoords.evaluation.shared_memory.sweep_stale_files()
    finally:
        os.close(held)
        living.kill()
        living.wait()
    assert sorted(removed) == sorted(paths[name] for name in ("dead", "unheld", "old"))
    assert sorted(os.listdir(folder)) == sorted(os.path.basename(paths[name]) for name in ("held", "mine"))


def test_workers_that_cannot_start_fall_back_to_this_process(monkeypatch, cage_and_points, automatic_two):
    # An interpreter without numpy (or a crash at start-up): automatic counts compute
    # here with a warning that quotes the worker; an explicit count raises.
    vertices, faces, points = cage_and_points
    expected = gencoords.coordinates(points, vertices, faces, workers=1)
    simulated_os.broken_start(monkeypatch)
    with pytest.warns(gencoords.WorkerWarning, match="No module named 'numpy'"):
        np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces), expected)
    with pytest.warns(gencoords.WorkerWarning, match="could not start"):
        np.testing.assert_array_equal(gencoords.point_locations(points, vertices, faces),
                                      gencoords.point_locations(points, vertices, faces, workers=1))
    with pytest.raises(gencoords.WorkerError, match="could not start.*pass workers=1"):
        gencoords.coordinates(points, vertices, faces, workers=2)
    # A kept cage warns once, then computes its automatic calls here.
    with gencoords.Cage(vertices, faces) as cage:
        with pytest.warns(gencoords.WorkerWarning):
            cage.coordinates(points)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            np.testing.assert_array_equal(cage.coordinates(points), expected)
        assert cage._pool is None
    assert not shared_files()


def test_an_interpreter_the_os_refuses_to_run_falls_back(monkeypatch, tmp_path, cage_and_points, automatic_two):
    # An antivirus blocking the interpreter: starting it raises OSError.
    vertices, faces, points = cage_and_points
    blocked = tmp_path / "python.exe"
    blocked.write_text("")
    blocked.chmod(0o600)
    monkeypatch.setattr(gencoords.evaluation.interpreters, "python_executable", lambda: str(blocked))
    with pytest.warns(gencoords.WorkerWarning, match="could not start"):
        result = gencoords.coordinates(points, vertices, faces)
    np.testing.assert_array_equal(result, gencoords.coordinates(points, vertices, faces, workers=1))
    with pytest.raises(gencoords.WorkerError, match="could not start"):
        gencoords.coordinates(points, vertices, faces, workers=2)


def test_a_worker_dying_mid_call_falls_back_for_automatic_counts(monkeypatch, cage_and_points, automatic_two):
    vertices, faces, points = cage_and_points
    cage = gencoords.Cage(vertices, faces)
    cage.coordinates(points[:400])
    processes = list(cage._pool._processes)
    sent = simulated_os.kill_mid_call(monkeypatch, cage._pool)
    with pytest.warns(gencoords.WorkerWarning, match="ended unexpectedly"):
        result = cage.coordinates(points)
    assert len(sent) == 3
    np.testing.assert_array_equal(result, cage.coordinates(points, workers=1))
    assert all(process.poll() is not None for process in processes)
    cage.close()


def test_stale_files_of_dead_processes_are_swept_when_workers_start(cage_and_points):
    vertices, faces, points = cage_and_points
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait()
    living = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    folder = tempfile.gettempdir()
    try:
        stale = os.path.join(folder, f"gencoords-{ended.pid}-test.shared")
        kept = [os.path.join(folder, f"gencoords-{living.pid}-test.shared"),
                os.path.join(folder, f"gencoords-noowner{os.getpid()}.shared")]  # an older name
        for path in [stale, *kept]:
            open(path, "wb").close()
        gencoords.coordinates(points, vertices, faces, workers=2)
        assert not os.path.exists(stale)
        assert all(os.path.exists(path) for path in kept)
    finally:
        living.kill()
        living.wait()
        for path in kept:
            os.unlink(path)


@pytest.mark.parametrize("windows, layout, expected", [
    (False, ["bin/python3.11", "bin/python3"], "bin/python3.11"),  # Blender on Linux and macOS
    (False, ["bin/python3", "bin/python"], "bin/python3"),  # a venv
    (True, ["bin/python.exe"], "bin/python.exe"),  # Blender on Windows
    (True, ["Scripts/python.exe"], "Scripts/python.exe"),  # a venv on Windows
    (True, ["python.exe"], "python.exe"),  # python.org on Windows
])
def test_the_interpreter_is_found_in_every_layout(tmp_path, windows, layout, expected):
    for name in layout:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("")
    candidates = gencoords.evaluation.interpreters.interpreter_candidates(str(tmp_path), (3, 11), windows)
    found = next(path for path in candidates if os.path.isfile(path))
    assert os.path.normpath(found) == os.path.normpath(tmp_path / expected)


def test_sizes_are_64_bit_whatever_the_shapes_integer_type():
    # numpy 1.x on Windows multiplies np.int32 lengths (and np.prod) in 32 bits.
    layout, size = gencoords.evaluation.shared_memory.shared_layout({"points": ((np.int32(60000), np.int32(3)), np.float64),
                                                "result": ((np.int32(60000), np.int32(50000)), np.float64)})
    assert size >= 60000 * 50000 * 8 > 2**31
    assert layout["result"][1] == (60000, 50000) and type(layout["result"][1][0]) is int

