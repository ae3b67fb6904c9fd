"""Worker processes: the points of one call split over fresh Python interpreters.

Threads do not help: the construction is many small numpy calls, each holding the
interpreter lock. Processes do. Each worker is a Python interpreter (the venv's, or the
one Blender bundles, never Blender itself: :func:`python_executable`) running only this
package and numpy: the package is imported by its folder, so a parent package that
needs bpy is never imported, and no ``multiprocessing`` start method re-runs the
caller's script.

Data crosses in shared memory, never pickled: a call's points, locations and result
live in one memory-mapped file (in ``/dev/shm`` where there is one), mapped by the
parent and by every worker; the file's name is removed as soon as the workers have
mapped it, so nothing is left behind whatever happens next. Commands and replies are
small pickles on the workers' stdin and stdout.

A worker keeps its prepared cage between calls (a :class:`core.Cage` owns its pool).
It computes whole chunks of :func:`core.evaluation.chunk_size` points, the same chunks
as one process, so the result is bitwise the same as ``workers=1``.
"""

import mmap
import os
import pickle
import queue
import subprocess
import sys
import tempfile
import threading
import weakref

import numpy as np

from .errors import WorkerError

__all__ = ["available_cores", "python_executable", "dispatch_units", "WorkerPool", "SharedArrays",
           "serve"]

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
_BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); "
         "import importlib; importlib.import_module(sys.argv[2] + '.parallel').serve()")
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
    point it at themselves), the interpreter under ``sys.prefix``.
    """
    name = os.path.basename(sys.executable or "").lower()
    if name.startswith("python"):
        return sys.executable
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    for candidate in (os.path.join(sys.prefix, "bin", f"python{version}"),
                      os.path.join(sys.prefix, "bin", "python3"), os.path.join(sys.prefix, "python.exe"),
                      os.path.join(sys.prefix, "bin", "python.exe")):
        if os.path.isfile(candidate):
            return candidate
    raise WorkerError(f"no Python interpreter found to start worker processes (sys.executable is "
                      f"{sys.executable!r}); pass workers=1")


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
    """Named arrays in one memory-mapped temporary file that workers map too.

    Parameters
    ----------
    specs : dict of name -> (shape, dtype)

    Attributes
    ----------
    arrays : dict of name -> ndarray
        Views of the mapping; they keep it alive after this object is gone.
    layout : dict of name -> (offset, shape, dtype string)
        What a worker needs to map the same arrays (:func:`attach`).
    reserved_by_writers : tuple of str
        Arrays whose memory the writers reserve, row by row, before writing them
        (:func:`reserve_rows`); they come last in ``specs``. Empty where the file is not
        in /dev/shm (then it is reserved whole, here).
    """

    def __init__(self, specs, reserved_by_writers=()):
        self.layout, offset = {}, 0
        for name, (shape, dtype) in specs.items():
            dtype = np.dtype(dtype)
            self.layout[name] = (offset, tuple(shape), dtype.str)
            offset += -(-int(np.prod(shape)) * dtype.itemsize // 64) * 64  # cache-line aligned
        size = max(offset, 1)
        # RAM (/dev/shm) where it has room, else the temporary folder (page cache). Space
        # is reserved before anything is written: a full tmpfs (containers give it 64 MB)
        # would otherwise kill the writers with SIGBUS halfway through. Reserving zeroes
        # the memory (45 ms for a 205 MB result, with the workers waiting): in /dev/shm
        # the writers reserve their own rows as they go (:func:`reserve_rows`).
        folders = ("/dev/shm", None) if os.access("/dev/shm", os.W_OK) else (None,)
        can_reserve = hasattr(os, "posix_fallocate")
        for folder in folders:
            descriptor, self.path = tempfile.mkstemp(prefix="gencoords-", suffix=".shared", dir=folder)
            try:
                if folder is not None and _free_bytes(folder) < size:
                    raise OSError(f"{folder} has less than {size / 2**20:.0f} MB free")
                deferred = tuple(reserved_by_writers) if folder is not None and can_reserve else ()
                upfront = min((self.layout[name][0] for name in deferred), default=size)
                os.ftruncate(descriptor, size)
                if can_reserve and upfront:
                    os.posix_fallocate(descriptor, 0, upfront)
                self._mapping = mmap.mmap(descriptor, size)
                self.reserved_by_writers = deferred
                break
            except OSError as error:
                self.remove()
                if folder is None:
                    raise WorkerError(f"no room for {size / 2**20:.0f} MB of shared results "
                                      f"({error}); pass workers=1") from error
            except BaseException:
                self.remove()
                raise
            finally:
                os.close(descriptor)
        self.arrays = _views(self._mapping, self.layout)

    def remove(self):
        """Remove the file's name (mappings stay valid until unmapped)."""
        try:
            os.unlink(self.path)
        except FileNotFoundError:
            pass
        except PermissionError:  # Windows cannot remove a mapped file: once unmapped
            weakref.finalize(self._mapping, _remove_quietly, self.path)


