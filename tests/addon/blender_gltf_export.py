"""Subprocess: export a .blend with Blender's glTF exporter, its default options but the
ones given (a JSON object of keyword arguments).

Usage: blender_gltf_export.py BLEND GLB OPTIONS_JSON
"""

import json
import sys

import bpy

blend_path, glb_path, options = sys.argv[1:4]
bpy.ops.wm.open_mainfile(filepath=blend_path)
exported = bpy.ops.export_scene.gltf(filepath=glb_path, export_format='GLB', **json.loads(options))
print("REPORT " + json.dumps({"exported": sorted(exported)}), flush=True)
