"""Quad-native mean value coordinates (core/construction/quad_cage.py) beside mean value on
the split cage: cost, the quadrature's error, and the dependence on each quad's first corner.

On the character's box-modelled quad cage (tests/fixtures/character.py: 196 vertices, 194
quads), points inside its body; one process, BLAS on one thread, the two kinds timed in
turn (CPU time, best of ``--repeats``: steadier on a shared machine), the cost per (point, quad) (mean value's on the 388 triangles
of the split counted per quad too). Then how far the linear-precision correction moved the
integrated coordinates (the quadrature's error), and how far each kind's coordinates move
when every quad lists its corners from the next one. Last, the same timing on the artist
fixtures whose cages have quads (tests/fixtures/artist_cages.py: hand, quadruped, cape,
character; the cup's cage is triangles), ``--points`` of each mesh's vertices taken evenly
along its vertex order, Quad Mean Value's time as a ratio of mean value's on the split.

    .venv/bin/python scripts/benchmarks/bench_quads.py [--points 2000] [--repeats 5]
        [--fixtures hand quadruped cup cape character] [--no-fixtures]
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
from tests.fixtures.artist_cages import fixture  # noqa: E402
from tests.fixtures.character import body_points, character_cage  # noqa: E402


# The harmonic issue's fixtures (docs/BENCHMARKS.md), the cup's cage of triangles included.
_FIXTURES = ("hand", "quadruped", "cup", "cape", "character")


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


def _timed(points, vertices, quads, repeats):
    """CPU seconds of mean value on the split cage and of Quad Mean Value, one process."""
    triangles = gencoords.cages.triangulate_quads(vertices, quads)
    return _best_times([lambda: gencoords.coordinates(points, vertices, triangles, kind=MEAN_VALUE, workers=1),
                        lambda: gencoords.mean_value_quad_coordinates(points, vertices, quads, workers=1)], repeats)


def _fixtures(names, count, repeats):
    """The table over the artist fixtures with quads in their cages."""
    print(f"\nartist fixtures, {count} mesh vertices each: mean value on the split, Quad Mean Value, ratio")
    for name in names:
        case = fixture(name)
        if case.cage_faces.shape[1] != 4:
            print(f"  {name:10s} cage of {len(case.cage_faces)} triangles: no quads")
            continue
        points = case.mesh_vertices[np.linspace(0, len(case.mesh_vertices) - 1, count).astype(int)]
        split, quad = _timed(points, case.cage_vertices, case.cage_faces, repeats)
        print(f"  {name:10s} {len(case.cage_vertices):4d} vertices, {len(case.cage_faces):4d} quads: "
              f"{split:.3f} s, {quad:.3f} s, {quad / split:.2f}x")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-fixtures", action="store_true", help="the character's figures only")
    parser.add_argument("--fixtures", nargs="+", choices=_FIXTURES, default=list(_FIXTURES),
                        help="the artist fixtures to time (default: all five)")
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
    if not arguments.no_fixtures:
        _fixtures(arguments.fixtures, arguments.points, arguments.repeats)


if __name__ == "__main__":
    main()