def _free_bytes(folder):
    status = os.statvfs(folder)
    return status.f_bavail * status.f_frsize


def _remove_quietly(path):
    try:
        os.unlink(path)
    except OSError:
        pass


def _views(mapping, layout):
    return {name: np.frombuffer(mapping, dtype=np.dtype(dtype), count=int(np.prod(shape)),
                                offset=offset).reshape(shape)
            for name, (offset, shape, dtype) in layout.items()}


def attach(path, layout):
    """A worker's views of a parent's :class:`SharedArrays`: (dict of name -> ndarray,
    an open file descriptor for :func:`reserve_rows`, closed by the caller)."""
    descriptor = os.open(path, os.O_RDWR)
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
        row_bytes = int(np.prod(shape[1:])) * np.dtype(dtype).itemsize
        if stop > start and row_bytes:
            try:
                os.posix_fallocate(descriptor, offset + start * row_bytes, (stop - start) * row_bytes)
            except OSError as error:
                raise WorkerError(f"could not reserve shared memory for the result ({error}); "
                                  "/dev/shm may be full: free some of it, or pass workers=1") from error


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
        package_folder = os.path.dirname(os.path.abspath(__file__))
        command = [python_executable(), "-c", _BOOT, os.path.dirname(package_folder),
                   os.path.basename(package_folder)]
        environment = dict(os.environ, **_SINGLE_THREADED)
        self._replies = queue.Queue()
        self._processes = []
        self._closed = False
        try:
            for index in range(count):
                process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                           env=environment)
                self._processes.append(process)
                threading.Thread(target=_read_replies, args=(index, process.stdout, self._replies),
                                 daemon=True).start()
                self._send(index, ("cage", np.asarray(vertices, np.float64), np.asarray(faces, np.int64)))
        except (OSError, WorkerError) as error:  # could not start, or died at once
            self.close()
            raise WorkerError(f"could not start worker processes with {command[0]!r}: {error}; "
                              "pass workers=1 to compute in this process") from error
        # Stop the workers whatever happens to the pool (garbage, interpreter exit).
        self._finalizer = weakref.finalize(self, _stop_processes, list(self._processes))

    @property
    def size(self):
        return len(self._processes)

    @property
    def closed(self):
        """Whether the workers are stopped (after close(), a failure or a cancel): bool."""
        return self._closed

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
            raise WorkerError(f"worker process {process.pid} ended unexpectedly (exit status "
                              f"{status})") from error

    def _receive(self):
        """The next reply; raises WorkerError for a failed or vanished worker."""
        while True:
            try:
                index, reply = self._replies.get(timeout=1.0)
            except queue.Empty:
                for index, process in enumerate(self._processes):
                    if process.poll() is not None:
                        raise WorkerError(f"worker process {process.pid} ended unexpectedly "
                                          f"(exit status {process.returncode})")
                continue
            if reply[0] == "error":
                raise WorkerError(f"worker process {self._processes[index].pid} failed:\n{reply[1]}")
            if reply[0] == "closed":
                status = self._processes[index].wait()
                raise WorkerError(f"worker process {self._processes[index].pid} ended unexpectedly "
                                  f"(exit status {status})")
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
                self._send(index, ("map", shared.path, shared.layout, shared.reserved_by_writers, job))
            for _ in range(self.size):
                self._receive()  # "mapped"
            shared.remove()
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
            self.close()
            raise
        finally:
            shared.remove()

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
        if process.stdout is not None:
            process.stdout.close()


def _read_replies(index, pipe, replies):
    try:
        while True:
            replies.put((index, pickle.load(pipe)))
    except (EOFError, OSError, ValueError, pickle.UnpicklingError):  # ValueError: pipe closed here
        replies.put((index, ("closed",)))


def serve():
    """A worker's main loop: commands from stdin, replies to stdout, until stdin ends."""
    import traceback

    from .construction import prepare_cage
    from .evaluation import evaluate_rows, evaluation_terms, keep_freed_memory_for_reuse, locate_rows

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
            elif command[0] == "map":
                if descriptor is not None:
                    os.close(descriptor)
                arrays = descriptor = None
                path, layout, reserved, job = command[1:]
                arrays, descriptor = attach(path, layout)
                reply("mapped")
            elif command[0] == "rows":
                start, stop, locate_only = command[1:]
                reserve_rows(descriptor, layout, reserved, start, stop)
                outside = _compute(cage, terms, arrays, job, start, stop, locate_only,
                                   evaluate_rows, locate_rows)
                reply("done", start, stop, outside)
        except BaseException:  # reported, then the worker stops
            reply("error", traceback.format_exc())
            return


def _compute(cage, terms, arrays, job, start, stop, locate_only, evaluate, locate):
    """One unit of rows, in chunks; returns the number of outside points in it."""
    from .boundary import OUTSIDE

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
