"""Creases at the character's joints without Blender (issue 35, item 5): harmonic
coordinates as each stored form gives them, against mean value, under the leg poses and
the bent forearm.

The body (``character.body_mesh(detail)``) is deformed by ``points + C @ (posed - rest)``
for coordinates C from: the two-level storage Automatic writes (each vertex its 4 grid
nodes' stored pairs), the field itself (every column: exact storage), the field's
interpolation alone (the cut cells' own pairs left out), and mean value on the
triangulated cage. Per pose: triangles near the joint (centroid within JOINT_RADIUS of
it) with a corner changing by more than CREASE_DEGREES, the 99th percentile and the mean
of the corner changes (degrees).

Usage: joint_creases.py [--detail 0.5] [--resolution N] [--fatten 0.012]
       [--forms stored field interpolated mean-value]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: tests.fixtures
import gencoords  # noqa: E402
from gencoords.base.triangulation import triangulate_quads  # noqa: E402
from gencoords.planning.bind_plan import plan_bind  # noqa: E402
from gencoords.planning.request import BindRequest  # noqa: E402
from gencoords.surfaces.named import HARMONIC, MEAN_VALUE  # noqa: E402
from scripts.common.measures import joint_creases  # noqa: E402
from tests.fixtures import character  # noqa: E402

CREASE_DEGREES = 30
JOINT_RADIUS = 0.15  # metres: the triangles counted around a joint
POSES = {**character.LEG_POSES, "bent forearm": (character.bent_forearm, character.ELBOW)}


def stored_deformer(plan, cage):
    """What the two-level deformer computes: (k, 3) positions from cage positions (n, 3)."""
    nodes = np.einsum("nk,nkc->nc", plan.node_weights.astype(np.float64), cage[plan.node_indices])
    return np.einsum("kc,kcd->kd", plan.slots.astype(np.float64), nodes[plan.indices])


def forms(points, vertices, quads, resolution, wanted):
    """{form name: function(cage (n, 3)) -> positions (k, 3)}."""
    triangles = triangulate_quads(vertices, quads)
    result = {}
    if "stored" in wanted:
        start = time.perf_counter()
        request = BindRequest(HARMONIC, polygons=quads, resolution=resolution)
        steps = plan_bind(points, vertices, triangles, request)
        try:
            while True:
                next(steps)
        except StopIteration as done:
            plan = done.value
        print(f"  stored: {plan.storage_choice} (resolution {plan.resolution}, {time.perf_counter() - start:.0f} s)",
              flush=True)
        result["stored"] = lambda cage, plan=plan: stored_deformer(plan, cage)
        resolution = resolution or plan.resolution
    if {"field", "interpolated"} & set(wanted):
        start = time.perf_counter()
        field = gencoords.harmonic_quad_field(vertices, quads, resolution=resolution or 64)
        print(f"  field: {field} ({time.perf_counter() - start:.0f} s)", flush=True)
        if "field" in wanted:
            exact = field.coordinates(points)
            result["field"] = lambda cage, c=exact: c @ cage
        if "interpolated" in wanted:
            nodes, weights = field.interpolation(points)
            mixed = np.einsum("kc,kcn->kn", weights, field.node_coordinates[nodes])
            result["interpolated"] = lambda cage, c=mixed: c @ cage
    if "mean-value" in wanted:
        mean_value = gencoords.coordinates(points, vertices, triangles, kind=MEAN_VALUE)
        result["mean-value"] = lambda cage, c=mean_value: c @ cage
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--detail", type=float, default=0.5)
    parser.add_argument("--resolution", type=int, default=None, help="the grid's (default: Automatic's)")
    parser.add_argument("--fatten", type=float, default=0.0,
                        help="metres added to every capsule's radius: a body nearer its cage (legs: 0.015 away at 0)")
    parser.add_argument("--forms", nargs="+", default=["stored", "field", "interpolated", "mean-value"])
    args = parser.parse_args()
    capsules = [(part, a, b, radius + args.fatten) for part, a, b, radius in character.character_capsules()]
    points, triangles, _ = character.capsules_mesh(capsules, args.detail)
    vertices, quads = character.character_cage()
    print(f"body {len(points)} vertices, detail {args.detail}, fattened by {args.fatten}", flush=True)
    deformers = forms(points, vertices, quads, args.resolution, args.forms)
    print(f"| pose | form | creased (> {CREASE_DEGREES} deg) | 99th pct | mean | triangles |\n|---|---|---:|---:|---:|---:|")
    for pose, (function, joint) in POSES.items():
        posed = function(vertices)[0]
        for name, deform in deformers.items():
            rest, moved = deform(vertices), deform(posed)
            creased, p99, mean, count = joint_creases(rest, moved, triangles, joint, JOINT_RADIUS, CREASE_DEGREES)
            print(f"| {pose} | {name} | {creased} | {p99:.1f} | {mean:.2f} | {count} |", flush=True)


if __name__ == "__main__":
    main()
