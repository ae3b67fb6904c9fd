"""Subprocess: export the selected objects of a .blend with Blender's glTF exporter.

Usage: blender_export_gltf.py BLEND GLB
"""

import json
import sys

import bpy

blend_path, glb_path = sys.argv[1:3]
bpy.ops.wm.open_mainfile(filepath=blend_path)
result = bpy.ops.export_scene.gltf(filepath=glb_path, export_format='GLB', use_selection=True)
print("REPORT " + json.dumps({"result": sorted(result),
                              "selected": sorted(o.name for o in bpy.context.selected_objects)}),
      flush=True)
