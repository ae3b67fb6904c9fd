"""GenCoords demo, headless: ``make demo`` (or ``.venv/bin/python scripts/demo/demo.py``).

1. Binds a subdivided Suzanne (7958 vertices) to a convex icosphere cage with each of the
   four coordinate types through the installed extension, checks that an affine cage
   motion moves the mesh exactly, and renders the mesh before and after a non-affine
   cage edit (out/before.png, out/after_<kind>.png, out/demo.png).
2. Renders the paper's figures 9 and 10: each type's coordinate field for one vertex v of
   a regular and an irregular octahedron, on three cross-sections (out/fields.png).
   ``--update-docs`` copies out/demo.png, out/fields.png, out/artist.png and
   out/green.png to docs/ for the README.
3. Makes a cage with Make Cage and deforms the mesh with two cages at once
   (out/artist.png); stretches the cage 1.6x with mean value and with Green coordinates
   and measures how much the mesh's triangle angles change (out/green.png).
4. Saves out/demo.blend: Suzanne bound to the cage (mean value), the cage animated by a
   keyframed shape key, ready to play in Blender with the extension installed.

Runs in well under two minutes on two cores.
"""

import argparse
import shutil
import time

import numpy as np

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported: Blender reads its user folder then
from scripts.common import measures, pictures  # noqa: E402
from scripts.common import scenes  # noqa: E402
import bpy  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402
import gencoords  # noqa: E402
import gencoords.cages.shapes  # noqa: E402  (not imported by core itself)

ADDON_KINDS = {kind: kind.upper() for kind in scenes.KINDS}  # "mean_value" -> 'MEAN_VALUE'

INK = (0.05, 0.05, 0.05, 1.0)  # labels and octahedron edges
ACCENT = (0.85, 0.1, 0.05, 1.0)  # the vertex v
SECTION_TINT = (0.62, 0.72, 0.85, 1.0)  # cutting planes in the "polyhedron" panel


# ------------------------------------------------------------------ figures 9 and 10


def section_polygon(vertices, faces, height):
    """Corners (counter-clockwise from above) of the convex polyhedron's section z = height."""
    edges = {tuple(sorted((f[i], f[(i + 1) % 3]))) for f in faces for i in range(3)}
    offset = vertices[:, 2] - height
    corners = [vertices[i] for i in range(len(vertices)) if abs(offset[i]) < 1e-12]
    for a, b in edges:
        if offset[a] * offset[b] < 0:  # the edge crosses the plane strictly
            s = offset[a] / (offset[a] - offset[b])
            corners.append(vertices[a] + s * (vertices[b] - vertices[a]))
    corners = np.array(corners)
    centre = corners.mean(axis=0)
    order = np.argsort(np.arctan2(corners[:, 1] - centre[1], corners[:, 0] - centre[0]))
    return corners[order]


def fan_grid(polygon, segments):
    """A fine triangle mesh of a convex polygon: each fan triangle (centre, a, b) split
    into ``segments``^2 small triangles, so vertex colours resolve the field smoothly.

    Points are pulled 0.1% towards the centre: boundary and vertex points are limits of
    the formulas, and the picture needs no more than what the interior shows.
    """
    centre = polygon.mean(axis=0)
    polygon = centre + (1.0 - 1e-3) * (polygon - centre)
    index = {}
    for i in range(segments + 1):
        for j in range(segments + 1 - i):
            index[i, j] = len(index)
    local = np.array(list(index), dtype=float) / segments  # (i, j) -> weights of a and b
    small = []
    for i in range(segments):
        for j in range(segments - i):
            small.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if i + j < segments - 1:
                small.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    small = np.array(small)
    points, faces = [], []
    for k in range(len(polygon)):
        a, b = polygon[k], polygon[(k + 1) % len(polygon)]
        faces.append(small + len(points) * len(local))
        points.append(centre + local[:, :1] * (a - centre) + local[:, 1:] * (b - centre))
    return np.concatenate(points), np.concatenate(faces)


