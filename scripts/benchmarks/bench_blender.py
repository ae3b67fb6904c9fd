"""GenCoords against Blender's Mesh Deform modifier, in one Blender process (``make bench``).

Scenes: Suzanne subdivided 2, 3, 4 times (7958 / 31658 / 126218 vertices) inside
icosphere cages of 42, 162, 642 vertices (radius 2: convex and containing the mesh).
Methods: Mesh Deform at precision 5 and 6 (6 takes minutes and gigabytes per scene, so by
default only on the smallest scene; 7 and more exhaust memory) and GenCoords with each
coordinate type in exact and compact storage, each bound in a freshly built scene.
``--million``: a 999,547-vertex UV sphere in the 642-vertex cage instead (the native
deformer's large-mesh target), GenCoords compact against Mesh Deform precision 5.
``--character``: the artist's character (``scenes.add_character``: a 43k-vertex body in
its 196-vertex box-modelled quad cage), GenCoords mean value and Green in exact storage
(``--storages`` to change) against Mesh Deform precision 5, with Bind's writing (node
group and attributes, ``bind.commit``) timed apart.

Metrics, measured the same way for every method:
  bind       wall time of the bind operator (``meshdeform_bind`` / ``gencoords_bind``).
  writing    of that, GenCoords' writing (``bind.commit.steps``: the node group, the
             attributes, the modifier), and the node group's node and link counts.
  update     one live update: move one cage vertex, then time ``view_layer.update()``
             (repeated until the evaluated mesh changes) plus reading the evaluated
             positions (``position`` attribute, ``foreach_get``: 2 ms for a million
             vertices); median of 7 moves.
  peak MB    peak resident memory of the process and its worker processes during the
             bind minus resident memory just before it, sampled every millisecond from
             /proc by a separate process
             (operators hold the GIL, so a thread could not sample during a bind); freed
             heap memory is handed back first (malloc_trim) so earlier runs hide nothing.
  kept MB    resident memory after the bind minus before it: what the binding retains.
  .blend MB  size of an uncompressed .blend holding just that bound scene.
  deviation  compact storage: its own measured deviation from exact coordinates for the
             standard smooth cage motion / the worst single dragged cage vertex (of the
             cage diagonal; measured at Bind on every vertex, as stored).
  affine     max distance, relative to the cage's bounding-box diagonal, between the
             deformed mesh and the exact image of the rest mesh under an affine map
             applied to every cage vertex (exact coordinates reproduce it exactly; for
             Green coordinates a similarity, which they reproduce).
  vs MD5     max / mean distance, relative to the cage diagonal, between this method's
             mesh and Mesh Deform precision 5's after the same non-affine cage edit
             (the demo's pull-and-twist): how different the deformations look.

Usage: bench_blender.py [--quick | --full] [--kinds mean_value ...] [--precisions 5 6]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
from scripts.common import scenes  # noqa: E402
import bpy  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from scripts.common.playback import settle, time_updates  # noqa: E402
from scripts.common.memory import PeakMemory, blend_size  # noqa: E402

CHARACTER = "character"  # run_method's level for the artist's character
CHARACTER_VERTICES, CHARACTER_CAGE_VERTICES = 43236, 196
MOVED_CAGE_VERTEX = 0  # the top vertex of every icosphere: moves many mesh vertices

# ------------------------------------------------------------------------------ methods


def bind_mesh_deform(mesh, cage, precision):
    """Mesh Deform modifier bound at ``precision``; returns the bind wall time."""
    modifier = mesh.modifiers.new("MeshDeform", "MESH_DEFORM")
    modifier.object = cage
    modifier.precision = precision
    scenes.make_active(mesh)
    start = time.perf_counter()
    with session.quiet():
        bpy.ops.object.meshdeform_bind(modifier=modifier.name)
    seconds = time.perf_counter() - start
    if not modifier.is_bound:
        raise RuntimeError(f"Mesh Deform precision {precision} did not bind")
    return seconds


def bind_gencoords(mesh, cage, kind, storage):
    """GenCoords bound with ``kind`` and ``storage`` ('EXACT', 'COMPACT', 'COMPACT:<slots>'
    or 'AUTO'); returns the bind wall time and, of it, the seconds spent writing."""
    storage, _, slots = storage.partition(":")
    commit = session.addon_module("bind.commit")
    steps, writing = commit.steps, []

    def timed_steps(*args, **kwargs):  # the writing, a generator run to its end here
        started = time.perf_counter()
        try:
            return (yield from steps(*args, **kwargs))
        finally:
            writing.append(time.perf_counter() - started)

    commit.steps = timed_steps
    start = time.perf_counter()
    try:
        with session.quiet():  # its "Info: Bound ..." report
            result = scenes.bind(mesh, cage, kind, storage=storage, compact_size=int(slots) if slots else None)
    finally:
        commit.steps = steps
    seconds = time.perf_counter() - start
    if "FINISHED" not in result or not mesh.modifiers:
        raise RuntimeError(f"gencoords_bind ({kind}) returned {result}")
    return seconds, sum(writing)


# ---------------------------------------------------------------------------- measuring


def run_method(level, subdivisions, method):
    """Build the scene, bind with ``method`` and measure everything for one table row.

    ``method`` is ``("md", precision)`` or ``("gencoords", kind, storage)``; ``level``
    None is the million-vertex sphere.
    """
    scenes.reset_scene()
    if level == CHARACTER:
        mesh, cage = scenes.add_character()
    else:
        mesh = scenes.add_benchmark_mesh(level)
        cage = scenes.add_icosphere_cage(subdivisions)
    rest_mesh, rest_cage = arrays.read_positions(mesh.data), arrays.read_positions(cage.data)
    size = scenes.cage_size(rest_cage)
    bpy.context.view_layer.update()

    with PeakMemory() as memory:
        if method[0] == "md":
            seconds, writing = bind_mesh_deform(mesh, cage, method[1]), None
        else:
            seconds, writing = bind_gencoords(mesh, cage, method[1], method[2])
    row = {"bind": seconds, "writing": writing, "peak": memory.peak, "kept": memory.kept, "deviation": "-",
           "group": "-"}
    if method[0] == "gencoords":
        found = session.addon_module("bind.bindings").binding(mesh)
        info = found.data
        tree = found.modifier.node_group
        row["group"] = f"{len(tree.nodes)} / {len(tree.links)}"
        row["storage"] = f"{info.storage.lower()} {info.slot_count}"
        if info.storage == "COMPACT":
            row["deviation"] = f"{info.deviation_smooth:.1e} / {info.deviation_drag:.1e}"

    bpy.context.view_layer.update()
    bound = arrays.evaluated_positions(mesh)
    row["rest_error"] = float(np.abs(bound - rest_mesh).max()) / size
    row["blend"] = blend_size(f"{method[0]}-{method[1]}")
    row["update"], row["passes"] = time_updates(mesh, cage, rest_cage, MOVED_CAGE_VERTEX)

    # Green coordinates are exact for similarities, the others for every affine map.
    exact_map = scenes.similarity_map if method[1] == scenes.GREEN else scenes.affine_map
    arrays.write_positions(cage.data, exact_map(rest_cage))
    moved = settle(mesh)
    row["affine"] = float(np.linalg.norm(moved - exact_map(rest_mesh), axis=1).max()) / size
    arrays.write_positions(cage.data, scenes.nonaffine_edit(rest_cage))
    row["edited"] = settle(mesh)
    row["size"] = size
    return row


# ------------------------------------------------------------------------------ report


def writing_words(seconds):
    return "" if seconds is None else f"writing {seconds:6.3f} s  "


def fmt_time(seconds):
    return f"{seconds:.2f} s" if seconds >= 0.1 else f"{seconds * 1000:.0f} ms"


def table(results):
    """The Markdown table: one row per (scene, method), ratios against Mesh Deform p5."""
    lines = [
        "| mesh | cage | method | bind | MD5 bind / bind | writing | nodes / links | update "
        "| update / MD5 update | peak MB | kept MB | .blend MB | deviation | affine err | vs MD5 max / mean |",
        "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|",
    ]
    for (verts, cage_verts), rows in results.items():
        reference = rows.get(("md", 5))
        for method, row in rows.items():
            name = (f"Mesh Deform p{method[1]}" if method[0] == "md"
                    else f"GenCoords {scenes.KIND_LABELS[method[1]]} ({row['storage']})")
            if reference is not None and method != ("md", 5):
                ratio = reference["bind"] / row["bind"]
                speedup = f"{ratio:.1f}x" if ratio >= 1 else f"{ratio:.2g}x"
                slowdown = f"{row['update'] / reference['update']:.2f}"
                gap = np.linalg.norm(row["edited"] - reference["edited"], axis=1) / row["size"]
                versus = f"{gap.max():.2e} / {gap.mean():.2e}"
            else:
                speedup = slowdown = versus = "-"
            lines.append(
                f"| {verts} | {cage_verts} | {name} | {fmt_time(row['bind'])} | {speedup} "
                f"| {'-' if row['writing'] is None else fmt_time(row['writing'])} | {row['group']} "
                f"| {row['update'] * 1000:.1f} ms | {slowdown} "
                f"| {row['peak'] / 2**20:.0f} | {row['kept'] / 2**20:.0f} "
                f"| {row['blend'] / 2**20:.1f} | {row['deviation']} | {row['affine']:.1e} "
                f"| {versus} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sweep = parser.add_mutually_exclusive_group()
    sweep.add_argument("--quick", action="store_true",
                       help="default: 8k and 32k vertex meshes, 42 and 162 vertex cages")
    sweep.add_argument("--full", action="store_true",
                       help="8k/32k/126k meshes x 42/162/642 cages (about an hour: "
                            "Mesh Deform precision 6 takes minutes per scene)")
    sweep.add_argument("--million", action="store_true",
                       help="a 999,547-vertex sphere in the 642-vertex cage: GenCoords "
                            "compact against Mesh Deform precision 5")
    kinds = list(scenes.KINDS) + [scenes.GREEN, HARMONIC]
    sweep.add_argument("--character", action="store_true",
                       help="the artist's character (43k vertices, 196-vertex quad cage): "
                            "mean value and Green, exact, against Mesh Deform precision 5")
    parser.add_argument("--kinds", nargs="+", choices=kinds, default=None)
    parser.add_argument("--storages", nargs="+", default=["EXACT", "COMPACT"],
                        help="EXACT, COMPACT (36 slots), COMPACT:<slots> or AUTO (what "
                             "Automatic chooses, measured at Bind); --million "
                             "default: COMPACT:12 COMPACT:24 COMPACT:36 (the trade-off)")
    parser.add_argument("--precisions", nargs="+", type=int, default=None,
                        help="Mesh Deform precisions on every scene (5 is the reference "
                             "for ratios). Default: 5 everywhere, 6 on the smallest scene "
                             "only (about 5 minutes); --full: 5 and 6 everywhere")
    parser.add_argument("--output", type=Path, default=session.OUT / "bench_blender.md")
    args = parser.parse_args()
    levels, cages = ((2, 3, 4), (2, 3, 4)) if args.full else ((2, 3), (2, 3))
    if args.million:
        levels, cages = (None,), (4,)
        if args.storages == ["EXACT", "COMPACT"]:
            args.storages = ["COMPACT:12", "COMPACT:24", "COMPACT:36"]
        args.precisions = args.precisions or [5]
    if args.character:
        levels, cages = (CHARACTER,), (None,)
        args.kinds = args.kinds or [scenes.MEAN_VALUE, scenes.GREEN]
        args.storages = ["EXACT"] if args.storages == ["EXACT", "COMPACT"] else args.storages
        args.precisions = args.precisions or [5]
    args.kinds = args.kinds or kinds
    if args.precisions:
        everywhere, smallest_only = sorted(set(args.precisions), key=lambda p: p != 5), []
    else:
        everywhere, smallest_only = ([5, 6], []) if args.full else ([5], [6])

    header = session.report_header("GenCoords vs Mesh Deform (Blender)")
    print("\n".join(header), flush=True)
    zip_path = session.install_extension()
    print(f"extension: {zip_path.relative_to(session.REPO)}\n", flush=True)

    # One throw-away bind of a plain Suzanne, so one-time costs (first imports, worker
    # threads) are not charged to the first measured row.
    run_method(0, 2, ("gencoords", args.kinds[0], "EXACT"))
    kinds = [("gencoords", kind, storage) for storage in args.storages for kind in args.kinds]
    results = {}
    started = time.perf_counter()
    for level in levels:
        for subdivisions in cages:
            key = ((CHARACTER_VERTICES, CHARACTER_CAGE_VERTICES) if level == CHARACTER else
                   (scenes.MILLION_VERTICES if level is None else scenes.SUZANNE_VERTICES[level],
                    scenes.ICOSPHERE_VERTICES[subdivisions]))
            rows = results.setdefault(key, {})
            smallest = (level, subdivisions) == (levels[0], cages[0])
            precisions = everywhere + (smallest_only if smallest else [])
            for method in [("md", p) for p in precisions] + kinds:
                row = run_method(level, subdivisions, method)
                rows[method] = row
                print(f"  {key[0]:>6} / {key[1]:>3} {method[0]:9s} "
                      f"{' '.join(map(str, method[1:])):25s} "
                      f"bind {row['bind']:7.3f} s  "
                      f"{writing_words(row['writing'])}"
                      f"group {row['group']:>11s}  update {row['update'] * 1000:6.1f} ms "
                      f"({row['passes']} passes)  peak {row['peak'] / 2**20:6.0f} MB  "
                      f"affine {row['affine']:.1e}  rest {row['rest_error']:.1e}",
                      flush=True)
    body = table(results)
    notes = (__doc__.split("Metrics, measured the same way for every method:")[1]
             .split("Usage:")[0].rstrip())
    report = "\n".join(header) + "\n\n" + body + "\n\nMetrics:" + notes + (
        f"\n\nTotal benchmark time {time.perf_counter() - started:.0f} s.\n")
    print("\n" + body + f"\n\nTotal {time.perf_counter() - started:.0f} s", flush=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(report)
    print(f"written to {args.output}")


if __name__ == "__main__":
    main()
