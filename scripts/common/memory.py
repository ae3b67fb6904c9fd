"""Memory and file-size figures the benchmarks measure the same way for every method:
peak and kept resident memory over a block (the process and its worker processes,
sampled from /proc by a separate process) and the size of an uncompressed .blend.
Import after ``session.prepare()``."""

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import bpy
from gencoords.harmonic.memory import release_freed_memory

from . import session

# A tiny watcher run in its own process: samples our resident memory, with that of our
# child processes (the core's workers, which Bind starts) but not its own, every
# millisecond until told to stop on stdin, then prints the peak in bytes.
_WATCHER = r"""
import os, select, sys
page = os.sysconf("SC_PAGE_SIZE")
parent, me = sys.argv[1], str(os.getpid())
def statm(pid):
    try:
        with open("/proc/%s/statm" % pid) as f:
            return int(f.read().split()[1]) * page
    except OSError:  # a worker that just ended
        return 0
def rss():
    try:
        with open("/proc/%s/task/%s/children" % (parent, parent)) as f:
            children = [pid for pid in f.read().split() if pid != me]
    except OSError:
        children = []
    return statm(parent) + sum(statm(pid) for pid in children)
peak = rss()
print("ready", flush=True)
while not select.select([sys.stdin], [], [], 0.001)[0]:
    peak = max(peak, rss())
print(max(peak, rss()), flush=True)
"""


def resident_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


class PeakMemory:
    """Context manager: ``peak`` and ``kept`` resident-memory growth (bytes) over a block."""

    def __enter__(self):
        release_freed_memory()  # glibc keeps freed memory for reuse: trimmed, RSS deltas mean something
        self._watcher = subprocess.Popen(
            [sys.executable, "-c", _WATCHER, str(os.getpid())],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self._watcher.stdout.readline()  # wait until it samples
        self.before = resident_bytes()
        return self

    def __exit__(self, *exc):
        release_freed_memory()  # "kept" is live data, not free memory malloc holds for reuse
        after = resident_bytes()
        out, _ = self._watcher.communicate("stop\n", timeout=30)
        self.peak = max(int(out), after) - self.before
        self.kept = after - self.before
        return False


def blend_size(tag):
    """Bytes of an uncompressed .blend of the current scene (written, measured, deleted)."""
    with tempfile.TemporaryDirectory(prefix="gencoords-bench-") as folder:
        path = Path(folder) / f"{tag}.blend"
        with session.quiet():
            bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True, compress=False)
        return path.stat().st_size
