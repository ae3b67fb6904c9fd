"""What a harmonic solve needs in memory, before it runs, and the finest grid that fits.

A grid of ``resolution`` cells keeps the nodes of the cells that hold the cage's inside
(about its volume over a cell's, and a shell of about 4 nodes per cell of its area); each
kept node costs about ``NODE_BYTES`` (its grid bookkeeping and the solver's levels) and
each (node, cage vertex) pair about ``PAIR_BYTES`` (the right-hand side, the solution and
the node coordinates, float64: every kept node's, though the field keeps dense rows only
for the nodes it solves, so a thin-walled cage's estimate errs higher still: the cup at 48
cells 663 MB against 52), the whole grid ``GRID_BYTES`` a node. Measured peaks
(tracemalloc, the solve in one process): a cube at 48 and 96 cells 97 and 379 MB against
105 and 770 estimated, a 162-vertex icosphere at 48 cells 270 against 360: an estimate
that errs high.
"""

import ctypes
import functools
import os
import sys

import numpy as np

from ..base.grid import fit_grid

__all__ = ["field_bytes", "fitting_resolution", "available_memory", "release_freed_memory", "NODE_BYTES", "PAIR_BYTES",
           "GRID_BYTES"]

NODE_BYTES, PAIR_BYTES, GRID_BYTES = 500, 24, 8
# Where the system does not say what memory is free: what a solve may take.
UNKNOWN_AVAILABLE = 4 << 30


def _volume_and_area(vertices, triangles):
    a, b, c = (vertices[triangles[:, corner]] for corner in range(3))
    volume = abs(float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0)
    area = float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()) / 2.0
    return volume, area


def field_bytes(vertices, triangles, resolution):
    """Estimated peak bytes of ``gencoords.harmonic_field`` on this cage: int.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
    resolution : int

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.memory import field_bytes
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, triangles = icosphere(2)
    >>> round(field_bytes(vertices, triangles, 48) / 1e6), round(field_bytes(vertices, triangles, 512) / 1e9)
    (371, 313)
    """
    vertices, triangles = np.asarray(vertices, dtype=np.float64), np.asarray(triangles)
    volume, area = _volume_and_area(vertices, triangles)
    return _estimate(vertices, volume, area, resolution)


def _estimate(vertices, volume, area, resolution):
    grid = fit_grid(vertices, resolution)
    cell = grid.spacing
    grid_nodes = float(np.prod(grid.shape))
    kept = min(grid_nodes, volume / cell ** 3 + 4.0 * area / cell ** 2)
    return int(NODE_BYTES * kept + PAIR_BYTES * kept * len(vertices) + GRID_BYTES * grid_nodes)


def fitting_resolution(vertices, triangles, resolution, budget):
    """The finest resolution, at most ``resolution``, whose :func:`field_bytes` fit in
    ``budget`` bytes: int, or 0 where not even 2 cells do.

    Examples
    --------
    >>> from gencoords.harmonic.memory import fitting_resolution
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, triangles = icosphere(2)
    >>> fitting_resolution(vertices, triangles, 512, 2 << 30), fitting_resolution(vertices, triangles, 32, 2 << 30)
    (91, 32)
    """
    vertices, triangles = np.asarray(vertices, dtype=np.float64), np.asarray(triangles)
    volume, area = _volume_and_area(vertices, triangles)
    low, high = 1, int(resolution) + 1  # fits at low (or none), not at high
    if _estimate(vertices, volume, area, resolution) <= budget:
        return int(resolution)
    while high - low > 1:
        middle = (low + high) // 2
        if _estimate(vertices, volume, area, middle) <= budget:
            low = middle
        else:
            high = middle
    return low if low >= 2 and _estimate(vertices, volume, area, low) <= budget else 0


def available_memory():
    """Bytes of memory the system says are free for a new allocation (Linux's
    MemAvailable, else half the physical memory), or UNKNOWN_AVAILABLE: int.

    Examples
    --------
    >>> from gencoords.harmonic.memory import available_memory
    >>> available_memory() > 0
    True
    """
    try:
        with open("/proc/meminfo") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (AttributeError, ValueError, OSError):
        return UNKNOWN_AVAILABLE


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another system or C library: nothing to hand
    back this way). Looked up in the process's own symbols on first use."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        trim = getattr(ctypes.CDLL(None), "malloc_trim", None)
    except OSError:
        return None
    if trim is not None:
        trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def release_freed_memory():
    """Hand the pages of memory already freed back to the system (glibc), in every
    allocator arena; elsewhere nothing. A thread allocates in an arena of its own, so
    what one step freed in one arena is not reused by the next step in the other: the
    cup's Bind (its field solved in a thread) held 77 MB resident at its peak, 68 with
    this called around the thread (63 with one arena for every thread).

    Examples
    --------
    >>> from gencoords.harmonic.memory import release_freed_memory
    >>> release_freed_memory()
    """
    trim = _malloc_trim()
    if trim is not None:
        trim(0)
