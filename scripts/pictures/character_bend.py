"""The README's character picture: Mesh Deform, mean value and harmonic coordinates side by
side under the same bend of the left forearm's cage (60 degrees about the elbow).

The artist's character (``tests/fixtures/character.py``: a 43k-vertex body in a
box-modelled, non-convex quad cage of 196 vertices) three times, each bound by one method
through its own operator (Mesh Deform at precision 5; GenCoords mean value and harmonic,
Automatic storage), each cage's forearm bent the same way, rendered from the front with
Workbench; the cage in wireframe. Also prints each method's triangle-angle change in the
left arm (mean and 99th percentile, degrees) and how far the other limbs moved.

    .venv/bin/python scripts/pictures/character_bend.py [--out docs/character_bend.png]
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
from tests.fixtures import character  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
from gencoords.surfaces.named import MEAN_VALUE  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402

METHODS = (("Mesh Deform p5", ("MESH_DEFORM", 5)), ("Mean value", ("GENCOORDS", MEAN_VALUE)),
           ("Harmonic", ("GENCOORDS", HARMONIC)))
SPACING = 2.3  # metres between the characters (the arms span 1.9)
BODY = (0.80, 0.80, 0.82, 1.0)
CAGE = (0.15, 0.35, 0.85, 1.0)


def bind(mesh, cage, method):
    """Bind ``mesh`` to ``cage`` with Mesh Deform (precision) or GenCoords (kind)."""
    scenes.make_active(mesh)
    with session.quiet():
        if method[0] == "MESH_DEFORM":
            modifier = mesh.modifiers.new("MeshDeform", 'MESH_DEFORM')
            modifier.object, modifier.precision = cage, method[1]
            with bpy.context.temp_override(active_object=mesh, object=mesh, selected_objects=[mesh]):
                bpy.ops.object.meshdeform_bind(modifier=modifier.name)
            ok = modifier.is_bound
        else:
            ok = "FINISHED" in scenes.bind(mesh, cage, method[1], storage='AUTO')
    if not ok:
        raise RuntimeError(f"{method} did not bind")


def arm_angle_change(rest, bent, triangles, labels):
    """The left arm's triangle angle changes: (mean, 99th percentile) in degrees."""
    arm = triangles[(labels[triangles] == "left_arm").all(axis=1)]

    def angles(points):
        corners = points[arm]
        found = []
        for c in range(3):
            a, b = corners[:, (c + 1) % 3] - corners[:, c], corners[:, (c + 2) % 3] - corners[:, c]
            cosine = (a * b).sum(1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
            found.append(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))
        return np.stack(found, axis=1)

    change = np.abs(angles(bent) - angles(rest)).ravel()
    return float(change.mean()), float(np.percentile(change, 99))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(session.OUT / "character_bend.png"))
    args = parser.parse_args()
    session.install_extension()
    scenes.reset_scene()
    _, triangles, labels = character.body_mesh()
    rest_cage, _ = character.character_cage()
    bent_cage, _ = character.bent_forearm(rest_cage, 60.0)
    size = scenes.cage_size(rest_cage)
    others = np.isin(labels, ("right_arm", "left_leg", "right_leg", "head"))
    shown = []
    for column, (name, method) in enumerate(METHODS):
        mesh, cage = scenes.add_character()
        for obj in (mesh, cage):
            obj.location.x = (column - 1) * SPACING
        cage.display_type, cage.hide_render = 'WIRE', True
        bind(mesh, cage, method)
        rest = arrays.evaluated_positions(mesh).astype(np.float64)
        arrays.write_positions(cage.data, bent_cage)
        bpy.context.view_layer.update()
        bent = arrays.evaluated_positions(mesh).astype(np.float64)
        mean, p99 = arm_angle_change(rest, bent, triangles, labels)
        moved = np.linalg.norm(bent[others] - rest[others], axis=1).max() / size
        print(f"{name:15s} left arm angle change: mean {mean:.2f}, 99th percentile {p99:.1f} degrees; "
              f"other limbs moved {moved:.1e} of the cage's diagonal")
        pictures.set_color_attribute(mesh, BODY)
        pictures.set_color_attribute(pictures.wireframe(cage), CAGE)
        shown.append(name)
    scene = bpy.context.scene
    pictures.setup_workbench(scene, 1500, 560, lighting="STUDIO", color_type="VERTEX")
    pictures.add_camera((0.0, 0.0, 1.0), azimuth=-75, elevation=15, ortho_scale=3 * SPACING)
    path = pictures.render(Path(args.out))
    print(f"wrote {path} ({', '.join(shown)}, left to right)")


if __name__ == "__main__":
    main()
