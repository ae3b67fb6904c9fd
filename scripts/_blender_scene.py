"""Scene-building helpers shared by ``demo.py`` and ``bench_blender.py``.

One piece of code per idea: both scripts build the same subdivided Suzanne inside the same
icosphere cage, install the extension the same way and read positions back the same way,
so the demo's pictures and the benchmark's numbers describe the same thing.

Importing this module imports ``bpy``; it first points Blender's user folder at a
throw-away directory so installing the extension never touches the user's own Blender
configuration (Blender reads ``BLENDER_USER_RESOURCES`` once, when ``bpy`` is imported).
"""

import atexit
import contextlib
import importlib
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "out"
DOCS = REPO / "docs"
DIST = REPO / "dist"

# `import core` must work from scripts/ without installing anything.
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

if "bpy" in sys.modules:  # pragma: no cover - only when run inside a Blender session
    USER_RESOURCES = None
else:
    USER_RESOURCES = tempfile.mkdtemp(prefix="gencoords-blender-user-")
    os.environ["BLENDER_USER_RESOURCES"] = USER_RESOURCES
    atexit.register(shutil.rmtree, USER_RESOURCES, True)

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import core  # noqa: E402
from mathutils import Euler, Vector  # noqa: E402

# Suzanne's subdivision level -> vertex count (primitive_monkey_add, size 2, applied
# Catmull-Clark): the benchmark's three mesh sizes.
SUZANNE_VERTICES = {2: 7958, 3: 31658, 4: 126_218}
# Icosphere subdivisions -> cage vertex count.
ICOSPHERE_VERTICES = {2: 42, 3: 162, 4: 642}
# Suzanne (size 2) reaches 1.45 from the origin; an icosphere of radius 2 has an
# inscribed radius above 1.85 from 42 vertices on, so it contains every vertex.
CAGE_RADIUS = 2.0

KINDS = core.KINDS
KIND_LABELS = {kind.name: kind.label for kind in core.KIND_TABLE}


# --------------------------------------------------------------------------- extension


def _newest_source_time():
    """Latest modification time of anything that goes into the extension zip."""
    paths = [REPO / "blender_manifest.toml", REPO / "scripts" / "build_extension.py"]
    for folder in ("core", "gencoords_addon"):
        paths.extend((REPO / folder).rglob("*"))
    return max((p.stat().st_mtime for p in paths if p.is_file()), default=0.0)


def extension_zip(rebuild_if_stale=True):
    """Path of the built extension zip, building it first when missing or stale.

    ``make demo`` does not depend on ``make build``, so a demo run after editing the
    add-on would otherwise silently show the old zip's behaviour.
    """
    zips = sorted(DIST.glob("gencoords-*.zip"), key=lambda p: p.stat().st_mtime)
    if zips and not (rebuild_if_stale and zips[-1].stat().st_mtime < _newest_source_time()):
        return zips[-1]
    print("building the extension: scripts/build_extension.py", flush=True)
    subprocess.run([sys.executable, str(REPO / "scripts" / "build_extension.py")],
                   cwd=REPO, check=True)
    zips = sorted(DIST.glob("gencoords-*.zip"), key=lambda p: p.stat().st_mtime)
    if not zips:
        raise RuntimeError("scripts/build_extension.py wrote no dist/gencoords-*.zip")
    return zips[-1]


def install_extension():
    """Install and enable the built extension in this (throw-away) Blender profile.

    Returns the zip installed. Raises if the add-on's operators do not appear, so a
    broken package fails here with a clear message rather than later in a bind.
    """
    zip_path = extension_zip()
    with quiet():
        result = bpy.ops.extensions.package_install_files(
            filepath=str(zip_path), repo="user_default", enable_on_install=True)
    if "FINISHED" not in result or not hasattr(bpy.types.Object, "gencoords"):
        raise RuntimeError(f"installing {zip_path} did not register Object.gencoords ({result})")
    return zip_path


