"""Bake to Bones, Fitted, on the character (issue 37 item 7): the ~43k-vertex body of
tests/fixtures/character.py bound to its cage (mean value, the default storage), the cage
animated over 40 frames (arms, legs and head, as bench_skin_fit.py moves them: a shape
key a frame), then the operator as a pipeline script calls it, defaults but the
influences. Printed: the bake's wall and CPU seconds, the fit's share, and the figures
it reports.

    .venv/bin/python scripts/benchmarks/bench_fitted_bake.py [--influences 4] [--detail 1.0]
"""

import argparse
import os
import sys
import time
from pathlib import Path

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
import bpy  # noqa: E402

from scripts.benchmarks.bench_skin_fit import character_motion  # noqa: E402
from scripts.common import scenes  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402

FRAMES = 40


def animated_character(detail):
    """The character bound to its cage, the cage keyed through ``character_motion``: a
    shape key a frame, on at its frame only. Returns the mesh."""
    scenes.reset_scene()
    mesh, cage = scenes.add_character(detail)
    with session.quiet():
        assert "FINISHED" in scenes.bind(mesh, cage, scenes.MEAN_VALUE)
    rest = arrays.read_positions(cage.data).astype(float)
    cage.shape_key_add(name="Basis")
    for frame, pose in enumerate(character_motion(rest, FRAMES), start=1):
        key = cage.shape_key_add(name=f"Frame {frame}")
        key.data.foreach_set("co", pose.astype("float32").ravel())
        for at in (frame - 1, frame, frame + 1):
            key.value = 1.0 if at == frame else 0.0
            key.keyframe_insert("value", frame=at)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.frame_set(1)
    return mesh


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--influences", type=int, default=4)
    parser.add_argument("--detail", type=float, default=1.0)
    args = parser.parse_args()
    session.install_extension()
    mesh = animated_character(args.detail)
    wall, cpu = time.perf_counter(), time.process_time()
    with bpy.context.temp_override(object=mesh, active_object=mesh, selected_objects=[mesh]), session.quiet():
        result = bpy.ops.object.gencoords_bake_bones(mode='FITTED', max_influences=args.influences)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    figures = mesh.parent.data["gencoords_bake"].to_dict()
    print(f"{len(mesh.data.vertices)} vertices, {FRAMES} frames, {args.influences} influences: {sorted(result)} "
          f"in {wall:.1f} s ({cpu:.1f} s CPU; the fit {figures['fit_seconds']:.1f} s), {figures['bones']} bones, "
          f"worst {100 * figures['worst']:.3f} %, RMS {100 * figures['rms']:.4f} % of the diagonal")


if __name__ == "__main__":
    main()
