"""Subprocess: export the selected objects of a .blend with Blender's glTF exporter,
import the file into an empty scene with Blender's glTF importer and save that scene.

Usage: blender_gltf_round_trip.py BLEND GLB IMPORTED_BLEND
"""

import json
import sys

import bpy

blend_path, glb_path, imported_path = sys.argv[1:4]
bpy.ops.wm.open_mainfile(filepath=blend_path)
selected = sorted(o.name for o in bpy.context.selected_objects)
exported = bpy.ops.export_scene.gltf(filepath=glb_path, export_format='GLB', use_selection=True)
bpy.ops.wm.read_homefile(use_empty=True)
imported = bpy.ops.import_scene.gltf(filepath=glb_path)
bpy.ops.wm.save_as_mainfile(filepath=imported_path)
print("REPORT " + json.dumps({"exported": sorted(exported), "selected": selected,
                              "imported": sorted(imported)}), flush=True)
