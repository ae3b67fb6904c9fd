"""The artist controls' figures (part of ``make bench``): what Strength and a vertex-group
Mask cost per evaluation, how long Make Cage takes and how many vertices it makes, how
far Bake to Bones deviates with 4, 8 or all influences per vertex, and what Automatic
storage chooses on Suzanne with 4 subdivisions in Make Cage's cage and in an icosphere
cage, with the deviations Blender's deformed mesh shows from exact mean value coordinates.

Usage: bench_artist.py [--million] [--storage-only]   (--million adds the strength and
mask timing on a 999,547-vertex sphere in a 642-vertex cage, compact storage: a few
minutes to bind, and the storage table's Automatic row on it; --storage-only runs only
the storage table)
"""

import argparse
import time

import numpy as np

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
from scripts.common import scenes  # noqa: E402
import bpy  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from gencoords import Cage  # noqa: E402
from gencoords.skinning import skinning  # noqa: E402
from gencoords.storage import deviations  # noqa: E402

REPEATS = 7


def bind(mesh, cage, kind=scenes.MEAN_VALUE, storage="AUTO"):
    """Bind through the operator (scenes.bind); returns the add-on's binding of ``mesh``."""
    with session.quiet():
        result = scenes.bind(mesh, cage, kind, storage=storage)
    if "FINISHED" not in result:
        raise RuntimeError(f"gencoords_bind returned {result}")
    return session.addon_module("bind.bindings").binding(mesh)


def evaluation_ms(mesh, cage):
    """Median milliseconds of one evaluation after moving the cage's first vertex."""
    rest = arrays.read_positions(cage.data)
    times = []
    for repeat in range(REPEATS):
        moved = rest.copy()
        moved[0, 2] += 0.02 * (repeat + 1)
        arrays.write_positions(cage.data, moved)
        start = time.perf_counter()
        bpy.context.view_layer.update()
        arrays.evaluated_positions(mesh)
        times.append(time.perf_counter() - start)
    arrays.write_positions(cage.data, rest)
    return 1000 * float(np.median(times))


def strength_and_mask(level, subdivisions, storage):
    scenes.reset_scene()
    mesh = scenes.add_benchmark_mesh(level)
    cage = scenes.add_icosphere_cage(subdivisions)
    found = bind(mesh, cage, storage=storage)
    plain = evaluation_ms(mesh, cage)
    compat = session.addon_module("blender_io.compat")
    upper = np.flatnonzero(arrays.read_positions(mesh.data)[:, 2] > 0.0)
    group = mesh.vertex_groups.new(name="Upper")
    group.add(upper.tolist(), 1.0, 'REPLACE')
    compat.set_modifier_input(found.modifier, "Strength", 0.5)
    compat.set_modifier_input_attribute(found.modifier, "Mask", "Upper")
    masked = evaluation_ms(mesh, cage)
    return len(mesh.data.vertices), len(cage.data.vertices), found.data.storage, plain, masked


def make_cage_figures(targets):
    rows = []
    for target in targets:
        scenes.reset_scene()
        mesh = scenes.add_suzanne(2)
        scenes.make_active(mesh)
        start = time.perf_counter()
        with session.quiet():
            bpy.ops.object.gencoords_make_cage(target_vertices=target)
        rows.append((target, time.perf_counter() - start, len(mesh.gencoords.cage.data.vertices)))
    return rows


def bake_deviation(subdivisions, influences):
    scenes.reset_scene()
    mesh = scenes.add_suzanne(2)
    cage = scenes.add_icosphere_cage(subdivisions)
    found = bind(mesh, cage, storage="EXACT")
    coordinates = found.coordinates(mesh.data)
    rest = arrays.read_positions(cage.data)
    moved = deviations.smooth_test_motion(rest)
    return [deviations.deviation(coordinates, skinning.truncate(coordinates, count), np.eye(len(rest)),
                              rest, moved) for count in influences]


def deviations_in_blender(mesh, cage, dragged):
    """What the evaluated mesh shows, per cage diagonal, against exact mean value
    coordinates (the core's, float64): the largest distance after the standard smooth
    cage motion and after dragging cage vertex ``dragged`` by a tenth of the diagonal."""
    rest_cage = arrays.read_positions(cage.data).astype(np.float64)
    rest = arrays.read_positions(mesh.data).astype(np.float64)
    motions = [deviations.smooth_test_motion(rest_cage),
               deviations.vertex_drag_motion(rest_cage, dragged)]
    cage.data.calc_loop_triangles()
    triangles = np.array([t.vertices[:] for t in cage.data.loop_triangles])
    exact = [rest.copy() for _ in motions]
    with Cage(rest_cage, triangles, tolerance=1e-6) as exact_cage:
        for start in range(0, len(rest), 20_000):  # a chunk at a time: 642 cage vertices
            rows = slice(start, start + 20_000)
            coordinates = exact_cage.coordinates(rest[rows])
            for moved, target in zip(motions, exact):
                target[rows] += coordinates @ (moved - rest_cage)
    diagonal = scenes.cage_size(rest_cage)
    found = []
    for moved, target in zip(motions, exact):
        arrays.write_positions(cage.data, moved)
        bpy.context.view_layer.update()
        found.append(np.linalg.norm(arrays.evaluated_positions(mesh) - target, axis=1).max()
                     / diagonal)
    arrays.write_positions(cage.data, rest_cage)
    return found


