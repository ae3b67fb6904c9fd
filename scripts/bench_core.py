"""Speed and memory of core.coordinates, beside an independent C++ implementation.

Cost is reported per (point x facet) on a 642-vertex icosphere cage (1280 triangles),
as the issue quotes the C++ figures measured on this machine (single-threaded), and
peak extra memory for a large batch (numpy reports its allocations to tracemalloc).

    .venv/bin/python scripts/bench_core.py [--points 4000] [--memory-points 200000]
"""

import argparse
import os
import sys
import time
import tracemalloc

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import core  # noqa: E402
import core.barycentric  # noqa: E402
from core.shapes import icosphere  # noqa: E402

CPP_NS_PER_POINT_FACET = {"wachspress": 39.0, "discrete_harmonic": 78.0, "mean_value": 231.0}


def interior_points(count, radius, seed=0):
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return directions * radius * rng.uniform(0.0, 1.0, size=(count, 1)) ** (1.0 / 3.0)


def best_time(function, repeats):
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4000)
    parser.add_argument("--memory-points", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    vertices, faces = icosphere(4 - 1)  # 642 vertices
    points = interior_points(args.points, 0.95)
    pairs = len(points) * len(faces)
    print(f"$ {' '.join([os.path.basename(sys.executable)] + sys.argv)}")
    print(f"cage: icosphere, {len(vertices)} vertices, {len(faces)} triangles; {len(points)} interior "
          f"points; {os.cpu_count()} cores\n")
    print("| kind | C++ 1 thread ns | ours 1 thread ns | ours 2 threads ns | C++ / ours (2 threads) "
          "| max linear precision error |")
    print("|---|---|---|---|---|---|")
    workers = core.barycentric._WORKERS
    for kind in core.KINDS:
        timings = {}
        core.coordinates(points[:200], vertices, faces, kind=kind)  # warm up
        for threads in (1, workers):
            core.barycentric._WORKERS = threads
            timings[threads] = best_time(lambda: core.coordinates(points, vertices, faces, kind=kind),
                                         args.repeats) / pairs * 1e9
        core.barycentric._WORKERS = workers
        error = np.abs(core.coordinates(points, vertices, faces, kind=kind) @ vertices - points).max()
        reference = CPP_NS_PER_POINT_FACET.get(kind)
        ratio = f"{reference / timings[workers]:.2f}" if reference else "-"
        print(f"| {kind} | {reference or '-'} | {timings[1]:.1f} | {timings[workers]:.1f} | {ratio} "
              f"| {error:.1e} |")

    many = interior_points(args.memory_points, 0.95, seed=1)
    tracemalloc.start()
    baseline = tracemalloc.get_traced_memory()[0]
    result = core.coordinates(many, vertices, faces, kind="mean_value")
    peak = tracemalloc.get_traced_memory()[1] - baseline
    tracemalloc.stop()
    print(f"\npeak memory for {len(many)} points (mean value): {peak / 2**20:.0f} MB, of which the "
          f"(k, n) result is {result.nbytes / 2**20:.0f} MB: working memory "
          f"{(peak - result.nbytes) / 2**20:.0f} MB (budget 256 MB)")


if __name__ == "__main__":
    main()
