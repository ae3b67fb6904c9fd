"""Worker processes: the points of one call split over fresh Python interpreters.

Threads do not help: the construction is many small numpy calls, each holding the
interpreter lock. Processes do. Each worker is a Python interpreter (the venv's, or the
one Blender bundles, never Blender itself: :mod:`.interpreters`) running only this
package and numpy: the package is imported by its folder, so a parent package that
needs bpy is never imported, and no ``multiprocessing`` start method re-runs the
caller's script.

Data crosses in shared memory, never pickled (:mod:`.shared_memory`: nothing is left
behind on any OS). The workers release the mapping at the end of every call, so a kept
pool holds no memory between calls. Commands and replies are small pickles on the
workers' stdin and stdout.

Test seam: where the environment variable ``GENCOORDS_WORKER_PRELUDE`` names a Python
file, every worker runs it before serving (the tests simulate Windows' and macOS'
semantics in the workers with it); nothing else reads it.

A worker keeps its prepared cage between calls (a :class:`gencoords.Cage` owns its pool).
It computes whole chunks of :func:`gencoords.evaluation.rows.chunk_size` points, the same chunks
as one process, so the result is bitwise the same as ``workers=1``.
"""

import collections
import os
import pickle
import queue
import subprocess
import sys
import threading
import warnings
import weakref

import numpy as np

from ..base.errors import WorkerError, WorkerWarning
from . import interpreters, shared_memory
from .shared_memory import attach, reserve_rows, sweep_stale_files

__all__ = ["dispatch_units", "WorkerPool", "computed_here_instead", "serve"]

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
# subprocess.CREATE_NO_WINDOW (defined on Windows only): no console window per worker
# (Blender has none to share when started from its icon), no output in the artist's.
_CREATE_NO_WINDOW = 0x08000000
_STDERR_KEPT = 40  # lines of a worker's stderr quoted when it dies
# BLAS threads in every worker would oversubscribe the cores the workers already use.
_SINGLE_THREADED = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                           "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")}


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
        creation_flags = _CREATE_NO_WINDOW if shared_memory._WINDOWS else 0  # POSIX Popen refuses any
        # The core's own folder (``core/`` in the repository and the extension,
        # ``gencoords/`` when pip-installed), two levels up from evaluation/parallel.py.
        package_folder = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        command = [interpreters.python_executable(), "-c", _BOOT, os.path.dirname(package_folder),
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
