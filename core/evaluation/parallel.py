"""Worker processes: the points of one call split over fresh Python interpreters.

Threads do not help: the construction is many small numpy calls, each holding the
interpreter lock. Processes do. Each worker is a Python interpreter (the venv's, or the
one Blender bundles, never Blender itself: :func:`python_executable`) running only this
package and numpy: the package is imported by its folder, so a parent package that
needs bpy is never imported, and no ``multiprocessing`` start method re-runs the
caller's script.

Data crosses in shared memory, never pickled: a call's points, locations and result
live in one mapping shared by the parent and every worker. Nothing is left behind on
any OS, after success, failure, a kill or a crash:

- Windows: memory backed by the paging file under a random tag name,
  ``gencoords-<parent pid>-<random>`` (``mmap.mmap(-1, size, tagname=...)``), never a
  file: Windows refuses to remove a file that any process holds, and the caller may
  keep the result (a view of the mapping) until it exits. The OS frees the memory when
  the last process holding it closes it or ends.
- Linux and macOS: a memory-mapped file ``gencoords-<parent pid>-<random>.shared`` (in
  ``/dev/shm`` where there is one, else the temporary folder), whose name goes as soon
  as the workers have mapped it (the mappings stay valid).

The workers release the mapping at the end of every call, so a kept pool holds no
memory between calls. A file a crash left behind (its owner dead; on Windows, one an
older version made that no process holds) is swept when the next pool starts
(:func:`sweep_stale_files`). Commands and replies are small pickles on the workers'
stdin and stdout.

Test seam: where the environment variable ``GENCOORDS_WORKER_PRELUDE`` names a Python
file, every worker runs it before serving (the tests simulate Windows' and macOS'
semantics in the workers with it); nothing else reads it.

A worker keeps its prepared cage between calls (a :class:`gencoords.Cage` owns its pool).
It computes whole chunks of :func:`gencoords.evaluation.rows.chunk_size` points, the same chunks
as one process, so the result is bitwise the same as ``workers=1``.
"""

import collections
import glob
import math
import mmap
import os
import pickle
import queue
import secrets
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings
import weakref

import numpy as np

from ..base.errors import WorkerError, WorkerWarning

__all__ = ["available_cores", "python_executable", "interpreter_candidates", "dispatch_units",
           "WorkerPool", "SharedArrays", "shared_layout", "shared_files", "sweep_stale_files", "computed_here_instead", "serve"]

# A worker gets this many dispatch units at a time: one computing, one queued, so it
# never waits on the parent.
_UNITS_IN_FLIGHT = 2
# Dispatch units: at most 1/8 of a worker's share of a call (progress reports and a
# cancel come between units), and from there on half the rows left per worker, so the
# units shrink towards the end and the workers finish together (equal units left one
# worker idle for 40 ms of a 650 ms call, measured).
_UNITS_PER_WORKER = 8
_UNIT_SHARE = 0.5
_STOP_SECONDS = 5.0
PRELUDE_VARIABLE = "GENCOORDS_WORKER_PRELUDE"
_BOOT = ("import sys, os, types; sys.path.insert(0, sys.argv[1]); "
         f"prelude = os.environ.get({PRELUDE_VARIABLE!r}); "
         "prelude and __import__('runpy').run_path(prelude); "
         # The package without its __init__, which imports every module (40 ms of each
         # start): a worker imports the evaluation, and the modules its tasks name.
         "package = types.ModuleType(sys.argv[2]); package.__path__ = [os.path.join(*sys.argv[1:3])]; "
         "sys.modules.setdefault(sys.argv[2], package); "
         "import importlib; importlib.import_module(sys.argv[2] + '.evaluation.parallel').serve(); "
         # Done: exit without the interpreter's teardown (60 ms of every Bind's waiting).
         "sys.stderr.flush(); os._exit(0)")
