"""Pictures the scripts render with Workbench: settings, an orthographic camera, colour
attributes, and PNGs read, written and put side by side."""

import math
from pathlib import Path

import bpy
import numpy as np

from .blender_objects import arrays
from .png import write_png
from .session import quiet
from mathutils import Vector


def setup_workbench(scene, width, height, lighting="STUDIO", color_type="MATERIAL",
                    background=(1.0, 1.0, 1.0)):
    """Workbench render settings for small, quick, colour-faithful pictures.

    ``Standard`` view transform so a grey of 0.5 in a colour attribute renders as
    sRGB 0.5 (Filmic/AgX would tone-map the paper-style grey scale).
    """
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.film_transparent = False
    scene.display.render_aa = "8"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    shading = scene.display.shading
    shading.light = lighting
    shading.color_type = color_type
    shading.show_cavity = False
    shading.show_shadows = False
    shading.show_object_outline = False
    scene.world.color = background
    return scene


def add_camera(target, azimuth, elevation, ortho_scale, distance=20.0, name="Camera"):
    """An orthographic camera looking at ``target`` from (azimuth, elevation) degrees."""
    az, el = math.radians(azimuth), math.radians(elevation)
    direction = Vector((math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)))
    camera = bpy.data.objects.new(name, bpy.data.cameras.new(name))
    bpy.context.scene.collection.objects.link(camera)
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = ortho_scale
    camera.data.clip_end = 4 * distance
    camera.location = Vector(target) + distance * direction
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    bpy.context.scene.camera = camera
    return camera


def camera_axes(camera):
    """World-space (right, up) unit vectors of the camera's image plane."""
    rotation = camera.rotation_euler.to_matrix()
    return np.array(rotation.col[0]), np.array(rotation.col[1])


def set_color_attribute(obj, colors, name="Color"):
    """Per-vertex (or one constant) linear RGBA colour that Workbench shows directly."""
    mesh = obj.data
    colors = np.asarray(colors, dtype=np.float32)
    if colors.ndim == 1:
        colors = np.tile(colors, (len(mesh.vertices), 1))
    attribute = mesh.color_attributes.get(name) or mesh.color_attributes.new(
        name, "FLOAT_COLOR", "POINT")
    arrays.write_point_colors(attribute, colors)
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.find(name)
    return attribute


def wireframe(cage):
    """A render-only copy of ``cage`` as thin struts (Workbench draws no wireframes; a
    Wireframe modifier on the cage itself would change what the deformers read)."""
    copy = bpy.data.objects.new(f"{cage.name} wire", cage.data.copy())
    copy.location = cage.location
    bpy.context.scene.collection.objects.link(copy)
    modifier = copy.modifiers.new("Wire", 'WIREFRAME')
    modifier.thickness, modifier.use_replace = 0.008, True
    return copy


def render(path):
    """Render the scene's camera view to ``path`` (PNG)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.context.scene.render.filepath = str(path)
    with quiet():
        bpy.ops.render.render(write_still=True)
    return path


def load_png(path):
    """A PNG as an ``(h, w, 4)`` float array of its stored bytes / 255 (rows bottom-up)."""
    image = bpy.data.images.load(str(path), check_existing=False)
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    return pixels.reshape(height, width, 4)


def side_by_side(paths, target, gap=8):
    """Concatenate same-height PNGs left to right with a white gap, into ``target``."""
    images = [load_png(p) for p in paths]
    height = max(image.shape[0] for image in images)
    spacer = np.ones((height, gap, 4), dtype=np.float32)
    parts = []
    for image in images:
        padded = np.ones((height, image.shape[1], 4), dtype=np.float32)
        padded[height - image.shape[0]:] = image  # rows are bottom-up: align tops
        parts.extend([padded, spacer])
    return Path(write_png(target, np.concatenate(parts[:-1], axis=1)[::-1]))  # rows top-down
