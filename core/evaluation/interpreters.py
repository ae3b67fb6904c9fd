"""Where worker processes run: the cores this process may use (:func:`available_cores`)
and the Python interpreter to start (:func:`python_executable`: the venv's, or the one
Blender bundles, never Blender itself).
"""

import os
import sys

from ..base.errors import WorkerError

__all__ = ["available_cores", "python_executable", "interpreter_candidates"]


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