_PREFIX = "gencoords-"
_SUFFIX = ".shared"
_RAM_FOLDER = "/dev/shm"
# Read when used, not at import: the tests simulate Windows on Linux by setting it.
_WINDOWS = os.name == "nt"
# subprocess.CREATE_NO_WINDOW (defined on Windows only): no console window per worker
# (Blender has none to share when started from its icon), no output in the artist's.
_CREATE_NO_WINDOW = 0x08000000
_STDERR_KEPT = 40  # lines of a worker's stderr quoted when it dies
_ZEROS = 1 << 22  # bytes written at a time where space is reserved by writing zeros
# BLAS threads in every worker would oversubscribe the cores the workers already use.
_SINGLE_THREADED = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                           "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")}


def available_cores():
    """Cores this process may run on (its affinity where the OS reports it): int."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def python_executable():
    """The Python interpreter to start workers with: str.

    ``sys.executable``, which Blender (2.91 and later) sets to the Python it bundles;
    where it is missing or is not a Python (some embedding programs leave it unset or
    point it at themselves), the first of :func:`interpreter_candidates` that exists.
    """
    name = os.path.basename(sys.executable or "").lower()
    if name.startswith("python"):
        return sys.executable
    for candidate in interpreter_candidates(sys.prefix, sys.version_info, os.name == "nt"):
        if os.path.isfile(candidate):
            return candidate
    raise WorkerError(f"no Python interpreter found to start worker processes (sys.executable is "
                      f"{sys.executable!r}, none under {sys.prefix!r}); pass workers=1 to compute "
                      "in this process")


def interpreter_candidates(prefix, version, windows):
    """Where a Python installation rooted at ``sys.prefix`` keeps its interpreter, most
    specific first: list of str.

    Blender's bundled Python (``<version>/python/bin/python3.11`` on Linux and macOS,
    ``<version>\\python\\bin\\python.exe`` on Windows), a venv (``bin/python3``;
    ``Scripts\\python.exe`` on Windows) and a plain installation (``bin/python3``;
    ``python.exe`` at the top on Windows).
    """
    if windows:
        return [os.path.join(prefix, folder, "python.exe") for folder in ("bin", "Scripts", "")]
    names = (f"python{version[0]}.{version[1]}", f"python{version[0]}", "python")
    return [os.path.join(prefix, "bin", name) for name in names]


def dispatch_units(count, chunk, workers):
    """Row ranges for :meth:`WorkerPool.run`: whole chunks, shrinking towards the end.

    Parameters
    ----------
    count, chunk, workers : int
        Rows, rows per chunk (units are made of whole chunks, so the rows are computed
        as in one process), worker processes.

    Returns
    -------
    units : list of (start, stop)
        In dispatch order, covering 0..count.
    """
    units, start = [], 0
    largest = max(1, count // (chunk * workers * _UNITS_PER_WORKER))
    while start < count:
        chunks = max(1, min(largest, int((count - start) * _UNIT_SHARE / (workers * chunk))))
        units.append((start, min(start + chunks * chunk, count)))
        start = units[-1][1]
    return units


class SharedArrays:
    """Named arrays in memory that workers map too: tagged memory on Windows, a
    memory-mapped temporary file elsewhere (the module's docstring says why).

    Parameters
    ----------
    specs : dict of name -> (shape, dtype)
    reserved_by_writers : sequence of str
        Arrays whose memory the writers may reserve row by row (they come last in ``specs``).

    Attributes
    ----------
    arrays : dict of name -> ndarray
        Views of the mapping; they keep it alive after this object is gone.
    layout : dict of name -> (offset, shape, dtype string)
        What a worker needs to map the same arrays (:func:`attach`), with ``address``.
    address : (kind, name, size)
        ``("tagname", tag name, bytes)`` on Windows, ``("path", file, bytes)`` elsewhere.
    path : str or None
        The file, ``gencoords-<this process's id>-<random>.shared``; None on Windows.
    reserved_by_writers : tuple of str
        Arrays whose memory the writers reserve, row by row, before writing them
        (:func:`reserve_rows`). Empty where the file is not in /dev/shm or the OS has no
        ``posix_fallocate`` (then it is reserved whole, here) and on Windows (the OS
        commits the whole mapping when it is made).

    Raises
    ------
    WorkerError
        No room for the memory or the file, or no usable temporary folder (its message
        says what to do).
    """

    def __init__(self, specs, reserved_by_writers=()):
        self.layout, size = shared_layout(specs)
        self.path = self._removal = None
        if _WINDOWS:
            self._mapping, name = _tagged_memory(size)
            self.reserved_by_writers, self.address = (), ("tagname", name, size)
        else:
            self._mapping, self.path, self.reserved_by_writers = _shared_file(
                size, self.layout, reserved_by_writers)
            self.address = ("path", self.path, size)
        self.arrays = _views(self._mapping, self.layout)

    def remove(self):
        """Remove the file's name (nothing to do for Windows' tagged memory): now where the
        OS allows it (a mapped file's name can go on Linux and macOS; the mappings stay
        valid), else once this process's last view of it is gone."""
        if self.path is None:
            return
        try:
            os.unlink(self.path)
        except FileNotFoundError:
            pass
        except PermissionError:
            if self._removal is None:
                # Runs after the mapping is unmapped (mmap clears weak references last).
                self._removal = weakref.finalize(self._mapping, _remove_quietly, self.path)


