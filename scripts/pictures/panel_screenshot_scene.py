"""The scene of the panel screenshots, built and bound headless with pip bpy:
``panel_screenshot_scene.py <folder>`` writes <folder>/unbound.blend, bound.blend and
field.blend.

Suzanne (one subdivision) in a fitted 42-vertex cage, picked as its cage; bound.blend
is the same scene bound with mean value coordinates through the installed extension,
field.blend also shows the coordinate field of cage vertex ``FIELD_VERTEX``.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
from scripts.common import scenes  # noqa: E402
import bpy  # noqa: E402

FIELD_VERTEX = 7  # a cage vertex in front of Suzanne's face: a field clearly visible


def save(path):
    with session.quiet():
        bpy.ops.wm.save_as_mainfile(filepath=str(path))


def main():
    folder = Path(sys.argv[1])
    folder.mkdir(parents=True, exist_ok=True)
    session.install_extension()
    scenes.reset_scene()
    mesh = scenes.add_suzanne(level=1)
    cage = scenes.add_fitted_cage(mesh, subdivisions=2)
    mesh.gencoords.cage = cage
    scenes.make_active(mesh)
    save(folder / "unbound.blend")
    with session.quiet():
        bpy.ops.object.gencoords_bind()
    save(folder / "bound.blend")
    mesh.gencoords.field_vertex = FIELD_VERTEX
    bpy.ops.object.gencoords_show_field()
    save(folder / "field.blend")
    print(f"{folder}/unbound.blend, bound.blend, field.blend")


if __name__ == "__main__":
    main()
