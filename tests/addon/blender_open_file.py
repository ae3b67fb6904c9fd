"""Subprocess: open a file saved by blender_make_bound_file.py and print checks as JSON.

Works with and without the extension installed: the deformation is Blender's own
evaluation of the saved modifier. Usage: blender_open_file.py BLEND NPY
"""

import json
import sys

import bpy
import numpy as np

from scene_helpers import evaluated_positions, load_user_preferences, read_positions, write_shape_key

blend_path, positions_path = sys.argv[1:3]
load_user_preferences()
bpy.ops.wm.open_mainfile(filepath=blend_path)
obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]
rest, stretched = np.load(positions_path)
scene = bpy.context.scene
report = {
    "enabled": "bl_ext.user_default.gencoords" in bpy.context.preferences.addons,
    "mesh_data_is_rest": bool(np.array_equal(read_positions(obj.data), rest)),
    "node_groups": sorted(group.name for group in bpy.data.node_groups),
    "meshes": sorted(mesh.name for mesh in bpy.data.meshes),
}
scene.frame_set(2)
report["frame_2_as_saved"] = bool(np.array_equal(evaluated_positions(obj), stretched))
scene.frame_set(1)
report["frame_1_is_rest"] = bool(np.array_equal(evaluated_positions(obj), rest))
if report["enabled"]:
    from bl_ext.user_default.gencoords.gencoords_addon.ui import status

    report["status"] = [text for text, _ in status.status_lines(obj)]
basis = cage.data.shape_keys.key_blocks["Basis"]  # an edit after reopening
write_shape_key(basis, read_positions(cage.data) * 1.25)
cage.data.update()
report["follows_an_edit"] = float(np.abs(evaluated_positions(obj) - rest * 1.25).max())
print("REPORT " + json.dumps(report), flush=True)
