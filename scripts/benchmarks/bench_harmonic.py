"""Harmonic coordinates (core/harmonic): cost and quality against the grid's resolution.

On the artist's character (tests/fixtures/character.py: a box-modelled, non-convex T-pose
quad cage, 196 vertices, arms 0.15 thick across 1.9) and points inside its body, for each
resolution: the bind's time (one process) and peak memory, the unknowns, the solver's
iterations and mean residual reduction per iteration, negative coordinates, linear
precision (``|sum_j w_j R_j - x|`` per cage diagonal) as solved and after
``skinning.skinning.reproduce_points`` on the 32 largest, locality, the weights above 1e-5 per
point, and the bend: the body mesh's left forearm cage turned 60 degrees
(``character.bent_forearm``), the left arm's triangle angle changes (mean and 99th
percentile, degrees) with the coordinates as solved, every one kept (what the resolution
does to the coordinates themselves; bench_local.py measures them as the Bind stores them,
against Mesh Deform). Timings are noisy on a shared machine; Blender's Mesh Deform is not
in this script (it needs Blender: bench_blender.py).

    .venv/bin/python scripts/benchmarks/bench_harmonic.py [--resolutions 32,48,64,96] [--points 20000]
"""

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))  # the repository
import gencoords  # noqa: E402
from tests.fixtures.character import (bent_forearm, body_mesh, body_points, cage_limb_vertices,  # noqa: E402
                                      character_cage, limb_labels)
from scripts.common.measures import angle_changes  # noqa: E402
from gencoords.skinning.skinning import reproduce_points, top_k  # noqa: E402


def measure(vertices, triangles, points, resolution, workers, body):
    diagonal = np.linalg.norm(np.ptp(vertices, axis=0))
    tracemalloc.start()
    start = time.perf_counter()
    field = gencoords.harmonic_field(vertices, triangles, resolution=resolution, workers=1)
    bind = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    spread = None
    if workers > 1:
        start = time.perf_counter()
        gencoords.harmonic_field(vertices, triangles, resolution=resolution, workers=workers)
        spread = time.perf_counter() - start
    start = time.perf_counter()
    coordinates = field.coordinates(points)
    lookup = time.perf_counter() - start
    history = field.convergence
    reduction = (history[-1] / history[0]) ** (1.0 / max(1, len(history) - 1))
    error = np.linalg.norm(coordinates @ vertices - points, axis=1).max() / diagonal
    indices, weights = top_k(coordinates, 32)
    corrected, residual = reproduce_points(indices, weights, vertices, points)
    hand = cage_limb_vertices(vertices, "left_arm")
    elsewhere = np.isin(limb_labels(points), ["right_arm", "right_leg", "left_leg"])
    return dict(resolution=resolution, bind=bind, peak=peak / 2**20, unknowns=int(field.node_inside.sum()),
                nodes=len(field.node_indices), iterations=len(history) - 1, reduction=reduction,
                lookup=lookup, negative=int((coordinates < 0.0).sum()), minimum=float(coordinates.min()),
                precision=error, corrected=float(residual.max() / diagonal),
                corrected_negative=int((corrected < 0.0).sum()),
                locality=float(coordinates[np.ix_(elsewhere, hand)].max()),
                above=float((coordinates > 1e-5).sum(axis=1).mean()), spacing=field.spacing, spread=spread,
                bend=bend(field, vertices, body))


def bend(field, vertices, body):
    """Mean and 99th percentile of the left arm's triangle angle changes (degrees) when
    the forearm's cage turns 60 degrees, ``body`` (``body_mesh()``) deformed by
    ``field``'s coordinates."""
    mesh, triangles, labels = body
    arm = triangles[(labels[triangles] == "left_arm").all(axis=1)]
    moved = mesh + field.coordinates(mesh) @ (bent_forearm(vertices)[0] - vertices)
    change = angle_changes(mesh, moved, arm)
    return float(change.mean()), float(np.percentile(change, 99))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolutions", default="32,48,64,96")
    parser.add_argument("--points", type=int, default=20000)
    parser.add_argument("--workers", type=int, default=0, help="also bind in this many processes (0: the cores)")
    arguments = parser.parse_args()
    vertices, quads = character_cage()
    triangles = gencoords.cages.triangulate_quads(vertices, quads)
    points = body_points(arguments.points)
    body = body_mesh()  # the bend's mesh, once for every resolution
    workers = arguments.workers or gencoords.evaluation.interpreters.available_cores()
    print(f"character cage: {len(vertices)} vertices, {len(triangles)} triangles; {len(points)} points inside; "
          f"box {np.ptp(vertices, axis=0).tolist()}, diagonal {np.linalg.norm(np.ptp(vertices, axis=0)):.2f}")
    print(f"bind s: one process; w={workers}: {workers} worker processes (started per bind)")
    print(f"res  cell   bind s  w={workers} s  peak MB  unknowns  nodes   its  red/it   lookup s  neg  lin.prec/diag  "
          "after reproduce(32)  other-limb max  >1e-5/pt  bend mean/p99")
    for resolution in (int(text) for text in arguments.resolutions.split(",")):
        row = measure(vertices, triangles, points, resolution, workers, body)
        spread = f"{row['spread']:6.2f}" if row["spread"] is not None else "     -"
        print(f"{row['resolution']:3d}  {row['spacing']:.3f}  {row['bind']:7.2f}  {spread}  {row['peak']:7.0f}  "
              f"{row['unknowns']:8d}  {row['nodes']:6d}  {row['iterations']:3d}  {row['reduction']:.3f}   "
              f"{row['lookup']:7.2f}  {row['negative']:3d}  {row['precision']:.2e}       "
              f"{row['corrected']:.1e} ({row['corrected_negative']} neg)      {row['locality']:.1e}        "
              f"{row['above']:.0f}       {row['bend'][0]:.2f} / {row['bend'][1]:.1f}")


if __name__ == "__main__":
    main()