def add_label(text, location, camera, size=0.32):
    """Dark text facing the camera, converted to a mesh so it can carry a colour attribute."""
    curve = bpy.data.curves.new(f"Label {text}", "FONT")
    curve.body = text
    curve.align_x, curve.align_y = "CENTER", "CENTER"
    curve.size = size
    obj = bpy.data.objects.new(curve.name, curve)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = location
    obj.rotation_euler = camera.rotation_euler
    scenes.make_active(obj)
    bpy.ops.object.convert(target="MESH")
    obj = bpy.context.active_object
    pictures.set_color_attribute(obj, INK)  # shown when Workbench colours by attribute
    obj.color = INK  # ... and when it colours by object
    return obj


def add_outline(polygon, height, location):
    """A thin dark frame around a drawn section, so light regions keep a visible edge."""
    polygon = np.column_stack([polygon[:, :2], np.full(len(polygon), height)])
    obj = scenes.add_mesh_object("outline", polygon, [range(len(polygon))])
    obj.location = location
    wire = obj.modifiers.new("Edge", "WIREFRAME")
    wire.thickness, wire.use_even_offset = 0.02, True
    pictures.set_color_attribute(obj, INK)
    return obj


def render_fields(path, segments=48):
    """Figures 9 and 10 in one Workbench render: rows regular / irregular octahedron,
    columns the octahedron with its cutting planes, then one panel per coordinate type.

    The three horizontal sections of each panel are drawn apart (exploded) so none hides
    another; one grey scale per panel (``gencoords.reports.field_colors`` over all three sections).
    Returns ``{(octahedron, kind): min coordinate of v}`` for the summary.
    """
    scene = scenes.reset_scene()
    width, height = 1400, 780
    pictures.setup_workbench(scene, width, height, lighting="FLAT", color_type="VERTEX")
    panel_w, panel_h, title_h = 3.0, 3.75, 0.55
    frame_h = 5 * panel_w * height / width
    camera = pictures.add_camera((0, 0, 0), azimuth=-62, elevation=35, ortho_scale=5 * panel_w)
    right, up = pictures.camera_axes(camera)
    # centre of panel (row 0, col 0): below the title strip at the top of the frame
    top_left = -2.0 * panel_w * right + (frame_h / 2 - title_h - panel_h / 2) * up
    spacing = 1.35  # exploded distance between drawn sections: far enough not to overlap

    def panel_origin(row, col):
        return top_left + col * panel_w * right - row * panel_h * up

    minima = {}
    for row, regular in enumerate((True, False)):
        vertices, faces = gencoords.cages.shapes.octahedron() if regular else gencoords.cages.shapes.irregular_octahedron()
        vertices = vertices - vertices.mean(axis=0)  # centre each panel's content
        top, bottom = vertices[:, 2].max(), vertices[:, 2].min()
        heights = (0.45 * top, 0.0, 0.45 * bottom)
        # The equator (z = 0) holds v (vertex 0) of both octahedra by construction.
        sections = [section_polygon(vertices, faces, h) for h in heights]
        name = "regular" if regular else "irregular"

        # Column 0: the polyhedron, its cutting planes and v.
        origin = panel_origin(row, 0) + 0.3 * up
        frame = scenes.add_mesh_object(f"{name} octahedron", vertices, faces)
        frame.location = origin
        wire = frame.modifiers.new("Edges", "WIREFRAME")
        wire.thickness, wire.use_relative_offset = 0.035, True
        pictures.set_color_attribute(frame, INK)
        for polygon in sections:
            plane = scenes.add_mesh_object(f"{name} cut", polygon, [range(len(polygon))])
            plane.location = origin
            pictures.set_color_attribute(plane, SECTION_TINT)
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.09, location=origin + vertices[0])
        pictures.set_color_attribute(bpy.context.active_object, ACCENT)
        add_label("v", origin + vertices[0] + 0.3 * right + 0.15 * up, camera)
        caption = "vertices on a sphere\n(fig. 9)" if regular else "irregular\n(fig. 10)"
        add_label(caption, panel_origin(row, 0) - 1.45 * up, camera, size=0.26)

        # Columns 1-4: the coordinate of v on the sections, one type each.
        grids = [fan_grid(polygon, segments) for polygon in sections]
        points = np.concatenate([g[0] for g in grids])
        for col, kind in enumerate(scenes.KINDS, start=1):
            values = gencoords.coordinates(points, vertices, faces, kind=kind)[:, 0]
            minima[name, kind] = float(values.min())
            colors = gencoords.reports.field_colors(values)
            start = 0
            for level, (grid_points, grid_faces) in enumerate(grids):
                drawn = grid_points.copy()
                drawn[:, 2] = (1 - level) * spacing  # exploded: top, middle, bottom
                obj = scenes.add_mesh_object(f"{name} {kind} {level}", drawn, grid_faces)
                obj.location = panel_origin(row, col)
                pictures.set_color_attribute(obj, colors[start:start + len(grid_points)])
                start += len(grid_points)
                add_outline(sections[level], drawn[0, 2], panel_origin(row, col))
    for col, title in enumerate(["polyhedron"] + [scenes.KIND_LABELS[k] for k in scenes.KINDS]):
        add_label(title, panel_origin(0, col) + (panel_h + title_h) / 2 * up, camera)
    pictures.render(path)
    return minima


