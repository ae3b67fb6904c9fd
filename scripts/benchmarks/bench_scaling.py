"""Multi-core scaling of the Bind's computing, core only (no Blender): the harmonic solve
(``gencoords.harmonic_field``) at 64, 96 and 128 cells and mean value coordinates of 200k
points, on the artist's character cage, with 1 to 16 worker processes. Meant for a
machine with many cores (this project's own machines have 2).

    python scripts/benchmarks/bench_scaling.py [--workers 1 2 4 8 16]
"""

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"  # processes, not BLAS threads, are what is measured

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
import numpy as np  # noqa: E402

import gencoords  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402
from tests.fixtures.character import body_points, character_cage  # noqa: E402


def timed(call):
    start = time.perf_counter()
    result = call()
    return time.perf_counter() - start, result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    parser.add_argument("--resolutions", type=int, nargs="+", default=[64, 96, 128])
    parser.add_argument("--points", type=int, default=200_000)
    args = parser.parse_args()
    vertices, quads = character_cage()
    faces = gencoords.cages.triangulate_quads(vertices, quads)
    print(f"{os.cpu_count()} cores, numpy {np.__version__}; character cage, {len(vertices)} vertices")
    for resolution in args.resolutions:
        alone = None
        for workers in args.workers:
            seconds, field = timed(lambda: gencoords.harmonic_field(vertices, faces, resolution=resolution,
                                                                    workers=workers))
            alone = alone or seconds
            print(f"harmonic {resolution} cells ({len(field.node_positions)} nodes), {workers:2d} workers: "
                  f"{seconds:6.2f} s, {alone / seconds:4.1f}x", flush=True)
    points = body_points(args.points)
    with gencoords.Cage(vertices, faces) as cage:
        alone = None
        for workers in args.workers:
            seconds, _ = timed(lambda: cage.coordinates(points, kind=MEAN_VALUE, outside="project",
                                                        workers=workers))
            alone = alone or seconds
            print(f"mean value, {len(points)} points, {workers:2d} workers: {seconds:6.2f} s, "
                  f"{alone / seconds:4.1f}x", flush=True)


if __name__ == "__main__":
    main()