def _tagged_memory(size):
    """Windows: ``size`` bytes backed by the paging file under a new random tag name, which
    the workers open (:func:`attach`): (mmap, name). Nothing is on disk; the OS commits the
    whole size here (so no writer can fail for want of it) and frees it when the last
    process holding it closes it or ends."""
    name = f"{_PREFIX}{os.getpid()}-{secrets.token_hex(8)}"
    try:
        return mmap.mmap(-1, size, tagname=name), name
    except OSError as error:
        raise WorkerError(f"no memory for {size / 2**20:.0f} MB of shared results ({error}): close "
                          "other programs, or pass workers=1 to compute in this process") from error


def _shared_file(size, layout, reserved_by_writers):
    """Linux and macOS: a new shared file of ``size`` bytes, its space reserved, mapped:
    (mmap, path, the arrays of ``reserved_by_writers`` that the writers reserve)."""
    # RAM (/dev/shm) where it has room, else the temporary folder (page cache). Space is
    # reserved before anything is written: a full tmpfs (containers give it 64 MB) or
    # disk would otherwise kill the writers with SIGBUS halfway through. Reserving zeroes
    # the memory (45 ms for a 205 MB result, with the workers waiting): in /dev/shm the
    # writers reserve their own rows as they go (:func:`reserve_rows`).
    in_ram = os.access(_RAM_FOLDER, os.W_OK)
    while True:
        folder = _RAM_FOLDER if in_ram else _temporary_folder()
        deferred = tuple(reserved_by_writers) if in_ram and hasattr(os, "posix_fallocate") else ()
        upfront = min((layout[name][0] for name in deferred), default=size)
        try:
            free = _free_bytes(folder)
            if free < size:
                raise OSError(f"{free / 2**20:.0f} MB free")
            return (*_mapped_file(folder, size, upfront), deferred)
        except OSError as error:
            if not in_ram:
                raise WorkerError(f"no room for {size / 2**20:.0f} MB of shared results in "
                                  f"{folder} ({error}): free some disk space, or pass workers=1 "
                                  "to compute in this process") from error
            in_ram = False


def _temporary_folder():
    """The temporary folder; WorkerError where there is none usable (tempfile raises
    FileNotFoundError when no candidate folder is writable)."""
    try:
        return tempfile.gettempdir()
    except OSError as error:
        raise WorkerError(f"no usable temporary folder for the shared results ({error}): set "
                          "TMPDIR to a writable folder with free space, or pass workers=1 to "
                          "compute in this process") from error