# ---------------------------------------------------------------------- deformation

SKIN = (0.85, 0.55, 0.32, 1.0)
CAGE_WIRE = (0.15, 0.3, 0.6, 1.0)
CAMERA_TARGET = np.array([0.0, 0.0, 0.4])  # the edited cage reaches higher than it sinks


def deformation_scene(shape_key=True):
    """Suzanne (7958 vertices) in a snug 42-vertex cage, a camera framing the edited
    cage, and (for the saved file) a "Pull and twist" shape key on the cage at value 0."""
    scene = scenes.reset_scene()
    pictures.setup_workbench(scene, 480, 360, lighting="STUDIO", color_type="OBJECT",
                        background=(0.94, 0.94, 0.94))
    mesh, cage = scenes.add_demo_mesh_and_cage()
    mesh.color, cage.color = SKIN, CAGE_WIRE
    rest_cage = arrays.read_positions(cage.data)
    if shape_key:
        # Animated through the evaluated cage, which is what the add-on follows.
        cage.shape_key_add(name="Basis")
        pull = cage.shape_key_add(name="Pull and twist", from_mix=False)
        arrays.write_shape_key(pull, scenes.nonaffine_edit(rest_cage))
        pull.value = 0.0
    pictures.add_camera(CAMERA_TARGET, azimuth=-75, elevation=12, ortho_scale=5.0)
    return scene, mesh, cage


def bind(mesh, cage, kind):
    """Bind through the extension's operator, as a user would; returns the wall time."""
    start = time.perf_counter()
    with session.quiet():  # its "Info: Bound ..." report; the summary says it all
        scenes.bind(mesh, cage, ADDON_KINDS[kind])
    return time.perf_counter() - start


def settle():
    """Evaluate the scene: the GenCoords modifier moves the mesh with its cage."""
    bpy.context.view_layer.update()


def render_with_cage_wire(cage, path, *more_cages):
    """Render with the cages drawn as thin wires: Workbench renders a WIRE-display object
    solid, and a Wireframe modifier on a cage itself would change the evaluated cage the
    mesh follows, so throw-away wire copies (of the evaluated cages) are drawn instead."""
    wires = []
    for each in (cage, *more_cages):
        each.hide_render = True
        wire = scenes.add_mesh_object("Cage wire", arrays.evaluated_positions(each), arrays.read_loop_triangles(each.data))
        wire.matrix_world, wire.color = each.matrix_world, CAGE_WIRE
        modifier = wire.modifiers.new("Wire", "WIREFRAME")
        # No even offset: it divides by the sine of the angles, spiking at sliver triangles.
        modifier.thickness, modifier.use_even_offset = 0.016, False
        wires.append(wire)
    pictures.render(path)
    for wire in wires:
        bpy.data.meshes.remove(wire.data)


