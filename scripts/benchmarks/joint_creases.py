"""Creases at the character's joints without Blender (issue 35, item 5): harmonic
coordinates as each stored form gives them, against mean value, under the leg poses and
the bent forearm.

The body (``character.body_mesh(detail)``) is deformed by ``points + C @ (posed - rest)``
for coordinates C from: the two-level storage Automatic writes (each vertex its 8 grid
nodes' stored pairs), the field itself (every column: exact storage), the field with
the cut cells' points keeping every entry before their reweighting (not their 32
largest), the field's interpolation alone (the cut cells' own pairs left out: points
near the cage placed only to within a fraction of a cell), and mean value on the
triangulated cage. Per pose: triangles near the joint (centroid within JOINT_RADIUS of
it) with a corner changing by more than CREASE_DEGREES, the 99th percentile and the mean
of the corner changes (degrees); with ``--where``, where the worst 1 % of those
triangles lie: their centroids' mean offset from the joint and the share in cut cells.

Usage: joint_creases.py [--detail 0.5] [--resolution N] [--fatten 0.012] [--triangulated]
       [--forms stored field every-entry interpolated mean-value] [--poses "bent forearm"] [--where]
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
from scripts.common.measures import angle_changes, joint_creases  # noqa: E402
from tests.fixtures import character  # noqa: E402

CREASE_DEGREES = 30
JOINT_RADIUS = 0.15  # metres: the triangles counted around a joint
POSES = {**character.LEG_POSES, "bent forearm": (character.bent_forearm, character.ELBOW)}


def stored_deformer(plan, cage):
    """What the two-level deformer computes: (k, 3) positions from cage positions (n, 3)."""
    nodes = np.einsum("nk,nkc->nc", plan.node_weights.astype(np.float64), cage[plan.node_indices])
    return np.einsum("kc,kcd->kd", plan.slots.astype(np.float64), nodes[plan.indices])


def every_entry_coordinates(field, points):
    """The field's coordinates of ``points`` ((k, 3)) with the cut cells' points
    reweighted from every entry of their interpolation (``cut_pairs`` with count n, not
    CUT_SUPPORT): (k, n)."""
    nodes, weights = field.interpolation(points)
    cut = field.cut(nodes)
    result = np.einsum("kc,kcn->kn", weights, field.node_rows(nodes.ravel()).reshape(*nodes.shape, -1))
    columns, values = field.cut_pairs(points[cut], nodes[cut], weights[cut], count=len(field.vertices))
    result[cut] = 0.0
    result[np.flatnonzero(cut)[:, None], columns] = values
    return result


def forms(points, vertices, quads, resolution, wanted, triangulated=False):
    """{form name: function(cage (n, 3)) -> positions (k, 3)}, and the field's cut
    points ((k,) bool; None without a field form). ``triangulated``: the field solved on
    the cage's triangles, not its bilinear quads."""
    triangles = triangulate_quads(vertices, quads)
    result, cut = {}, None
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
    if {"field", "every-entry", "interpolated"} & set(wanted):
        start = time.perf_counter()
        if triangulated:
            field = gencoords.harmonic_field(vertices, triangles, resolution=resolution or 64)
        else:
            field = gencoords.harmonic_quad_field(vertices, quads, resolution=resolution or 64)
        print(f"  field: {field} ({time.perf_counter() - start:.0f} s)", flush=True)
        nodes, weights = field.interpolation(points)
        cut = field.cut(nodes)
        if "field" in wanted:
            exact = field.coordinates(points)
            result["field"] = lambda cage, c=exact: c @ cage
        if "every-entry" in wanted:
            every = every_entry_coordinates(field, points)
            result["every-entry"] = lambda cage, c=every: c @ cage
        if "interpolated" in wanted:
            mixed = np.einsum("kc,kcn->kn", weights, field.node_rows(nodes.ravel()).reshape(*nodes.shape, -1))
            result["interpolated"] = lambda cage, c=mixed: c @ cage
    if "mean-value" in wanted:
        mean_value = gencoords.coordinates(points, vertices, triangles, kind=MEAN_VALUE)
        result["mean-value"] = lambda cage, c=mean_value: c @ cage
    return result, cut


def worst_triangles(rest, moved, triangles, joint, cut):
    """Where the worst 1 % of the triangles near ``joint`` lie (those with a corner
    changing by more than the 99th percentile): a line of text."""
    centroids = rest[triangles].mean(axis=1)
    near = np.linalg.norm(centroids - joint, axis=1) < JOINT_RADIUS
    change = angle_changes(rest, moved, triangles[near]).reshape(-1, 3)
    worst = change.max(axis=1) > np.percentile(change, 99)
    offset = (centroids[near][worst] - joint).mean(axis=0)
    text = f"worst {int(worst.sum())}: mean offset from the joint {np.round(offset, 3).tolist()} m"
    if cut is not None:
        text += f", in cut cells {int(cut[triangles[near][worst]].any(axis=1).sum())}"
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--detail", type=float, default=0.5)
    parser.add_argument("--resolution", type=int, default=None, help="the grid's (default: Automatic's)")
    parser.add_argument("--fatten", type=float, default=0.0,
                        help="metres added to every capsule's radius: a body nearer its cage (legs: 0.015 away at 0)")
    parser.add_argument("--forms", nargs="+", default=["stored", "field", "interpolated", "mean-value"],
                        choices=["stored", "field", "every-entry", "interpolated", "mean-value"])
    parser.add_argument("--poses", nargs="+", default=list(POSES), choices=list(POSES))
    parser.add_argument("--triangulated", action="store_true", help="the field on the cage's triangles, not its quads")
    parser.add_argument("--where", action="store_true", help="where the worst 1 %% of the triangles lie")
    args = parser.parse_args()
    capsules = [(part, a, b, radius + args.fatten) for part, a, b, radius in character.character_capsules()]
    points, triangles, _ = character.capsules_mesh(capsules, args.detail)
    vertices, quads = character.character_cage()
    print(f"body {len(points)} vertices, detail {args.detail}, fattened by {args.fatten}", flush=True)
    deformers, cut = forms(points, vertices, quads, args.resolution, args.forms, args.triangulated)
    print(f"| pose | form | creased (> {CREASE_DEGREES} deg) | 99th pct | mean | triangles |\n|---|---|---:|---:|---:|---:|")
    for pose in args.poses:
        function, joint = POSES[pose]
        posed = function(vertices)[0]
        for name, deform in deformers.items():
            rest, moved = deform(vertices), deform(posed)
            creased, p99, mean, count = joint_creases(rest, moved, triangles, joint, JOINT_RADIUS, CREASE_DEGREES)
            print(f"| {pose} | {name} | {creased} | {p99:.2f} | {mean:.2f} | {count} |", flush=True)
            if args.where:
                print(f"    {worst_triangles(rest, moved, triangles, joint, cut)}", flush=True)


if __name__ == "__main__":
    main()
