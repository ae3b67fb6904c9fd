"""What an adaptive grid could save a Harmonic Bind at best (issue 35, item 1), against
Mesh Deform p5 in the same run.

An adaptive (octree) grid keeps the uniform grid's finest cells near the cage, where the
points and the cut cells are, and coarsens away from it. On each fixture
(``tests/fixtures/artist_cages.py``) at Automatic's resolution this script measures:

  nodes      the uniform grid's kept nodes, and the share of them at least 4 cells (in
             the cube metric) from every cell the cage cuts.
  octree     a generous estimate of a graded octree's nodes: a node d cells from the cage
             sits in cells of side s = the largest power of 2 not above max(1, d / 2),
             so it counts 1 / s^3 (hanging nodes and the octree's bookkeeping free).
  node parts the Bind's seconds that grow with the grid's nodes (the grid, its boundary
             values, the solve, the nodes placed exactly, the two-level layout), of the
             core's whole Bind (``bind_split.py``'s timers, wall clock).
  bound      the add-on's Bind (the installed zip through ``bpy.ops``) with the node
             parts scaled by octree / nodes and every other part unchanged, of Mesh
             Deform p5's Bind: no adaptive grid with the same finest cells binds faster.
  32 cells   the add-on's Bind at Resolution 32 (Mesh Deform p5's cells), of p5's: a
             coarser uniform grid, for the trend.

    .venv/bin/python scripts/benchmarks/adaptive_bound.py [--fixtures hand cup] [--detail 0.6]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.benchmarks import bench_fixtures, bind_split  # noqa: E402 (prepares the session, imports bpy)
from scripts.common import session  # noqa: E402
from tests.fixtures import artist_cages  # noqa: E402
from gencoords.harmonic import grid_field  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402

NODE_PARTS = ("grid + inside nodes", "boundary values", "solve", "nodes placed exactly", "two levels: layout")
FAR_CELLS = 4


def grown(mask):
    """``mask`` ((x, y, z) bool) grown by one cell in the cube metric: separably, one cell
    along each axis in turn."""
    for axis in range(3):
        moved = np.moveaxis(mask, axis, 0)
        padded = np.pad(moved, [(1, 1)] + [(0, 0)] * 2)
        mask = np.moveaxis(padded[:-2] | padded[1:-1] | padded[2:], 0, axis)
    return mask


def cell_distances(cut):
    """Each cell's distance in cells (cube metric) from the nearest cut cell ((x, y, z)
    bool): (x, y, z) int, found by growing the cut cells one layer at a time."""
    far = np.iinfo(np.int32).max
    distance = np.where(cut, 0, far).astype(np.int32)
    reached, layer = cut.copy(), 0
    while reached.any() and not reached.all():
        layer += 1
        now = grown(reached)
        distance[now & ~reached] = layer
        reached = now
    return distance


def node_distances(field):
    """Each kept node's distance in cells from the cage's cut cells: the least over the
    (up to 8) cells it is a corner of: (N,) int."""
    cells = cell_distances(field._surface)
    padded = np.pad(cells, 1, constant_values=np.iinfo(np.int32).max)
    indices = field.node_indices  # node (i, j, k) is a corner of cells i-1..i along each axis
    least = np.full(len(indices), np.iinfo(np.int32).max, dtype=np.int64)
    for corner in np.ndindex(2, 2, 2):
        least = np.minimum(least, padded[tuple((indices + np.array(corner)).T)])
    return least


def octree_nodes(distances):
    """The graded octree's estimated node count (the module's docstring)."""
    side = 2.0 ** np.floor(np.log2(np.maximum(1.0, distances / 2.0)))
    return float((1.0 / side ** 3).sum())


def core_split(scene, timers):
    """The core's Bind of ``scene`` (wall seconds, ``bind_split``'s timers installed):
    (total, node parts, the harmonic field it solved)."""
    fields = []
    solved = grid_field._solved_field
    grid_field._solved_field = lambda *args, **kwargs: fields.append(solved(*args, **kwargs)) or fields[-1]
    try:
        timers.own = {}
        start = time.perf_counter()
        bind_split.bind(scene)
        total = time.perf_counter() - start
    finally:
        grid_field._solved_field = solved
    return total, sum(timers.own.get(label, 0.0) for label in NODE_PARTS), fields[-1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=list(bench_fixtures.FIXTURES))
    parser.add_argument("--detail", type=float, default=0.6)
    args = parser.parse_args()
    print("\n".join(session.report_header("What an adaptive grid could save a Harmonic Bind")), flush=True)
    session.install_extension()
    timers = bind_split.Timers()
    bind_split.install(timers)
    rows = ["| fixture | resolution | nodes | >= 4 cells from the cage | octree (est.) | node parts "
            "| Bind / MD p5 | bound / MD p5 | 32 cells / MD p5 |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name in args.fixtures:
        scene = artist_cages.fixture(name, args.detail)
        core_split(scene, timers)  # warm: imports, caches
        core, node_seconds, field = core_split(scene, timers)
        distances = node_distances(field)
        octree = octree_nodes(distances)
        md5 = bench_fixtures.measure(scene, ("md", 5))["bind"]
        addon = bench_fixtures.measure(scene, ("gencoords", HARMONIC))["bind"]
        coarse = bench_fixtures.measure(scene, ("gencoords", f"{HARMONIC}:32"))["bind"]
        bound = addon - node_seconds * (1.0 - octree / len(distances))
        rows.append(f"| {name} | {field.resolution} | {len(distances)} | {np.mean(distances >= FAR_CELLS):.0%} "
                    f"| {octree:.0f} | {node_seconds / core:.0%} | {addon / md5:.2f}x | {bound / md5:.2f}x "
                    f"| {coarse / md5:.2f}x |")
        print(rows[-1], flush=True)
    print("\n" + "\n".join(rows))


if __name__ == "__main__":
    main()