def addon_module(submodule):
    """A module of the installed add-on, e.g. ``addon_module("binding")``: the figures its
    panel shows (smallest coordinate, ...) come from there."""
    for name in bpy.context.preferences.addons.keys():
        if name.split(".")[-1] == "gencoords":
            return importlib.import_module(f"{name}.gencoords_addon.{submodule}")
    raise RuntimeError("the gencoords extension is not enabled")


# ------------------------------------------------------------------------------ scenes


def reset_scene():
    """An empty scene, keeping enabled add-ons (``read_factory_settings`` would not)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    if scene.world is None:  # Workbench takes its background from the world colour
        scene.world = bpy.data.worlds.new("World")
    return scene


def add_suzanne(level=2, name="Suzanne"):
    """Suzanne with ``level`` Catmull-Clark subdivisions applied (7958 vertices at 2)."""
    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    if level:
        modifier = obj.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = modifier.render_levels = level
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    bpy.ops.object.shade_smooth()
    return obj


MILLION_VERTICES = 999_547  # the large-mesh scene: a 1000 x 1000 UV sphere


def add_benchmark_mesh(level):
    """Suzanne subdivided ``level`` times, or (``None``) the million-vertex UV sphere,
    which a radius-2 icosphere cage contains like Suzanne."""
    if level is None:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=1000, ring_count=1000, radius=1.4)
        return bpy.context.active_object
    return add_suzanne(level)


def add_icosphere_cage(subdivisions=2, radius=CAGE_RADIUS, name="Cage"):
    """A convex icosphere cage (42, 162, 642 vertices at 2, 3, 4), drawn as a wireframe."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=radius)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    obj.display_type = "WIRE"  # the bound mesh stays visible inside it in the viewport
    return obj


