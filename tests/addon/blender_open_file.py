"""Subprocess: open a file saved by blender_make_bound_file.py and print checks as JSON.

Works with and without the extension installed. Usage: blender_open_file.py BLEND NPY
"""

import json
import sys

import bpy
import numpy as np

from scene_helpers import (evaluated_cage_positions, load_user_preferences, positions,
                           set_positions, update)

blend_path, positions_path = sys.argv[1:3]
load_user_preferences()
bpy.ops.wm.open_mainfile(filepath=blend_path)
obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]
saved = np.load(positions_path)
report = {
    "enabled": "bl_ext.user_default.gencoords" in bpy.context.preferences.addons,
    "kept_saved_shape": bool(np.array_equal(positions(obj.data), saved)),
    "bind_data_texts": sorted(text.name for text in bpy.data.texts
                              if text.name.startswith(".GenCoords bind data")),
}
bpy.context.scene.frame_set(1)
if report["enabled"]:
    from bl_ext.user_default.gencoords.gencoords_addon import status, storage

    data = storage.load(obj)
    report["status"] = [text for text, _ in status.status_lines(obj)]
    rest_error = np.abs(positions(obj.data) - data.rest_positions).max()
    report["rest_error_at_frame_1"] = float(rest_error)
    cage.active_shape_key_index = 0
    set_positions(cage.data, positions(cage.data) * 1.25)
    update()
    expected = data.coordinates @ evaluated_cage_positions(cage)
    report["follows_exactly"] = bool(np.array_equal(positions(obj.data), expected))
else:
    set_positions(cage.data, positions(cage.data) * 1.25)
    update()
    report["unchanged_after_edits"] = bool(np.array_equal(positions(obj.data), saved))
print("REPORT " + json.dumps(report))
