"""The README's quad picture: one non-planar edit of a six-quad box cage, the mesh bound
with mean value split along one diagonal, along the other, and with Quad Mean Value.

A sphere in a box cage of six quads, three times: bound with Mean Value as the quads are
listed (each split along its first diagonal), with Mean Value with each quad's corners
listed one position later (the other diagonal), and with Quad Mean Value; each cage's
top corner then dragged up and out (three quads no longer planar), rendered with
Workbench, the cage in wireframe. Prints how far each mesh lies from the quad-native one.

    .venv/bin/python scripts/pictures/quad_split.py [--out docs/quad_split.png]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
import bpy  # noqa: E402

from scripts.common import pictures, scenes  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from gencoords import MEAN_VALUE_QUADS  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402

BOX = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
# Outward, counter-clockwise seen from outside (vertex index = 4 x + 2 y + z, each 0 or 1).
QUADS = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
CORNER, DRAG = 7, np.array([0.5, 0.5, 1.1])  # the top corner at (1, 1, 1), dragged up and out
COLUMNS = (("Mean value, split one way", MEAN_VALUE, 0), ("Mean value, split the other way", MEAN_VALUE, 1),
           ("Quad Mean Value", MEAN_VALUE_QUADS, 0))
SPACING = 3.6
BODY = (0.80, 0.80, 0.82, 1.0)
CAGE = (0.15, 0.35, 0.85, 1.0)


def sphere(name, x):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, segments=48, ring_count=24, location=(x, 0.0, 0.0))
    obj = bpy.context.active_object
    obj.name = name
    return obj


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(session.OUT / "quad_split.png"))
    args = parser.parse_args()
    session.install_extension()
    scenes.reset_scene()
    meshes = []
    for column, (name, kind, shift) in enumerate(COLUMNS):
        x = (column - 1) * SPACING
        cage = scenes.add_mesh_object(f"Cage {column}", BOX + [x, 0.0, 0.0], np.roll(QUADS, -shift, axis=1))
        cage.hide_render = True
        mesh = sphere(f"Sphere {column}", x)
        with session.quiet():
            if "FINISHED" not in scenes.bind(mesh, cage, kind):
                raise RuntimeError(f"{name} did not bind")
        bent = BOX + [x, 0.0, 0.0]
        bent[CORNER] += DRAG
        arrays.write_positions(cage.data, bent)
        pictures.set_color_attribute(mesh, BODY)
        pictures.set_color_attribute(pictures.wireframe(cage), CAGE)
        meshes.append(mesh)
    bpy.context.view_layer.update()
    shapes = [arrays.evaluated_positions(mesh).astype(np.float64) for mesh in meshes]  # each in its own space
    size = scenes.cage_size(BOX)
    for (name, _, _), shape in zip(COLUMNS, shapes):
        print(f"{name:32s} farthest from the quad-native mesh: {np.abs(shape - shapes[2]).max() / size:.3f} "
              "of the cage's diagonal")
    pictures.setup_workbench(bpy.context.scene, 1500, 640, lighting="STUDIO", color_type="VERTEX")
    pictures.add_camera((0.15, 0.0, 0.55), azimuth=-80, elevation=12, ortho_scale=3.05 * SPACING)
    path = pictures.render(Path(args.out))
    print(f"wrote {path} ({', '.join(name for name, _, _ in COLUMNS)}, left to right)")


if __name__ == "__main__":
    main()
