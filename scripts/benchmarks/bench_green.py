"""Green coordinates (core/green.py) beside mean value: cost and shape preservation.

Cost per (point x face), one process, on a 642-vertex icosphere cage (1280 triangles),
best of three, beside ``gencoords.coordinates(kind="mean_value", workers=1)`` on the same
points; then the issue's sanity figure: the vertices of a sphere's triangulation
(radius 0.6, 642 vertices) inside a 42-vertex icosphere cage stretched 1.6x along x, the
mean and worst change of its triangles' angles with each.

    .venv/bin/python scripts/benchmarks/bench_green.py [--points 4000]
"""

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))  # the repository
import gencoords  # noqa: E402
from gencoords import green_coordinates, green_deform  # noqa: E402
from gencoords.cages.shapes import icosphere  # noqa: E402
from gencoords.construction.green import GREEN  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402
from scripts.common.measures import triangle_angles  # noqa: E402


def best_time(run, repeats=3):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=4000)
    args = parser.parse_args()

    vertices, faces = icosphere(3)
    rng = np.random.default_rng(1)
    points = rng.normal(size=(args.points, 3))
    points *= (rng.uniform(0.0, 0.9, args.points) ** (1 / 3) / np.linalg.norm(points, axis=1))[:, None]
    pairs = len(points) * len(faces)
    green = best_time(lambda: green_coordinates(points, vertices, faces))
    mean_value = best_time(lambda: gencoords.coordinates(points, vertices, faces, kind=MEAN_VALUE, workers=1))
    print(f"{len(points)} points, {len(vertices)}-vertex cage ({len(faces)} faces), one process:")
    print(f"  green      {green:.3f} s  {green / pairs * 1e9:6.1f} ns per (point x face)")
    print(f"  mean value {mean_value:.3f} s  {mean_value / pairs * 1e9:6.1f} ns per (point x face)"
          f"  (green / mean value: {green / mean_value:.2f})")

    cage_vertices, cage_faces = icosphere(1)
    mesh_vertices, mesh_faces = icosphere(3, radius=0.6)
    stretched = cage_vertices * np.array([1.6, 1.0, 1.0])
    rest = triangle_angles(mesh_vertices, mesh_faces)
    phi, psi = green_coordinates(mesh_vertices, cage_vertices, cage_faces)
    by_green = green_deform(phi, psi, cage_vertices, stretched, cage_faces)
    by_mean_value = gencoords.coordinates(mesh_vertices, cage_vertices, cage_faces) @ stretched
    print("angle change under a 1.6x stretch along x, mean / worst (degrees):")
    for name, moved in ((GREEN, by_green), ("mean value", by_mean_value)):
        change = np.abs(triangle_angles(moved, mesh_faces) - rest)
        print(f"  {name:10s} {change.mean():.2f} / {change.max():.1f}")


if __name__ == "__main__":
    main()