def shared_layout(specs):
    """Where :class:`SharedArrays` puts ``specs`` (dict of name -> (shape, dtype)):
    (layout as its attribute, file size in bytes)."""
    layout, offset = {}, 0
    for name, (shape, dtype) in specs.items():
        dtype = np.dtype(dtype)
        # Python ints: numpy 1.x on Windows multiplies in 32 bits (np.prod, np.int32 shapes).
        shape = tuple(int(length) for length in shape)
        layout[name] = (offset, shape, dtype.str)
        offset += -(-math.prod(shape) * dtype.itemsize // 64) * 64  # cache-line aligned
    return layout, max(offset, 1)


def _mapped_file(folder, size, upfront):
    """A new shared file of ``size`` bytes in ``folder``, its first ``upfront`` bytes
    reserved, mapped: (mmap, path). Nothing is left behind on a failure."""
    descriptor, path = tempfile.mkstemp(prefix=f"{_PREFIX}{os.getpid()}-", suffix=_SUFFIX, dir=folder)
    try:
        os.ftruncate(descriptor, size)
        _reserve(descriptor, 0, upfront)
        mapping = mmap.mmap(descriptor, size)
    except BaseException:
        os.close(descriptor)  # first: Windows refuses to remove an open file
        _remove_quietly(path)
        raise
    os.close(descriptor)  # the mapping keeps the file
    return mapping, path


def _reserve(descriptor, offset, length):
    """Allocate ``length`` bytes of the file from ``offset``, so that writing them through
    a mapping cannot fail (SIGBUS) for want of space; OSError where there is no room."""
    if length <= 0:
        return
    if hasattr(os, "posix_fallocate"):  # Linux
        os.posix_fallocate(descriptor, offset, length)
    else:  # macOS: ftruncate made a sparse file; zeros written are allocated
        zeros = memoryview(bytes(min(_ZEROS, length)))
        os.lseek(descriptor, offset, os.SEEK_SET)
        end = offset + length
        while offset < end:
            offset += os.write(descriptor, zeros[:end - offset])


def _free_bytes(folder):
    return shutil.disk_usage(folder).free


def _remove_quietly(path):
    try:
        os.unlink(path)
    except OSError:
        pass


def sweep_stale_files():
    """Remove the shared files of processes that ended without removing them (a crash,
    a kill, Windows at exit): list of the paths removed.

    A file's owner is the process id in its name. Linux and macOS: its files go once
    that process is gone. Windows (files of older versions; this one makes none there,
    and asking a process id could signal it): every file is tried, and the OS refuses
    those that a living process holds. Never raises: a folder it cannot read is skipped.
    """
    removed = []
    for path in shared_files():
        owner = _owner(path)
        if owner == os.getpid():
            continue
        if not _WINDOWS and (owner is None or _alive(owner)):
            continue
        try:
            os.unlink(path)
        except OSError:  # in use (Windows), or another sweep was first
            continue
        removed.append(path)
    return removed


def shared_files(owner=None):
    """The shared files in the folders they are made in, of every process or of the
    process id ``owner``: list of str."""
    pattern = f"{_PREFIX}*{_SUFFIX}" if owner is None else f"{_PREFIX}{int(owner)}-*{_SUFFIX}"
    folders = [_RAM_FOLDER] if os.access(_RAM_FOLDER, os.W_OK) else []
    try:
        folders.append(tempfile.gettempdir())
    except OSError:  # no usable temporary folder: nothing made there either
        pass
    return [path for folder in folders for path in glob.glob(os.path.join(glob.escape(folder), pattern))]


def _owner(path):
    """The process id in a shared file's name, or None (a name without one)."""
    field = os.path.basename(path)[len(_PREFIX):].split("-", 1)[0]
    return int(field) if field.isdigit() else None


def _alive(pid):
    try:
        os.kill(pid, 0)  # POSIX: no signal, only the check
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def _views(mapping, layout):
    return {name: np.frombuffer(mapping, dtype=np.dtype(dtype), count=math.prod(shape),
                                offset=offset).reshape(shape)
            for name, (offset, shape, dtype) in layout.items()}


def attach(address, layout):
    """A worker's views of a parent's :class:`SharedArrays` (its ``address`` and ``layout``):
    (dict of name -> ndarray, an open file descriptor for :func:`reserve_rows`, closed by
    the caller; None for Windows' tagged memory)."""
    kind, name, size = address
    if kind == "tagname":  # opens the parent's mapping: same name, same size
        return _views(mmap.mmap(-1, size, tagname=name), layout), None
    descriptor = os.open(name, os.O_RDWR | getattr(os, "O_BINARY", 0))
    try:
        return _views(mmap.mmap(descriptor, 0), layout), descriptor
    except BaseException:
        os.close(descriptor)
        raise


def reserve_rows(descriptor, layout, names, start, stop):
    """Reserve rows ``start:stop`` of the named shared arrays before writing them: a full
    /dev/shm then raises WorkerError here instead of killing the writer with SIGBUS."""
    for name in names:
        offset, shape, dtype = layout[name]
        row_bytes = math.prod(shape[1:]) * np.dtype(dtype).itemsize
        if stop > start and row_bytes:
            try:
                _reserve(descriptor, offset + start * row_bytes, (stop - start) * row_bytes)
            except OSError as error:
                raise WorkerError(f"could not reserve shared memory for the result ({error}); "
                                  "/dev/shm may be full: free some of it, or pass workers=1") from error


def computed_here_instead(error):
    """Warn (:class:`WorkerWarning`) that worker processes failed with ``error`` and the
    call is computed in this process instead."""
    warnings.warn(f"worker processes failed, computing in this process instead: {error}",
                  WorkerWarning, stacklevel=3)


class WorkerPool:
    """Worker processes holding one prepared cage.

    Parameters
    ----------
    vertices : (n, N) float
    faces : (m, N) int
        A cage already validated by the caller (workers do not validate again).
    count : int
        Number of processes.
    """

    def __init__(self, vertices, faces, count):
        sweep_stale_files()
        creation_flags = _CREATE_NO_WINDOW if _WINDOWS else 0  # POSIX Popen refuses any
        # The core's own folder (``core/`` in the repository and the extension,
        # ``gencoords/`` when pip-installed), two levels up from evaluation/parallel.py.
        package_folder = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        command = [python_executable(), "-c", _BOOT, os.path.dirname(package_folder),
                   os.path.basename(package_folder)]
        environment = dict(os.environ, **_SINGLE_THREADED)
        self._replies = queue.Queue()
        self._processes, self._stderr, self._stderr_readers = [], [], []
        self._closed = False
        try:
            for index in range(count):
                # stderr is kept to quote when a worker dies, not printed in the artist's console.
                process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE, env=environment,
                                           creationflags=creation_flags)
                self._processes.append(process)
                self._stderr.append(collections.deque(maxlen=_STDERR_KEPT))
                for target, args in ((_read_replies, (index, process.stdout, self._replies)),
                                     (_read_lines, (process.stderr, self._stderr[index]))):
                    thread = threading.Thread(target=target, args=args, daemon=True)
                    thread.start()
                self._stderr_readers.append(thread)
                self._send(index, ("cage", np.asarray(vertices, np.float64), np.asarray(faces, np.int64)))
            for _ in range(count):
                self._receive()  # "ready": each started, imported numpy and prepared the cage
        except BaseException as error:
            self.close()
            if not isinstance(error, (OSError, WorkerError)):  # a cancel (KeyboardInterrupt)
                raise
            raise WorkerError(f"worker processes could not start with {command[0]!r} (pass workers=1 "
                              f"to compute in this process): {error}") from error
        # Stop the workers whatever happens to the pool (garbage, interpreter exit).
        self._finalizer = weakref.finalize(self, _stop_processes, list(self._processes))

    @property
    def size(self):
        return len(self._processes)

    @property
    def closed(self):
        """Whether the workers are stopped (after close(), a failure or a cancel): bool."""
        return self._closed

    def _ended(self, index, status):
        """The WorkerError for worker ``index`` gone with exit ``status``, quoting its stderr."""
        process = self._processes[index]
        if process.poll() is not None:
            self._stderr_readers[index].join(timeout=1.0)  # its last words
        said = "".join(list(self._stderr[index])).strip()
        return WorkerError(f"worker process {process.pid} ended unexpectedly (exit status {status}; "
                           "try again, or pass workers=1 to compute in this process)"
                           + (f", saying:\n{said}" if said else ""))

    def _send(self, index, message):
        process = self._processes[index]
        try:
            pickle.dump(message, process.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            process.stdin.flush()
        except OSError as error:  # a broken pipe: the worker is gone (killed, crashed)
            try:
                status = process.wait(timeout=_STOP_SECONDS)
            except subprocess.TimeoutExpired:
                status = "unknown"
            raise self._ended(index, status) from error

    def _receive(self):
        """The next reply; raises WorkerError for a failed or vanished worker."""
        while True:
            try:
                index, reply = self._replies.get(timeout=1.0)
            except queue.Empty:
                for index, process in enumerate(self._processes):
                    if process.poll() is not None:
                        raise self._ended(index, process.returncode)
                continue
            if reply[0] == "error":
                raise WorkerError(f"worker process {self._processes[index].pid} failed:\n{reply[1]}")
            if reply[0] == "closed":
                raise self._ended(index, self._processes[index].wait())
            return index, reply

    def run(self, shared, job, units, progress=None, stop_early=None):
        """Compute ``units`` (row ranges) of ``job`` into ``shared``, spread over the workers.

        Parameters
        ----------
        shared : SharedArrays
            With the arrays the job names.
        job : dict
            Parameters of :func:`_compute` (kind, outside, ...).
        units : list of (start, stop)
        progress : callable, optional
            ``progress(rows_done)`` on the calling thread after each unit.
        stop_early : callable, optional
            ``stop_early(reply)`` after each unit; True makes the remaining units
            "locate only" (with outside="raise", once a point is outside).

        Any exception (a worker's, or one raised by ``progress``, a cancel) closes the
        pool: its workers are stopped before the exception propagates.
        """
        try:
            if self._closed:
                raise WorkerError("the worker pool is closed")
            for index in range(self.size):
                self._send(index, ("map", shared.address, shared.layout, shared.reserved_by_writers, job))
            for _ in range(self.size):
                self._receive()  # "mapped"
            shared.remove()  # Linux, macOS: the name gone now, whatever happens next
            pending = list(reversed(units))
            busy = [0] * self.size
            locate_only = False
            for index in range(self.size):
                for _ in range(_UNITS_IN_FLIGHT):
                    if pending:
                        self._send(index, ("rows", *pending.pop(), locate_only))
                        busy[index] += 1
            done = 0
            while any(busy):
                index, reply = self._receive()
                busy[index] -= 1
                done += reply[2] - reply[1]
                if stop_early is not None and not locate_only:
                    locate_only = bool(stop_early(reply))
                if pending:
                    self._send(index, ("rows", *pending.pop(), locate_only))
                    busy[index] += 1
                if progress is not None:
                    progress(done)
        except BaseException:
            self.close()  # stopped workers hold nothing
            raise
        finally:
            if not self._closed:
                self._release()
            shared.remove()

    def _release(self):
        """Have the workers unmap the call's shared file (Windows removes it only once no
        process holds it); a worker failing to closes the pool (a dead one holds nothing)."""
        try:
            for index in range(self.size):
                self._send(index, ("release",))
            for _ in range(self.size):
                self._receive()  # "released"
        except WorkerError:
            self.close()

    def close(self):
        """Stop the workers (idempotent)."""
        self._closed = True
        finalizer = getattr(self, "_finalizer", None)
        if finalizer is not None:
            finalizer()
        else:
            _stop_processes(self._processes)


def _stop_processes(processes):
    for process in processes:
        try:
            process.stdin.close()  # a worker exits at the end of its input
        except OSError:
            pass
    for process in processes:
        try:
            process.wait(timeout=_STOP_SECONDS)
        except subprocess.TimeoutExpired:  # busy with a unit nobody wants any more
            process.kill()
            process.wait()
        for pipe in (process.stdout, process.stderr):
            if pipe is not None:
                pipe.close()


def _read_lines(pipe, lines):
    try:
        for line in pipe:
            lines.append(line.decode(errors="replace"))
    except (OSError, ValueError):
        pass


def _read_replies(index, pipe, replies):
    try:
        while True:
            replies.put((index, pickle.load(pipe)))
    except (EOFError, OSError, ValueError, pickle.UnpicklingError):  # ValueError: pipe closed here
        replies.put((index, ("closed",)))


def serve():
    """A worker's main loop: commands from stdin, replies to stdout, until stdin ends."""
    import traceback

    from ..construction.general import prepare_cage
    from .rows import evaluate_rows, evaluation_terms, keep_freed_memory_for_reuse, locate_rows

    commands, replies = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # nothing but replies on the reply pipe

    def reply(*message):
        pickle.dump(message, replies, protocol=pickle.HIGHEST_PROTOCOL)
        replies.flush()

    cage = terms = arrays = job = descriptor = None
    keep_freed_memory_for_reuse()
    while True:
        try:
            command = pickle.load(commands)
        except EOFError:
            return
        try:
            if command[0] == "cage":
                cage = prepare_cage(command[1], command[2])
                terms = evaluation_terms(cage)
                reply("ready")
            elif command[0] == "map":
                if descriptor is not None:
                    os.close(descriptor)
                arrays = descriptor = None
                address, layout, reserved, job = command[1:]
                arrays, descriptor = attach(address, layout)
                reply("mapped")
            elif command[0] == "release":  # a kept pool holds no memory between calls
                if descriptor is not None:
                    os.close(descriptor)
                arrays = descriptor = None  # the last views: unmapped
                reply("released")
            elif command[0] == "rows":
                start, stop, locate_only = command[1:]
                reserve_rows(descriptor, layout, reserved, start, stop)
                if "task" in job:  # another computation of the package, by name
                    outside = _run_task(job["task"], arrays, job, start, stop)
                else:
                    outside = _compute(cage, terms, arrays, job, start, stop, locate_only,
                                       evaluate_rows, locate_rows)
                reply("done", start, stop, outside)
        except BaseException:  # reported, then the worker stops
            reply("error", traceback.format_exc())
            return


def _run_task(task, arrays, job, start, stop):
    """Rows ``start:stop`` of a job naming its own function, ``"module:function"`` within
    this package (e.g. ``"harmonic.solve:solve_columns_task"``), called as
    ``function(arrays, job, start, stop)``; returns 0 (no outside points)."""
    import importlib

    module, _, name = task.partition(":")
    package = __name__.rpartition(".")[0].rpartition(".")[0]  # <package>.evaluation.parallel
    getattr(importlib.import_module(f"{package}.{module}"), name)(arrays, job, start, stop)
    return 0


def _compute(cage, terms, arrays, job, start, stop, locate_only, evaluate, locate):
    """One unit of rows, in chunks; returns the number of outside points in it."""
    from ..construction.boundary import OUTSIDE

    points, locations, result = arrays["points"], arrays["locations"], arrays.get("result")
    outside = 0
    step = job["chunk"]
    for begin in range(start, stop, step):
        rows = slice(begin, min(begin + step, stop))
        if locate_only or result is None:
            where = locate(cage, points[rows], job["absolute"], job["convex"])
        else:
            where = evaluate(cage, terms, points[rows], job["kind"], job["convex"], job["absolute"],
                             job["outside"], job["normalise"], result[rows], job.get("gamma"))
        locations[rows] = where
        outside += int(np.count_nonzero(where == OUTSIDE))
        if outside and job["outside"] == "raise":
            locate_only = True
    return outside
