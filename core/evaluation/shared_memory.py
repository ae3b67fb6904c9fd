"""Shared memory between the parent and its worker processes (:mod:`.parallel`): one
mapping per call holding its points, locations and result, never pickled, and nothing
left behind on any OS after success, failure, a kill or a crash:

- Windows: memory backed by the paging file under a random tag name,
  ``gencoords-<parent pid>-<random>`` (``mmap.mmap(-1, size, tagname=...)``), never a
  file: Windows refuses to remove a file that any process holds, and the caller may
  keep the result (a view of the mapping) until it exits. The OS frees the memory when
  the last process holding it closes it or ends.
- Linux and macOS: a memory-mapped file ``gencoords-<parent pid>-<random>.shared`` (in
  ``/dev/shm`` where there is one, else the temporary folder), whose name goes as soon
  as the workers have mapped it (the mappings stay valid).

A file a crash left behind (its owner dead; on Windows, one an older version made that
no process holds) is swept when the next pool starts (:func:`sweep_stale_files`).
"""

import glob
import math
import mmap
import os
import secrets
import shutil
import tempfile
import weakref

import numpy as np

from ..base.errors import WorkerError

__all__ = ["SharedArrays", "shared_layout", "attach", "reserve_rows", "shared_files", "sweep_stale_files"]

_PREFIX = "gencoords-"
_SUFFIX = ".shared"
_RAM_FOLDER = "/dev/shm"
# Read when used, not at import: the tests simulate Windows on Linux by setting it.
_WINDOWS = os.name == "nt"
_ZEROS = 1 << 22  # bytes written at a time where space is reserved by writing zeros


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