def storage_figures(level, cage_kind, storage):
    """Bind Suzanne with ``level`` subdivisions (None: the million-vertex sphere) in Make
    Cage's 100-vertex cage (``cage_kind`` "make cage") or a 642-vertex icosphere
    ("icosphere") with ``storage`` ('AUTO' or 'COMPACT:<slots>'); returns the row of the
    storage table."""
    scenes.reset_scene()
    mesh = scenes.add_benchmark_mesh(level)
    scenes.make_active(mesh)
    if cage_kind == "make cage":
        with session.quiet():
            bpy.ops.object.gencoords_make_cage(target_vertices=100)
        cage = mesh.gencoords.cage
    else:
        cage = scenes.add_icosphere_cage(4)
    setting, _, slots = storage.partition(":")
    if slots:
        mesh.gencoords.compact_size = int(slots)
    start = time.perf_counter()
    info = bind(mesh, cage, storage=setting).data
    seconds = time.perf_counter() - start
    smooth, drag = deviations_in_blender(mesh, cage, info.deviation_drag_vertex)
    return {"mesh": len(mesh.data.vertices), "cage": f"{cage_kind}, {len(cage.data.vertices)}",
            "setting": storage.lower(), "chose": f"{info.storage.lower()} {info.slot_count}",
            "why": (info.storage_choice or "-"), "bind": seconds,
            "reported": (info.deviation_smooth, info.deviation_drag),
            "blender": (smooth, drag), "evaluation": evaluation_ms(mesh, cage),
            "megabytes": info.nbytes / 2**20}


def print_storage_table(million=False):
    print("\nStorage: what Automatic chooses, and the deviation from exact mean value "
          "coordinates (of the cage diagonal) for the standard smooth motion / the worst "
          "dragged cage vertex (a tenth of the diagonal): as Bind reports it (measured on every "
          "vertex, as stored) and as Blender deforms the mesh (read back after moving the cage)")
    print("| mesh | cage | Storage | chose | panel says | bind | reported | in Blender "
          "| evaluation | bind data |")
    print("|---:|---|---|---|---|---:|---|---|---:|---:|")
    rows = [(4, "make cage", "AUTO"), (4, "make cage", "COMPACT:36"), (4, "icosphere", "AUTO"),
            (4, "icosphere", "COMPACT:36")]
    for level, cage_kind, storage in rows + ([(None, "icosphere", "AUTO")] if million else []):
        row = storage_figures(level, cage_kind, storage)
        print(f"| {row['mesh']} | {row['cage']} | {row['setting']} | {row['chose']} | "
              f"{row['why']} | {row['bind']:.1f} s | "
              + " / ".join(f"{value:.1e}" for value in row["reported"]) + " | "
              + " / ".join(f"{value:.1e}" for value in row["blender"])
              + f" | {row['evaluation']:.1f} ms | {row['megabytes']:.0f} MB |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--million", action="store_true")
    parser.add_argument("--storage-only", action="store_true")
    args = parser.parse_args()
    session.install_extension()
    if args.storage_only:
        print_storage_table(args.million)
        return
    print(f"Blender {bpy.app.version_string}; ms per evaluation after a cage edit "
          f"(median of {REPEATS}), reading the positions included")
    print("\nStrength and Mask:")
    print("| mesh | cage | storage | plain | strength 0.5 + vertex-group mask |")
    print("|---:|---:|---|---:|---:|")
    scenes = [(3, 3, "AUTO")] + ([(None, 4, "COMPACT")] if args.million else [])
    for level, subdivisions, storage in scenes:
        k, n, used, plain, masked = strength_and_mask(level, subdivisions, storage)
        print(f"| {k} | {n} | {used.lower()} | {plain:.1f} ms | {masked:.1f} ms |", flush=True)
    print("\nMake Cage around the demo's Suzanne (7958 vertices):")
    print("| target vertices | time | cage vertices |")
    print("|---:|---:|---:|")
    for target, seconds, count in make_cage_figures((50, 100, 200)):
        print(f"| {target} | {seconds * 1000:.0f} ms | {count} |", flush=True)
    print("\nBake to Bones: deviation for the standard smooth cage motion (of the cage size),"
          " Suzanne 7958 vertices, mean value:")
    influences = (4, 8, 0)
    print("| cage | 4 influences | 8 influences | all |")
    print("|---:|---:|---:|---:|")
    for subdivisions in (2, 3):
        row = bake_deviation(subdivisions, influences)
        print(f"| {scenes.ICOSPHERE_VERTICES[subdivisions]} | "
              + " | ".join(f"{value:.1e}" for value in row) + " |", flush=True)
    print_storage_table(args.million)


if __name__ == "__main__":
    main()