def artist_pictures():
    """A cage made by Make Cage around the demo mesh, and two cages deforming it at once
    (the made cage stretched, the fitted one pulled and twisted): out/artist.png."""
    scene, mesh, fitted = deformation_scene(shape_key=False)
    scenes.make_active(mesh)
    with session.quiet():
        bpy.ops.object.gencoords_make_cage(target_vertices=100, margin=0.04)
    made = mesh.gencoords.cage
    corner_label(f"made cage, {len(made.data.vertices)} vertices", scene.camera)
    fitted.hide_render = True
    render_with_cage_wire(made, session.OUT / "made_cage.png")
    bind(mesh, made, scenes.MEAN_VALUE)
    bind(mesh, fitted, scenes.MEAN_VALUE)
    stretched = arrays.read_positions(made.data) * (1.25, 1.0, 1.0)
    arrays.write_positions(made.data, stretched)
    arrays.write_positions(fitted.data, scenes.nonaffine_edit(arrays.read_positions(fitted.data)))
    settle()
    corner_label("two cages at once", scene.camera)
    render_with_cage_wire(fitted, session.OUT / "two_cages.png", made)
    pictures.side_by_side([session.OUT / "made_cage.png", session.OUT / "two_cages.png"],
                     session.OUT / "artist.png")


def triangle_angles(mesh):
    """The evaluated mesh's triangles' corner angles, (t, 3) in degrees."""
    return measures.triangle_angles(arrays.evaluated_positions(mesh), arrays.read_loop_triangles(mesh.data))


def green_pictures(stretch=1.6):
    """The cage stretched ``stretch`` times along x, the mesh bound with mean value and
    with Green coordinates (out/green.png), and the mean change of the mesh's triangle
    angles under each: Green keeps details' shape. Returns {kind: (mean, worst)}."""
    scene, mesh, cage = deformation_scene(shape_key=False)
    scene.camera.data.ortho_scale = 6.5  # the stretched mesh is wider
    rest_cage = arrays.read_positions(cage.data)
    centre = rest_cage.mean(axis=0)
    stretched = centre + (rest_cage - centre) * (stretch, 1.0, 1.0)
    rest_angles = triangle_angles(mesh)
    changes, paths = {}, []
    for kind in (scenes.MEAN_VALUE, scenes.GREEN):
        scenes.bind(mesh, cage, kind.upper())
        arrays.write_positions(cage.data, stretched)
        settle()
        change = np.abs(triangle_angles(mesh) - rest_angles)
        changes[kind] = (float(change.mean()), float(change.max()))
        label = "mean value" if kind == scenes.MEAN_VALUE else "green (shape-preserving)"
        corner_label(f"{label}: angles change {changes[kind][0]:.1f} deg", scene.camera)
        paths.append(session.OUT / f"stretched_{kind}.png")
        render_with_cage_wire(cage, paths[-1])
        arrays.write_positions(cage.data, rest_cage)
        settle()
        scenes.make_active(mesh)
        bpy.ops.object.gencoords_unbind()
    pictures.side_by_side(paths, session.OUT / "green.png")
    return changes


def corner_label(text, camera):
    """A caption in the picture's top-left corner (replaces the previous one)."""
    for obj in [o for o in bpy.data.objects if o.name.startswith("Caption")]:
        bpy.data.objects.remove(obj)
    right, up = pictures.camera_axes(camera)
    obj = add_label(text, CAMERA_TARGET - 2.3 * right + 1.72 * up, camera, size=0.26)
    obj.name = "Caption"
    # Left-align: shift by half the text's width (labels are centred on their location).
    obj.location = np.array(obj.location) + 0.5 * obj.dimensions.x * right
    return obj


def deform_each_kind(kinds):
    """Bind with each type; affine check; render the non-affine edit. Returns summary rows."""
    scene, mesh, cage = deformation_scene(shape_key=False)
    rest_mesh, rest_cage = arrays.read_positions(mesh.data), arrays.read_positions(cage.data)
    size = scenes.cage_size(rest_cage)
    corner_label("rest", scene.camera)
    render_with_cage_wire(cage, session.OUT / "before.png")
    binding = session.addon_module("bind.bindings")
    rows = []
    for kind in kinds:
        seconds = bind(mesh, cage, kind)
        smallest = binding.binding(mesh).data.min_coordinate
        # Affine check: exact coordinates move the mesh exactly like the cage.
        arrays.write_positions(cage.data, scenes.affine_map(rest_cage))
        settle()
        error = np.linalg.norm(arrays.evaluated_positions(mesh) - scenes.affine_map(rest_mesh),
                               axis=1).max()
        arrays.write_positions(cage.data, scenes.nonaffine_edit(rest_cage))
        settle()
        corner_label(scenes.KIND_LABELS[kind].lower(), scene.camera)
        render_with_cage_wire(cage, session.OUT / f"after_{kind}.png")
        arrays.write_positions(cage.data, rest_cage)
        settle()
        scenes.make_active(mesh)
        bpy.ops.object.gencoords_unbind()
        rows.append((kind, seconds, smallest, error))
    return rows, size


