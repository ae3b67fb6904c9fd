"""Subprocess: render a saved animation like a farm worker, print per-frame results as JSON.

Records the bound mesh's x extent each rendered frame (its evaluated mesh in the render
depsgraph) and the opaque pixels of each rendered image (the background is transparent).
Works with and without the extension installed.
Usage: blender_render_file.py BLEND OUTPUT_DIR
"""

import json
import sys
from pathlib import Path

import bpy
import numpy as np

from scene_helpers import load_user_preferences, read_positions

blend_path, output_dir = sys.argv[1:3]
load_user_preferences()
bpy.ops.wm.open_mainfile(filepath=blend_path)
scene = bpy.context.scene
widths = {}


def record_width(scene, depsgraph):
    if depsgraph.mode != 'RENDER':  # the viewport re-evaluates once rendering ends
        return
    x = read_positions(bpy.data.objects["Mesh"].evaluated_get(depsgraph).data)[:, 0]
    widths[scene.frame_current] = float(x.max() - x.min())


bpy.app.handlers.frame_change_post.append(record_width)
scene.render.filepath = str(Path(output_dir) / "frame_")
bpy.ops.render.render(animation=True)
covered_pixels = {}
for frame in (1, 2):
    image = bpy.data.images.load(str(Path(output_dir) / f"frame_{frame:04d}.png"))
    pixels = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(pixels)
    covered_pixels[frame] = int(np.count_nonzero(pixels.reshape(-1, 4)[:, 3] > 0.5))
print("REPORT " + json.dumps({
    "widths": widths,
    "covered_pixels": covered_pixels,
}), flush=True)
