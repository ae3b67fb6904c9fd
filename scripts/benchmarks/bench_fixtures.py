"""Harmonic coordinates on the scenes an artist builds, against Mesh Deform p5 and p6 in the
same run (part of ``make bench``; issue 35).

The fixtures are ``tests/fixtures/artist_cages.py``'s: a hand with close fingers, a
quadruped with close legs and a thin tail, a thin-walled cup, an open cape in a thin box
cage, the character, and two prongs pressed together (a closed slot). Each method binds
each fixture in a fresh scene, at default settings (Mesh Deform at precision 5 and 6;
GenCoords Harmonic, Automatic storage).

Metrics (ratios to Mesh Deform p5 of the same run):
  bind       wall time of the bind operator.
  playback   median wall time of a live update (``playback.time_updates``: one cage
             vertex moved, ``view_layer.update()``, the evaluated mesh read).
  leak       per edit of the fixture (bend a finger, a leg, swing the tail, the cape's
             lower half, the forearm, either prong of the slot): the largest move of the
             other parts' vertices (``Edit.still``), of the cage's diagonal.
  similarity the cage turned 40 degrees, scaled 1.5 and moved: the mesh's largest distance
             from the same similarity of its rest shape, of the moved cage's size. Where
             Mesh Deform does not deform a mesh at all (the open cape), this is the whole
             move (about 1) and the table says "does not deform".
  peak MB    peak resident memory growth during the bind (``scripts/common/memory.py``),
             every bind in one process: a later bind can find memory an earlier one freed.

Usage: bench_fixtures.py [--fixtures hand quadruped cup cape character] [--detail 0.6]
                         [--kinds harmonic harmonic:32]  (harmonic:<resolution>: another grid)
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.benchmarks import bench_local  # noqa: E402 (prepares the session, imports bpy)
from scripts.common import playback, scenes, session  # noqa: E402
from tests.fixtures import artist_cages  # noqa: E402
import bpy  # noqa: E402
from scripts.common.memory import PeakMemory  # noqa: E402
from scripts.common.playback import settle  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from gencoords.planning.similarity import probe_similarity  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402

MESH_DEFORM = (("md", 5), ("md", 6))
FIXTURES = ("hand", "quadruped", "cup", "cape", "character", "slot")
DOES_NOT_DEFORM = 0.5  # a similarity error this large: the mesh did not follow at all


def similarity_error(mesh, cage, scene, rest):
    """The mesh's largest distance from :func:`probe_similarity` of its rest shape, of
    the moved cage's size (the cage put back after)."""
    rotation, scale, shift = probe_similarity(scene.cage_vertices)
    arrays.write_positions(cage.data, scale * scene.cage_vertices @ rotation.T + shift)
    now = settle(mesh).astype(np.float64)
    arrays.write_positions(cage.data, scene.cage_vertices)
    settle(mesh)
    wanted = scale * rest @ rotation.T + shift
    return float(np.linalg.norm(now - wanted, axis=1).max() / (scale * scene.diagonal))


def leaks(mesh, cage, scene, rest):
    """Per edit, the largest move of the other parts' vertices, of the cage's diagonal."""
    found = {}
    for name, edit in scene.edits.items():
        arrays.write_positions(cage.data, edit.cage_vertices)
        now = settle(mesh).astype(np.float64)
        found[name] = float(np.linalg.norm(now[edit.still] - rest[edit.still], axis=1).max() / scene.diagonal)
    arrays.write_positions(cage.data, scene.cage_vertices)
    settle(mesh)
    return found


def measure(scene, method):
    """One fixture bound with one method in a fresh scene: the row (dict)."""
    scenes.reset_scene()
    mesh = scenes.add_mesh_object(scene.name, scene.mesh_vertices, scene.mesh_faces)
    cage = scenes.add_mesh_object(scene.name + "Cage", scene.cage_vertices, scene.cage_faces)
    bpy.context.view_layer.update()
    try:
        with PeakMemory() as memory:
            seconds = bench_local.bind(mesh, cage, method)
    except RuntimeError as error:
        return {"error": str(error).splitlines()[-1][:80]}
    rest = settle(mesh).astype(np.float64)
    row = {"bind": seconds, "peak": memory.peak, "similarity": similarity_error(mesh, cage, scene, rest),
           "leaks": leaks(mesh, cage, scene, rest)}
    row["playback"], _ = playback.time_updates(mesh, cage, scene.cage_vertices.astype(np.float32))
    return row


def cell(row, reference, key, unit_scale, digits):
    if "error" in row:
        return "-"
    ratio = "" if not reference or "error" in reference else f" ({row[key] / reference[key]:.2f}x)"
    return f"{row[key] * unit_scale:.{digits}f}{ratio}"


def table(results):
    lines = ["| fixture | method | bind s (/ MD p5) | playback ms (/ MD p5) | other parts' largest move | "
             "similarity | peak MB |", "|---|---|---:|---:|---|---:|---:|"]
    for name, rows in results.items():
        reference = rows.get(("md", 5))
        for method, row in rows.items():
            if "error" in row:
                lines.append(f"| {name} | {bench_local.label(method)} | {row['error']} | | | | |")
                continue
            moves = ", ".join(f"{edit} {value:.1e}" for edit, value in row["leaks"].items()) or "-"
            similarity = ("does not deform" if row["similarity"] > DOES_NOT_DEFORM else f"{row['similarity']:.1e}")
            lines.append(f"| {name} | {bench_local.label(method)} | {cell(row, reference, 'bind', 1, 2)} "
                         f"| {cell(row, reference, 'playback', 1e3, 1)} | {moves} | {similarity} "
                         f"| {row['peak'] / 2**20:.0f} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=list(FIXTURES))
    parser.add_argument("--detail", type=float, default=0.6, help="mesh density (1: 12k to 45k vertices)")
    parser.add_argument("--kinds", nargs="+", default=[HARMONIC],
                        help="GenCoords kinds; harmonic:<resolution> for another grid (e.g. Mesh Deform p5's, 32)")
    parser.add_argument("--output", type=Path, default=session.OUT / "bench_fixtures.md")
    args = parser.parse_args()
    methods = MESH_DEFORM + tuple(("gencoords", kind) for kind in args.kinds)
    header = session.report_header("Harmonic on the scenes an artist builds, against Mesh Deform")
    print("\n".join(header), flush=True)
    session.install_extension()
    results = {}
    for name in args.fixtures:
        scene = artist_cages.fixture(name, args.detail)
        print(f"{name}: {len(scene.mesh_vertices)} vertices, cage {len(scene.cage_vertices)} vertices", flush=True)
        results[name] = {}
        for method in methods:
            started = time.perf_counter()
            results[name][method] = row = measure(scene, method)
            print(f"  {bench_local.label(method)}: {row} ({time.perf_counter() - started:.0f} s)", flush=True)
    body = table(results)
    print("\n" + body, flush=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(header) + "\n\n" + body + "\n")
    print(f"written to {args.output}")


if __name__ == "__main__":
    main()