def add_fitted_cage(mesh, subdivisions=2, margin=1.08, name="Cage"):
    """A snug convex cage: an icosphere stretched into an ellipsoid around ``mesh``.

    The axis radii follow the mesh's bounding box; then the whole cage is scaled until
    every mesh vertex is inside every face plane, times ``margin``. Scaling keeps it
    convex. A snug cage makes the mesh follow cage edits visibly (a loose one smooths
    them out), which is what the demo wants to show.
    """
    points = positions(mesh) @ np.array(mesh.matrix_world)[:3, :3].T + np.array(
        mesh.matrix_world.translation)
    centre = 0.5 * (points.max(axis=0) + points.min(axis=0))
    radii = 0.5 * (points.max(axis=0) - points.min(axis=0))
    cage = add_icosphere_cage(subdivisions, radius=1.0, name=name)
    unit = positions(cage)
    faces = triangles(cage)
    # For the unit icosphere P: x is inside diag(radii) * P iff x / radii is inside P.
    a, b, c = (unit[faces[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    offsets = np.einsum("ij,ij->i", normals, a)  # > 0: the origin is inside
    scaled = (points - centre) / radii
    needed = (scaled @ normals.T / offsets).max()  # scale that puts every point inside
    set_positions(cage, centre + unit * radii * needed * margin)
    return cage


def add_mesh_object(name, vertices, faces=(), edges=(), collection=None):
    """A mesh object from arrays, linked to ``collection`` (the scene's by default)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(vertices, dtype=float).tolist(),
                     [tuple(e) for e in np.asarray(edges, dtype=int).reshape(-1, 2)],
                     [tuple(f) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def make_active(obj):
    """Select ``obj`` alone and make it active: what the bind operators act on."""
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


# --------------------------------------------------------------------------- polyhedra


def octahedron(regular=True):
    """The two octahedra of the paper's figures 9 and 10: ``(vertices, faces)``.

    Vertex 0 (+x, on the "equator") is the vertex ``v`` whose coordinate the figures
    plot. The regular one has its vertices on the unit sphere; the irregular one is a
    convex double pyramid over a planar convex quadrilateral, its apexes leaning off
    axis, so no sphere passes through its vertices.
    """
    if regular:
        vertices = np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0],
                             [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
    else:
        vertices = np.array([[1.25, 0.15, 0.0], [-0.1, 0.95, 0.0], [-0.85, -0.1, 0.0],
                             [0.2, -0.8, 0.0], [0.3, 0.15, 1.1], [-0.25, -0.1, -0.8]])
    ring = [0, 1, 2, 3]
    faces = [(ring[i], ring[(i + 1) % 4], apex)
             for apex in (4, 5) for i in range(4)]
    return vertices, core.orient_facets_outward(vertices, faces)


# --------------------------------------------------------------------------- positions


def positions(obj):
    """Vertex positions of a mesh object (local coordinates) as a ``(n, 3)`` float64 array."""
    mesh = obj.data
    flat = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", flat)
    return flat.reshape(-1, 3).astype(np.float64)


def set_positions(obj, points):
    """Write vertex positions of a mesh object and tag it so the depsgraph re-evaluates."""
    obj.data.vertices.foreach_set("co", np.asarray(points, dtype=np.float32).ravel())
    obj.data.update()


def triangles(obj):
    """Triangles of a mesh object as ``(m, 3)`` int, winding kept (outward for a cage)."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    flat = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", flat)
    return flat.reshape(-1, 3).astype(np.int64)


def evaluated_positions(obj, depsgraph=None, out=None):
    """Positions of the evaluated (deformed) mesh, read the same way for every method."""
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(depsgraph).data
    if out is None:
        out = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    # The position attribute: 35 times faster than ``vertices`` (2 ms for a million).
    mesh.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3)


def cage_size(points):
    """Length of the cage's bounding-box diagonal: the scale errors are reported against."""
    points = np.asarray(points)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


# --------------------------------------------------------------------------- cage edits


def nonaffine_edit(rest):
    """The demo's cage edit: pull the upper vertices up and twist them about the z axis.

    Height-dependent stretch and twist, so no affine map reproduces it and the mesh
    actually has to interpolate.
    """
    rest = np.asarray(rest, dtype=float)
    z = rest[:, 2]
    t = np.clip((z - z.min()) / max(z.max() - z.min(), 1e-12), 0.0, 1.0)  # 0 bottom, 1 top
    lift = np.maximum(t - 0.45, 0.0) ** 2 * 1.6 * (z.max() - z.min()) / 2.0
    angle = np.radians(75.0) * np.maximum(t - 0.3, 0.0)
    cos, sin = np.cos(angle), np.sin(angle)
    edited = rest.copy()
    edited[:, 0] = cos * rest[:, 0] - sin * rest[:, 1]
    edited[:, 1] = sin * rest[:, 0] + cos * rest[:, 1]
    edited[:, 2] = z + lift
    return edited


def affine_map(points):
    """A fixed general affine map (rotation, anisotropic scale, shear, translation).

    Exact coordinates reproduce it exactly on the bound mesh: the accuracy check.
    """
    matrix = (np.array(Euler((0.3, -0.2, 0.5)).to_matrix())
              @ np.array([[1.2, 0.25, 0.0], [0.0, 0.8, 0.1], [0.0, 0.0, 1.1]]))
    return np.asarray(points, dtype=float) @ matrix.T + np.array([0.3, -0.2, 0.15])


# --------------------------------------------------------------------------- rendering


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
    attribute.data.foreach_set("color", colors.ravel())
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.find(name)
    return attribute


@contextlib.contextmanager
def quiet():
    """Silence Blender's own console lines (render progress, headless EGL warnings,
    operator reports) for the block; failures still raise in Python with their message."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        os.dup2(null.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


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


def save_png(path, pixels):
    """Write an ``(h, w, 4)`` array (as returned by ``load_png``) to a PNG file."""
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    height, width = pixels.shape[:2]
    image = bpy.data.images.new(Path(path).stem, width, height, alpha=True)
    image.pixels.foreach_set(pixels.ravel())
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)
    return Path(path)


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
    return save_png(target, np.concatenate(parts[:-1], axis=1))
