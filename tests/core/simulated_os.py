"""Windows' and macOS' semantics on Linux, in the test process and in every worker.

``simulate(monkeypatch, system, holds)`` patches this process (undone by ``monkeypatch``)
and sets environment variables so that every worker started afterwards runs this file
first (``gencoords.evaluation.parallel.PRELUDE_VARIABLE``, the core's one test seam) and patches itself
the same way. Simulated, for ``system``:

- ``"macos"`` and ``"windows"``: no ``os.posix_fallocate``, ``os.sched_getaffinity``,
  ``os.statvfs`` (``shutil.disk_usage`` still works, as it does there), no ``/dev/shm``.
  The temporary folder is ``holds/temp``, private to the test (a simulated Windows
  sweep tries every file there, as Windows does, and must not meet other runs' files).
- ``"windows"`` also: the core takes its Windows branches (its ``_WINDOWS``, set in this
  process: workers only follow the parent), ``subprocess.Popen`` accepts (and records)
  ``creationflags``, and removing a ``gencoords-*.shared`` file raises PermissionError
  while any living process holds it open (``os.open``) or mapped (``mmap.mmap``). Holds
  are marker files in the folder ``holds``, one per open descriptor or mapping, named
  with the holder's process id, so that every process sees every other's (no
  ``/proc``); a dead process's holds are void, as Windows closes its handles.
  ``mmap.mmap(-1, size, tagname=name)`` (memory backed by the paging file, opened by
  name from every process) is a file ``holds/tagged/<name>``, held like the others and
  removed when its last living holder lets go; :func:`tagged_memory` lists those alive.

``broken_start(monkeypatch)`` makes every worker die at start-up the way an interpreter
without numpy does.

``kill_mid_call(monkeypatch, pool)`` kills a worker at a point where it certainly still
owes rows: killing it from a progress callback raced with it (a worker whose replies
were all in the pipe had nothing left to owe, and the call rightly succeeded).
"""

import itertools
import os
import sys

SYSTEM_VARIABLE = "GENCOORDS_SIMULATED_OS"
HOLDS_VARIABLE = "GENCOORDS_SIMULATED_HOLDS"
BROKEN_VARIABLE = "GENCOORDS_SIMULATED_BROKEN_START"
PRELUDE_VARIABLE = "GENCOORDS_WORKER_PRELUDE"  # gencoords.evaluation.parallel.PRELUDE_VARIABLE


class _Plain:
    """monkeypatch's setattr/delattr for a worker, where nothing needs undoing."""

    setattr = staticmethod(setattr)
    delattr = staticmethod(delattr)


def simulate(monkeypatch, system, holds):
    for folder in ("temp", "tagged"):
        os.makedirs(os.path.join(holds, folder), exist_ok=True)
    monkeypatch.setenv(PRELUDE_VARIABLE, os.path.abspath(__file__))
    monkeypatch.setenv(SYSTEM_VARIABLE, system)
    monkeypatch.setenv(HOLDS_VARIABLE, str(holds))
    _apply(monkeypatch, system, str(holds))
    if system == "windows":
        _take_the_windows_branches(monkeypatch)


def tagged_memory(holds):
    """Names of the simulated tagged mappings that a living process still holds: list."""
    return sorted(name for name in os.listdir(os.path.join(holds, "tagged"))
                  if _held(str(holds), name))


def _take_the_windows_branches(patch):
    import subprocess

    # The core's shared-memory module(s): imported as gencoords, or as the extension's core.
    for name, module in list(sys.modules.items()):
        if name.endswith("evaluation.shared_memory") and hasattr(module, "_WINDOWS"):
            patch.setattr(module, "_WINDOWS", True)

    class Popen(subprocess.Popen):
        def __init__(self, *args, creationflags=0, **options):
            self.creationflags = creationflags  # Linux refuses any but 0
            super().__init__(*args, **options)

    patch.setattr(subprocess, "Popen", Popen)


def broken_start(monkeypatch):
    monkeypatch.setenv(PRELUDE_VARIABLE, os.path.abspath(__file__))
    monkeypatch.setenv(BROKEN_VARIABLE, "1")


def kill_mid_call(monkeypatch, pool, index=0, after=2):
    """Kill worker ``index`` of ``pool`` (and wait until it is dead) just before the parent
    sends it its unit of rows number ``after + 1`` of the next call: it has computed some
    units (``after`` are in flight at a time), the other workers are busy, and the unit
    being sent is one only it was to compute, so the call cannot succeed. Returns the
    list of units sent to it (the test asserts the kill happened: longer than ``after``)."""
    send, sent = pool._send, []

    def sending(to, message):
        if to == index and message[0] == "rows":
            sent.append(message[1:3])
            if len(sent) == after + 1:
                pool._processes[index].kill()
                pool._processes[index].wait()
        return send(to, message)

    monkeypatch.setattr(pool, "_send", sending)
    return sent


