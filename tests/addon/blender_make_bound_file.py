"""Subprocess: save a .blend with a mesh bound to a render-hidden cage animated by a
shape key, after deleting another object bound to that cage.

Frame 1 is the rest cage, frame 2 stretches it along x. The mesh's rest positions and
its evaluated positions at frame 2 go to an .npy file, (2, k, 3).
Usage: blender_make_bound_file.py BLEND NPY [KIND]  (the mesh's coordinate type, default MEAN_VALUE)
"""

import sys

import bpy
import numpy as np

from scene_helpers import (add_icosphere_cage, add_sphere, bind, evaluated_positions,
                           load_user_preferences, read_positions, write_shape_key)

blend_path, positions_path = sys.argv[1:3]
kind = sys.argv[3] if len(sys.argv) > 3 else "MEAN_VALUE"
load_user_preferences()
assert "bl_ext.user_default.gencoords" in bpy.context.preferences.addons
bpy.ops.wm.read_homefile(use_empty=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 2

cage = add_icosphere_cage()
cage.hide_render = True  # as artists do; renders must still follow its animation
cage.shape_key_add(name="Basis")
stretch = cage.shape_key_add(name="Stretch")
write_shape_key(stretch, read_positions(cage.data) * (1.6, 1.0, 1.0) + (0.8, 0, 0))
for frame, value in ((1, 0.0), (2, 1.0)):
    stretch.value = value
    stretch.keyframe_insert("value", frame=frame)

obj = add_sphere()
scene.frame_set(1)
assert bind(obj, cage, kind=kind) == {'FINISHED'}
deleted = add_sphere(radius=0.5, name="Deleted")
assert bind(deleted, cage) == {'FINISHED'}
bpy.data.objects.remove(deleted)  # its bind data must not be saved
scene.frame_set(2)
np.save(positions_path, np.stack([read_positions(obj.data), evaluated_positions(obj)]))

camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
camera.location = (0, -8, 0)
camera.rotation_euler = (np.pi / 2, 0, 0)
scene.camera = camera
scene.render.engine = 'CYCLES'
scene.cycles.device = 'CPU'
scene.cycles.samples = 1
scene.cycles.use_denoising = False
scene.render.film_transparent = True  # the mesh's pixels are the opaque ones, lit or not
scene.render.resolution_x = scene.render.resolution_y = 48
scene.render.image_settings.file_format = 'PNG'
scene.render.image_settings.color_mode = 'RGBA'
bpy.ops.wm.save_as_mainfile(filepath=blend_path)
