"""Local coordinates on the artist's character, against Mesh Deform (part of ``make bench``).

The character (``tests/fixtures/character.py``): a 43k-vertex body of capsules in its
box-modelled, non-convex T-pose quad cage (196 vertices). Methods, each bound in a fresh
scene: Mesh Deform at precision 5 and 6, GenCoords mean value and GenCoords harmonic
(local, positive; sparse storage), both with Automatic storage.

Metrics:
  bind       wall time of the bind operator (``meshdeform_bind`` / ``gencoords_bind``).
  peak MB    peak resident memory growth during the bind (the process and its workers,
             ``scripts/common/memory.py``). Each method binds in a Blender process of its
             own (this script again, ``--measure``): in one process, a bind after Mesh
             Deform's found the allocator's arenas as Mesh Deform's threads left them and
             grew by up to 35 MB more than in a fresh process (none with
             MALLOC_ARENA_MAX=1), which measured the order, not the method.
  .blend MB  uncompressed .blend size the binding adds to the unbound scene.
  update     live update (move one cage vertex, ``view_layer.update()``, read the
             evaluated mesh), every method bound side by side in one scene and timed in
             turns (``--rounds`` rounds): median and least wall time, and the ratio of the
             median CPU time (the process's, all threads: steadier on a shared machine)
             to Mesh Deform p5's.
  locality   each of the two arms, two legs and head in turn: its cage vertices
             (``character.cage_limb_vertices``: the outer half of a limb) moved forward by
             20 % of the cage's diagonal; the largest move of the body's vertices of the
             four other limbs (``limb_labels``; the torso and neck, which they hang on,
             not counted), of the diagonal: the worst over the arms and legs, and the
             head's (its cage's lowest vertices sit a cell above the shoulders).
  bend       the left forearm's cage vertices turned 60 degrees about the elbow (the
             y axis through the middle of the arm): per triangle of the left arm, the
             change of its three angles; mean and 99th percentile (degrees), and triangles
             flipped (normal against both its rest normal and its rest normal turned 60
             degrees), and triangles with a corner changing by more than 30 degrees.
  joints     (``--poses``: only these, every method bound in turn in one process) the
             left knee bent and the left leg swung forward (``character.LEG_POSES``) and
             the forearm bent: per pose, the body's triangles within JOINT_RADIUS of the
             joint, those with a corner changing by more than 30 degrees, the 99th
             percentile and the mean of the corner changes (issue 35, item 5).
  negative   share of the (mesh vertex, cage vertex) coordinates below 0, and the
             smallest (GenCoords; Mesh Deform has none).

Usage: bench_local.py [--precisions 5 6] [--kinds mean_value harmonic] [--rounds 15]
       bench_local.py --poses [--detail 0.5] [--kinds harmonic]
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported
from scripts.common import measures, scenes  # noqa: E402
from tests.fixtures import character  # noqa: E402
import bpy  # noqa: E402
from scripts.common import playback  # noqa: E402
from scripts.common.memory import PeakMemory, blend_size  # noqa: E402
from scripts.common.playback import settle  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402

MOVED_LIMBS = ("left_arm", "right_arm", "left_leg", "right_leg", "head")
LOCALITY_MOVE = 0.2  # of the cage's diagonal
BEND_DEGREES = 60.0
CREASE_DEGREES = 30  # a corner changing by more than this reads as a crease (issue 35, item 5)
JOINT_RADIUS = 0.15  # metres: the triangles a joint's figures count
POSES = {**character.LEG_POSES, "bent forearm": (character.bent_forearm, character.ELBOW)}


def bind(mesh, cage, method):
    """Bind ``mesh`` to ``cage`` with ``method`` (("md", precision) or ("gencoords",
    kind[:resolution])); returns the wall time."""
    scenes.make_active(mesh)
    start = time.perf_counter()
    with session.quiet():
        if method[0] == "md":
            modifier = mesh.modifiers.new("MeshDeform", 'MESH_DEFORM')
            modifier.object, modifier.precision = cage, method[1]
            bpy.ops.object.meshdeform_bind(modifier=modifier.name)
            ok = modifier.is_bound
        else:
            kind, _, resolution = method[1].partition(":")
            if resolution:
                mesh.gencoords.resolution = int(resolution)
            ok = "FINISHED" in scenes.bind(mesh, cage, kind, storage='AUTO')
    if not ok:
        raise RuntimeError(f"{method} did not bind")
    return time.perf_counter() - start


def locality(mesh, cage, rest_cage, labels, size):
    """The largest move of the other limbs' vertices when one limb's cage vertices move
    by LOCALITY_MOVE of the diagonal, of the diagonal: {limb: figure}."""
    rest = settle(mesh)
    moves = {}
    for limb in MOVED_LIMBS:
        moved = rest_cage.astype(np.float64)
        moved[character.cage_limb_vertices(rest_cage, limb)] += (0.0, -LOCALITY_MOVE * size, 0.0)
        arrays.write_positions(cage.data, moved)
        now = settle(mesh)
        other = np.isin(labels, MOVED_LIMBS) & (labels != limb)
        moves[limb] = float(np.linalg.norm(now[other] - rest[other], axis=1).max()) / size
    arrays.write_positions(cage.data, rest_cage)
    settle(mesh)
    return moves


def normals(points, triangles):
    corners = points[triangles]
    return np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])


def bend(mesh, cage, rest_cage, labels, triangles):
    """The left forearm's cage vertices turned BEND_DEGREES about the elbow
    (``character.bent_forearm``): the left arm's triangle angle changes (mean, 99th
    percentile, degrees), flipped triangles and triangles with a corner changing by more
    than CREASE_DEGREES (issue 35's count of creases)."""
    rest = settle(mesh).astype(np.float64)
    moved, rotation = character.bent_forearm(rest_cage, BEND_DEGREES)
    arrays.write_positions(cage.data, moved)
    now = settle(mesh).astype(np.float64)
    arrays.write_positions(cage.data, rest_cage)
    settle(mesh)
    arm = triangles[(labels[triangles] == "left_arm").all(axis=1)]
    change = measures.angle_changes(rest, now, arm)
    before, after = normals(rest, arm), normals(now, arm)
    flipped = ((after * before).sum(1) < 0) & ((after * (before @ rotation.T)).sum(1) < 0)
    creased = int((change.reshape(-1, 3) > CREASE_DEGREES).any(axis=1).sum())
    return float(change.mean()), float(np.percentile(change, 99)), int(flipped.sum()), creased


def joints(mesh, cage, rest_cage, triangles):
    """Each of POSES applied to the cage: {pose: (creased, 99th percentile, mean,
    triangles counted)} near its joint (``measures.joint_creases``)."""
    rest = settle(mesh).astype(np.float64)
    figures = {}
    for pose, (function, joint) in POSES.items():
        arrays.write_positions(cage.data, function(rest_cage)[0])
        now = settle(mesh).astype(np.float64)
        figures[pose] = measures.joint_creases(rest, now, triangles, joint, JOINT_RADIUS, CREASE_DEGREES)
    arrays.write_positions(cage.data, rest_cage)
    settle(mesh)
    return figures


def joints_table(methods, detail):
    """Every method bound in turn in this process, on the body at ``detail``: the joints'
    figures as a table."""
    lines = [f"| pose | method | creased (> {CREASE_DEGREES} deg) | 99th pct | mean | triangles | bind |",
             "|---|---|---:|---:|---:|---:|---:|"]
    rows = {}
    for method in methods:
        scenes.reset_scene()
        mesh, cage = scenes.add_character(detail=detail)
        rest_cage = arrays.read_positions(cage.data).copy()
        triangles = arrays.read_loop_triangles(mesh.data)
        bpy.context.view_layer.update()
        seconds = bind(mesh, cage, method)
        rows[method] = (joints(mesh, cage, rest_cage, triangles), seconds)
        print(f"  {label(method)}: {rows[method]}", flush=True)
    for pose in POSES:
        for method, (figures, seconds) in rows.items():
            creased, p99, mean, count = figures[pose]
            lines.append(f"| {pose} | {label(method)} | {creased} | {p99:.1f} | {mean:.2f} | {count} | {seconds:.1f} s |")
    return "\n".join(lines)


def measure_apart(method, kinds):
    """:func:`measure` in a Blender process of its own (one-time costs of the GenCoords
    kinds paid before, by a throw-away bind on a small body): the row."""
    command = [sys.executable, str(Path(__file__).resolve()), "--measure", json.dumps(method), "--kinds", *kinds]
    done = subprocess.run(command, check=True, stdout=subprocess.PIPE, text=True)
    lines = done.stdout.splitlines()
    print("\n".join(line for line in lines if line.startswith("  ")), flush=True)
    return json.loads(lines[-1])


def measure_here(method, kinds):
    """The ``--measure`` side of :func:`measure_apart`: prints the row as JSON, last."""
    session.install_extension()
    scenes.reset_scene()
    scenes.add_character()
    empty_blend = blend_size("unbound")  # the scene before its binding
    if method[0] == "gencoords":
        for kind in {kind.partition(":")[0] for kind in kinds}:
            scenes.reset_scene()
            bind(*scenes.add_character(detail=0.2), ("gencoords", kind))
    rows = {}
    measure(method, empty_blend, rows)
    print(json.dumps(rows[method]), flush=True)


def measure(method, empty_blend, rows):
    """Bind ``method`` in a fresh scene and measure everything but the update."""
    scenes.reset_scene()
    mesh, cage = scenes.add_character()
    rest_cage = arrays.read_positions(cage.data).copy()
    points = arrays.read_positions(mesh.data)
    labels = character.limb_labels(points)
    triangles = arrays.read_loop_triangles(mesh.data)
    size = scenes.cage_size(rest_cage)
    bpy.context.view_layer.update()
    with PeakMemory() as memory:
        seconds = bind(mesh, cage, method)
    row = {"bind": seconds, "peak": memory.peak}
    row["blend"] = blend_size("local") - empty_blend
    moves = locality(mesh, cage, rest_cage, labels, size)
    row["locality"] = max(moves[limb] for limb in MOVED_LIMBS if limb != "head")
    row["locality_head"] = moves["head"]
    row["bend_mean"], row["bend_99"], row["flipped"], row["creased"] = bend(mesh, cage, rest_cage, labels, triangles)
    row["storage"], row["negative"] = stored(mesh) if method[0] == "gencoords" else ("-", "0")
    rows[method] = row
    print(f"  {label(method)}: bind {seconds:.2f} s, peak {memory.peak / 2**20:.0f} MB, "
          f".blend +{row['blend'] / 2**20:.1f} MB, locality {row['locality']:.1e} "
          f"(head {row['locality_head']:.1e}), bend {row['bend_mean']:.2f} / {row['bend_99']:.1f} deg, "
          f"{row['flipped']} flipped, {row['storage']}", flush=True)


def stored(mesh):
    """The storage Automatic chose, and the share of negative coordinates."""
    result = session.addon_module("api").binding_result(mesh)
    share = (result.negative_entries or 0) / (result.mesh_vertex_count * result.cage_vertex_count)
    return f"{result.storage.lower()} {result.slot_count}", f"{share:.1%} (min {result.min_coordinate:.3f})"


def time_side_by_side(methods, rows, rounds):
    """Every method bound in one scene, each on its own mesh and cage; median updates
    timed in turns."""
    scenes.reset_scene()
    bound = []
    for method in methods:
        mesh, cage = scenes.add_character()
        bpy.context.view_layer.update()
        bind(mesh, cage, method)
        bound.append((method, mesh, cage, arrays.read_positions(cage.data).copy()))
    bpy.context.view_layer.update()
    state = [settle(mesh) for _, mesh, _, _ in bound]
    times = [[] for _ in bound]
    for repeat in range(rounds):
        for i, (_, mesh, cage, rest_cage) in enumerate(bound):
            seconds, _, state[i], cpu = playback.time_update(mesh, cage, rest_cage, repeat, state[i])
            times[i].append((seconds, cpu))
    for (method, *_), measured in zip(bound, times):
        wall, cpu = np.array(measured).T
        rows[method]["update"], rows[method]["cpu"] = float(np.median(wall)), float(np.median(cpu))
        rows[method]["update_min"] = float(wall.min())


def label(method):
    if method[0] == "md":
        return f"Mesh Deform p{method[1]}"
    kind, _, resolution = method[1].partition(":")
    return f"GenCoords {kind.replace('_', ' ')}" + (f" (resolution {resolution})" if resolution else "")


def table(rows):
    reference = rows.get(("md", 5))
    lines = ["| method | storage | bind | bind / MD p5 | peak MB | .blend MB added | update median / min "
             "| CPU / MD p5 | arms and legs: other limbs' largest move | head: other limbs' largest move "
             f"| bend: mean / 99th pct angle change | over {CREASE_DEGREES} deg | flipped | negative |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for method, row in rows.items():
        ratio = (f"{row['bind'] / reference['bind']:.2f}", f"{row['cpu'] / reference['cpu']:.2f}") \
            if reference else ("-", "-")
        lines.append(
            f"| {label(method)} | {row['storage']} | {row['bind']:.2f} s | {ratio[0]} "
            f"| {row['peak'] / 2**20:.0f} | {row['blend'] / 2**20:.1f} "
            f"| {row['update'] * 1e3:.1f} / {row['update_min'] * 1e3:.1f} ms | {ratio[1]} "
            f"| {row['locality']:.1e} | {row['locality_head']:.1e} "
            f"| {row['bend_mean']:.2f} / {row['bend_99']:.1f} deg | {row['creased']} | {row['flipped']} | {row['negative']} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--precisions", nargs="+", type=int, default=[5, 6])
    parser.add_argument("--kinds", nargs="+", default=[MEAN_VALUE, HARMONIC],
                        help="GenCoords kinds; harmonic:<resolution> for another grid")
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--output", type=Path, default=session.OUT / "bench_local.md")
    parser.add_argument("--poses", action="store_true", help="only the joints' creases under the poses")
    parser.add_argument("--detail", type=float, default=1.0, help="the body's (--poses)")
    parser.add_argument("--measure", help=argparse.SUPPRESS)  # one method, in this process
    args = parser.parse_args()
    if args.measure:
        measure_here(tuple(json.loads(args.measure)), args.kinds)
        return
    header = session.report_header("Local coordinates on the character, against Mesh Deform")
    print("\n".join(header), flush=True)
    session.install_extension()
    methods = [("md", p) for p in args.precisions] + [("gencoords", kind) for kind in args.kinds]
    if args.poses:
        body = joints_table(methods, args.detail)
        print("\n" + body, flush=True)
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.with_name("bench_local_joints.md").write_text("\n".join(header) + "\n\n" + body + "\n")
        return
    scenes.reset_scene()
    mesh, cage = scenes.add_character()
    print(f"character: {len(mesh.data.vertices)} vertices, cage {len(cage.data.vertices)} vertices",
          flush=True)
    rows = {method: measure_apart(method, args.kinds) for method in methods}
    time_side_by_side(methods, rows, args.rounds)
    body = table(rows)
    print("\n" + body, flush=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(header) + "\n\n" + body + "\n")
    print(f"written to {args.output}")


if __name__ == "__main__":
    main()
