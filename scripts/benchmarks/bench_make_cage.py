"""Make Cage, Convex against Tight, on the artist's character (43,236 vertices, capsules
that overlap) and on Suzanne (2 subdivisions, 7958 vertices): the time Make Cage takes
(through the operator, reading what it wrote), the cage's vertex count, its volume over
the mesh's, and whether it encloses every vertex (as Bind splits its quads). The mesh's volume is the union of its
shells (overlaps once): winding numbers along a grid of vertical columns
(``gencoords.cages.volumes.union_volume``). The character's own box-modelled cage is the
reference for what an artist models.

Usage: bench_make_cage.py [--vertices 200] [--sweep]   (about a minute; --sweep adds Tight
at other vertex counts and offsets on both meshes, refusals included: two more minutes;
timings are noisy on a shared machine)
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
import bpy  # noqa: E402
import gencoords  # noqa: E402
from gencoords.cages import self_intersection, volumes  # noqa: E402
from scripts.common import scenes  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402


def world_arrays(obj):
    """World positions (float64) of ``obj``'s mesh and its triangles as Bind reads them
    (quads split by the core)."""
    matrix = np.array(obj.matrix_world)
    local = arrays.read_positions(obj.data)
    triangles, _ = session.addon_module("blender_io.mesh_io").read_triangles(obj.data, local)
    return local.astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3], triangles


def add_mesh(name):
    """The scene's mesh (the character's artist cage too, or None)."""
    scenes.reset_scene()
    if name == "character":
        return scenes.add_character()
    return scenes.add_suzanne(2), None


def row(mesh, cage, seconds, label):
    """What the table says of ``cage`` around ``mesh``."""
    body, body_triangles = world_arrays(mesh)
    points, triangles = world_arrays(cage)
    where = gencoords.point_locations(body, points, triangles, tolerance=1e-6)
    crossing = len(self_intersection.self_intersections(points, triangles))
    ratio = volumes.volume_ratio(points, triangles, body, body_triangles)
    inside = "all" if (where == gencoords.INSIDE).all() else f"{int((where != gencoords.INSIDE).sum())} not"
    time_text = f"{seconds:.1f} s" if seconds is not None else "-"
    quads = sum(len(polygon.vertices) == 4 for polygon in cage.data.polygons)
    return (f"| {label} | {len(body)} | {time_text} | {len(points)} | {len(cage.data.polygons)} "
            f"({quads}) | {ratio:.2f} | {inside} | {crossing} |")


SWEEP = ((60, 0.01), (100, 0.01), (300, 0.01), (150, 0.02), (200, 0.005))  # (vertices, Offset)


def make_cage(mesh, shape, vertices, **options):
    scenes.make_active(mesh)
    start = time.perf_counter()
    with session.quiet(), bpy.context.temp_override(active_object=mesh, object=mesh,
                                                    selected_objects=[mesh]):
        result = bpy.ops.object.gencoords_make_cage(shape=shape, target_vertices=vertices, **options)
    if result != {'FINISHED'}:
        raise RuntimeError(f"Make Cage returned {result}")
    return mesh.gencoords.cage, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vertices", type=int, default=200)
    parser.add_argument("--sweep", action="store_true")
    args = parser.parse_args()
    session.install_extension()
    print(f"Blender {bpy.app.version_string}; Make Cage with {args.vertices} vertices asked, "
          "default offsets (Convex: Margin 0.05, Tight: Offset 0.01 of the mesh's size)")
    print("| mesh, cage | mesh vertices | Make Cage | cage vertices | faces (quads) | "
          "volume / mesh's | mesh vertices inside | crossing face pairs |")
    print("|---|---:|---:|---:|---:|---:|---|---:|")
    for name in ("character", "suzanne"):
        for shape in ("CONVEX", "TIGHT"):
            mesh, artist = add_mesh(name)
            cage, seconds = make_cage(mesh, shape, args.vertices)
            print(row(mesh, cage, seconds, f"{name}, {shape.lower()}"), flush=True)
        if artist is not None:
            print(row(mesh, artist, None, f"{name}, the artist's box cage"), flush=True)
    for name in ("character", "suzanne") if args.sweep else ():
        for vertices, offset in SWEEP:
            mesh, _ = add_mesh(name)
            label = f"{name}, tight, {vertices} vertices, Offset {offset}"
            try:
                cage, seconds = make_cage(mesh, "TIGHT", vertices, offset=offset)
            except RuntimeError as error:  # a refusal: its message
                print(f"| {label} | {len(mesh.data.vertices)} | refused: {str(error).strip()} |||||", flush=True)
                continue
            print(row(mesh, cage, seconds, label), flush=True)


if __name__ == "__main__":
    main()