def save_playable_blend(path):
    """out/demo.blend: mean value bind, the cage's shape key keyframed 0 -> 1 -> 0."""
    scene, mesh, cage = deformation_scene(shape_key=True)
    rest_mesh = arrays.read_positions(mesh.data)
    bind(mesh, cage, scenes.MEAN_VALUE)
    pull = cage.data.shape_keys.key_blocks["Pull and twist"]
    for frame, value in ((1, 0.0), (40, 1.0), (60, 1.0), (100, 0.0)):
        pull.value = value
        pull.keyframe_insert("value", frame=frame)
    scene.frame_start, scene.frame_end = 1, 100
    # Check the animation drives the mesh: at frame 50 the cage is fully edited.
    scene.frame_set(50)
    settle()
    moved = np.abs(arrays.evaluated_positions(mesh) - rest_mesh).max()
    scene.frame_set(1)
    settle()
    cage.hide_render = True  # F12 shows Suzanne, not a solid cage
    scenes.make_active(mesh)
    path.unlink(missing_ok=True)  # else Blender keeps the previous run as demo.blend1
    with session.quiet():
        bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True)
    return moved


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-deform", action="store_true",
                        help="only the coordinate-field figures (no extension needed)")
    parser.add_argument("--update-docs", action="store_true",
                        help="also copy the README's pictures into docs/ (the demo itself "
                             "writes only to out/, leaving a clone's files untouched)")
    args = parser.parse_args()
    started = time.perf_counter()
    session.OUT.mkdir(exist_ok=True)

    if not args.skip_deform:
        zip_path = session.install_extension()
        print(f"extension {zip_path.relative_to(session.REPO)} installed")
        rows, size = deform_each_kind(scenes.KINDS)
        pictures.side_by_side([session.OUT / "before.png", session.OUT / "after_mean_value.png"],
                         session.OUT / "demo.png")
        pictures.side_by_side([session.OUT / f"after_{kind}.png" for kind in scenes.KINDS],
                         session.OUT / "after_all.png")
        print(f"Suzanne (7958 vertices) in a snug 42-vertex icosphere cage "
              f"(diagonal {size:.2f}):")
        print(f"  {'type':17s} {'bind':>7s} {'min coordinate':>15s} {'affine error':>13s}")
        for kind, seconds, smallest, error in rows:
            print(f"  {kind:17s} {seconds:6.2f}s {smallest:15.3e} {error:13.1e}")
        print("  (affine error: max |deformed - exact image| after an affine cage motion)")
        print("pictures: out/before.png, out/after_<type>.png, out/after_all.png, "
              "out/demo.png (before | mean value)")
        artist_pictures()
        print("out/artist.png: a cage made by Make Cage, and two cages deforming one mesh")
        changes = green_pictures()
        print("out/green.png: the cage stretched 1.6x along x; mean / worst change of the mesh's "
              "triangle angles: " + ", ".join(f"{kind} {mean:.1f} / {worst:.1f} degrees"
                                              for kind, (mean, worst) in changes.items()))

    minima = render_fields(session.OUT / "fields.png")
    if args.update_docs:
        session.DOCS.mkdir(exist_ok=True)
        for picture in ("demo.png", "fields.png", "artist.png", "green.png"):
            if (session.OUT / picture).exists():
                shutil.copyfile(session.OUT / picture, session.DOCS / picture)
        print("README pictures updated in docs/")
    print("coordinate fields (figures 9, 10) -> out/fields.png; min coordinate of v:")
    for (name, kind), value in minima.items():
        print(f"  {name:9s} {kind:17s} {value:+.4f}")
    if not args.skip_deform:
        moved = save_playable_blend(session.OUT / "demo.blend")
        print(f"out/demo.blend: Suzanne bound (mean value) to the cage, shape key keyframed "
              f"over frames 1-100 (mesh moves up to {moved:.2f} at frame 50); open it in "
              "Blender with the extension installed and press play")
    print(f"done in {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
