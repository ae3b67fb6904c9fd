"""Quad-native mean value coordinates (core/construction/quad_cage.py) beside mean value on
the split cage: cost, the quadrature's error, and the dependence on each quad's first corner.

On the character's box-modelled quad cage (tests/fixtures/character.py: 196 vertices, 194
quads), points inside its body; one process, BLAS on one thread, the two kinds timed in
turn (CPU time, best of ``--repeats``: steadier on a shared machine), the cost per (point, quad) (mean value's on the 388 triangles
of the split counted per quad too). Then how far the linear-precision correction moved the
integrated coordinates (the quadrature's error), and how far each kind's coordinates move
when every quad lists its corners from the next one.

    .venv/bin/python scripts/benchmarks/bench_quads.py [--points 2000] [--repeats 5]
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
from gencoords.construction import quad_cage  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402
from tests.fixtures.character import body_points, character_cage  # noqa: E402


def _best_times(calls, repeats):
    best = [np.inf] * len(calls)
    for _ in range(repeats):
        for i, call in enumerate(calls):
            start = time.process_time()
            call()
            best[i] = min(best[i], time.process_time() - start)
    return best


def _correction(points, vertices, quads):
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    origin, size = 0.5 * (low + high), np.linalg.norm(high - low)
    local, inside = (vertices - origin) / size, (points - origin) / size
    weights, _ = quad_cage.integrated_weights(inside, local, quads)
    _, change = quad_cage.restore_linear_precision(weights / weights.sum(axis=1, keepdims=True), local, inside)
    return change.max()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    arguments = parser.parse_args()
    vertices, quads = character_cage()
    triangles = gencoords.cages.triangulate_quads(vertices, quads)
    points = body_points(arguments.points, seed=0)
    mean_value = lambda faces: gencoords.coordinates(points, vertices, faces, kind=MEAN_VALUE, workers=1)  # noqa: E731
    native = lambda faces: gencoords.mean_value_quad_coordinates(points, vertices, faces, workers=1)  # noqa: E731
    split, quad = _best_times([lambda: mean_value(triangles), lambda: native(quads)], arguments.repeats)
    pairs = len(points) * len(quads)
    print(f"{len(vertices)}-vertex cage, {len(quads)} quads, {len(points)} points")
    print(f"mean value, split:  {split:.3f} s, {split / pairs * 1e9:.0f} ns per (point, quad)")
    print(f"mean value, quads:  {quad:.3f} s, {quad / pairs * 1e9:.0f} ns per (point, quad), "
          f"{quad / split:.2f}x the split's")
    print(f"linear-precision correction (the quadrature's error): {_correction(points, vertices, quads):.1e}")
    rolled = np.roll(quads, 1, axis=1)
    moved_split = np.abs(mean_value(gencoords.cages.triangulate_quads(vertices, rolled)) - mean_value(triangles))
    moved_quads = np.abs(native(rolled) - native(quads))
    print(f"quads' corners listed from the next one, largest coordinate change: split {moved_split.max():.1e}, "
          f"quads {moved_quads.max():.1e}")


if __name__ == "__main__":
    main()