def _apply(patch, system, holds):
    import shutil
    import tempfile

    real_statvfs, real_access = os.statvfs, os.access

    def disk_usage(path):  # what shutil gives on Windows and macOS, without os.statvfs
        status = real_statvfs(path)
        return shutil._ntuple_diskusage(status.f_blocks * status.f_frsize,
                                        (status.f_blocks - status.f_bfree) * status.f_frsize,
                                        status.f_bavail * status.f_frsize)

    def access(path, mode, **options):
        if os.fspath(path).startswith("/dev/shm"):
            return False
        return real_access(path, mode, **options)

    for name in ("posix_fallocate", "sched_getaffinity", "statvfs"):
        patch.delattr(os, name)
    patch.setattr(shutil, "disk_usage", disk_usage)
    patch.setattr(os, "access", access)
    patch.setattr(tempfile, "tempdir", os.path.join(holds, "temp"))
    if system == "windows":
        _refuse_removing_held_files(patch, holds)


def _shared(path):
    name = os.path.basename(os.fspath(path))
    return name.startswith("gencoords-") and name.endswith(".shared")


def _held(holds, name):
    """Whether a living process holds the file or tagged mapping ``name``."""
    prefix = name + "."
    for marker in os.listdir(holds):
        if marker.startswith(prefix):
            holder = int(marker[len(prefix):].split(".")[0])
            try:
                os.kill(holder, 0)
                return True
            except ProcessLookupError:
                pass  # the OS closed a dead process's handles
    return False


def _refuse_removing_held_files(patch, holds):
    import mmap

    real_open, real_close, real_unlink, real_mmap = os.open, os.close, os.unlink, mmap.mmap
    counter = itertools.count()
    descriptors = {}  # open descriptor -> (path, its hold)

    def hold(path):
        marker = os.path.join(holds, f"{os.path.basename(path)}.{os.getpid()}.{next(counter)}")
        real_close(real_open(marker, os.O_CREAT | os.O_WRONLY))
        return marker

    def let_go(marker):
        try:
            real_unlink(marker)
        except FileNotFoundError:
            pass

    def held(path):
        return _held(holds, os.path.basename(path))

    def open_(path, flags, mode=0o777, *, dir_fd=None):
        descriptor = real_open(path, flags, mode, dir_fd=dir_fd)
        if _shared(path):
            descriptors[descriptor] = (os.fspath(path), hold(path))
        return descriptor

    def close(descriptor):
        entry = descriptors.pop(descriptor, None)
        real_close(descriptor)
        if entry is not None:
            let_go(entry[1])

    def unlink(path, *, dir_fd=None):
        if _shared(path) and held(os.fspath(path)):
            raise PermissionError(13, "The process cannot access the file because it is being "
                                      "used by another process (simulated Windows)", os.fspath(path))
        real_unlink(path, dir_fd=dir_fd)

    def tagged(name, length):
        """The file standing for tagged memory ``name``, made anew where no living process
        holds one (Windows freed it), open: a descriptor."""
        path = os.path.join(holds, "tagged", name)
        if held(path):
            return real_open(path, os.O_RDWR)
        descriptor = real_open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC)
        os.ftruncate(descriptor, length)
        return descriptor

    class Mapping(real_mmap):
        # Let go in __del__, which runs before weak references are cleared: a real mmap
        # unmaps before its weak references' callbacks run.
        def __new__(cls, fileno, length, *args, tagname=None, **options):
            if tagname is None:
                mapping = super().__new__(cls, fileno, length, *args, **options)
                mapping.hold = hold(descriptors[fileno][0]) if fileno in descriptors else None
                mapping.tagged = None
                return mapping
            descriptor = tagged(tagname, length)
            try:
                mapping = super().__new__(cls, descriptor, length, *args, **options)
            finally:
                real_close(descriptor)
            mapping.tagged = os.path.join(holds, "tagged", tagname)
            mapping.hold = hold(mapping.tagged)
            return mapping

        def __del__(self):
            if self.hold is not None:
                let_go(self.hold)
            if self.tagged is not None and not held(self.tagged):  # the last handle closed
                try:
                    real_unlink(self.tagged)
                except FileNotFoundError:
                    pass

    patch.setattr(os, "open", open_)
    patch.setattr(os, "close", close)
    patch.setattr(os, "unlink", unlink)
    patch.setattr(os, "remove", unlink)
    patch.setattr(mmap, "mmap", Mapping)


if __name__ == "<run_path>":  # a worker's prelude
    if os.environ.get(BROKEN_VARIABLE):
        sys.stderr.write("Traceback (most recent call last):\n"
                         "ModuleNotFoundError: No module named 'numpy' (simulated)\n")
        sys.exit(1)
    if os.environ.get(SYSTEM_VARIABLE):
        _apply(_Plain, os.environ[SYSTEM_VARIABLE], os.environ[HOLDS_VARIABLE])
