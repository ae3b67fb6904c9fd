"""Building a case's scene in Blender (``cases.scene_of``): the cage with its defect,
modifier and transform, the mesh with its extras, both placed at the case's scale and
offset. Returns the roles (``cases.ROLES``) mapped to object names.
"""

import random

import bmesh
import bpy
import numpy as np

from tests.fixtures import character
from scripts.common.blender_objects import arrays, make_active

NAN = float("nan")


def _primitive(operator, name, **arguments):
    operator(**arguments)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    return obj


def _object_from(name, vertices, faces=()):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([list(map(float, v)) for v in vertices], [], [list(map(int, f)) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    make_active(obj)
    return obj


def _character_cage(name):
    vertices, quads = character.character_cage()
    vertices = vertices - (vertices.max(axis=0) + vertices.min(axis=0)) / 2
    return _object_from(name, vertices / np.abs(vertices).max(), quads)


def _dented_cage(name):
    obj = _primitive(bpy.ops.mesh.primitive_cube_add, name, size=2.0)
    edit(obj, lambda bm: bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True))
    positions = arrays.read_positions(obj.data).copy()
    top = np.flatnonzero(np.all(np.abs(positions - (0.0, 0.0, 1.0)) < 1e-6, axis=1))
    positions[top, 2] = 0.3  # the top face's centre pushed in: a dent
    arrays.write_positions(obj.data, positions)
    return obj


CAGE_BUILDERS = {
    "cube": lambda name: _primitive(bpy.ops.mesh.primitive_cube_add, name, size=2.0),
    "icosphere": lambda name: _primitive(bpy.ops.mesh.primitive_ico_sphere_add, name, subdivisions=1, radius=1.2),
    "cylinder": lambda name: _primitive(bpy.ops.mesh.primitive_cylinder_add, name, vertices=8, radius=1.2,
                                        depth=2.0, end_fill_type='NGON'),
    "uv_sphere": lambda name: _primitive(bpy.ops.mesh.primitive_uv_sphere_add, name, segments=8, ring_count=6,
                                         radius=1.2),
    "dented": _dented_cage,
    "character": _character_cage,
}


def edit(obj, change):
    """Apply ``change(bm)`` to the object's mesh data through bmesh."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.ensure_lookup_table()
    bm.faces.ensure_lookup_table()
    bm.edges.ensure_lookup_table()
    change(bm)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def _collapse_to_zero_area(bm):
    """Put a vertex on the midpoint of two neighbours of its: their triangle has zero area."""
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.faces.ensure_lookup_table()
    face = bm.faces[0]
    a, b, c = face.verts
    a.co = (b.co + c.co) / 2


def _fin(bm):
    """A third face on an edge: non-manifold."""
    edge = bm.edges[0]
    tip = bm.verts.new(edge.verts[0].co * 1.5 + edge.verts[1].co * 0.2)
    bm.faces.new((edge.verts[0], edge.verts[1], tip))


CAGE_DEFECTS = {
    "open": lambda bm: bmesh.ops.delete(bm, geom=[bm.faces[0]], context='FACES_ONLY'),
    "non_manifold": _fin,
    "self_intersecting": lambda bm: setattr(bm.verts[0], "co", bm.verts[0].co * -2.0),
    "duplicate_vertices": lambda bm: bmesh.ops.split_edges(bm, edges=[bm.edges[0]]),
    "zero_area_face": _collapse_to_zero_area,
    "flipped": lambda bm: bmesh.ops.reverse_faces(bm, faces=bm.faces[:]),
    "flipped_face": lambda bm: bmesh.ops.reverse_faces(bm, faces=[bm.faces[0]]),
    "nan": lambda bm: setattr(bm.verts[0], "co", (NAN, 0.0, 0.0)),
    "loose_vertex": lambda bm: bm.verts.new((0.1, 0.2, 0.3)),
    "flat": lambda bm: [setattr(v, "co", (v.co.x, v.co.y, 0.0)) for v in bm.verts],
}


def add_modifier(obj, kind):
    modifier = obj.modifiers.new(kind.title(), kind)
    if kind == 'SUBSURF':
        modifier.levels = modifier.render_levels = 1
    elif kind == 'DISPLACE':
        modifier.strength = 0.1
    elif kind == 'SOLIDIFY':
        modifier.thickness = 0.1
    return modifier


def scale_oddly(obj, odd):
    """A zero or negative axis, a mirror on every axis, or ``one`` (back to positive)."""
    scale = list(obj.scale)
    if odd == "zero_x":
        scale[0] = 0.0
    elif odd == "negative_x":
        scale[0] = -abs(scale[0]) or -1.0
    elif odd == "negative_all":
        scale = [-abs(s) for s in scale]
    else:
        scale = [abs(s) or 1.0 for s in scale]
    obj.scale = scale


def build_cage(spec):
    cage = CAGE_BUILDERS[spec["shape"]]("Cage")
    if spec["defect"]:
        edit(cage, CAGE_DEFECTS[spec["defect"]])
    if spec["modifier"]:
        add_modifier(cage, spec["modifier"])
    return cage


def _mesh_shape(spec, cage, rng):
    size = spec["size"]
    shape = spec["shape"]
    if shape == "sphere":
        return _primitive(bpy.ops.mesh.primitive_uv_sphere_add, "Mesh", segments=12, ring_count=6, radius=size)
    if shape == "monkey":
        return _primitive(bpy.ops.mesh.primitive_monkey_add, "Mesh", size=size * 1.4)
    if shape == "grid":
        return _primitive(bpy.ops.mesh.primitive_grid_add, "Mesh", x_subdivisions=5, y_subdivisions=5,
                          size=2 * size)
    if shape == "icosphere":
        return _primitive(bpy.ops.mesh.primitive_ico_sphere_add, "Mesh", subdivisions=2, radius=size)
    if shape == "points":
        return _object_from("Mesh", [[rng.uniform(-size, size) for _ in range(3)] for _ in range(30)])
    if shape == "cage_itself":
        obj = bpy.data.objects.new("Mesh", cage.data.copy())
        obj.data.name = "Mesh"
        bpy.context.scene.collection.objects.link(obj)
        make_active(obj)
        return obj
    return _object_from("Mesh", [(0.0, 0.0, 0.0)])


def build_mesh(spec, cage, rng):
    obj = _mesh_shape(spec, cage, rng)
    if spec["loose_vertices"]:
        edit(obj, lambda bm: [bm.verts.new([rng.uniform(-0.5, 0.5) for _ in range(3)]) for _ in range(3)])
    if spec["shape_keys"]:
        obj.shape_key_add(name="Basis")
        key = obj.shape_key_add(name="Key 1")
        arrays.write_shape_key(key, arrays.read_positions(obj.data) * 0.9 + 0.02)
        key.value = 0.5
    if spec["modifier"]:
        add_modifier(obj, spec["modifier"])
    if spec.get("nan"):
        edit(obj, lambda bm: setattr(bm.verts[-1], "co", (0.0, NAN, 0.0)))
    return obj


def place(objects, placement):
    """Every object at the case's scale and offset: in its data (shape keys too) or in its
    transform."""
    scale, offset = placement["scale"], placement["offset"]
    shift = np.array([offset, -offset / 2, offset / 3])
    for obj in objects:
        if not placement["in_data"]:
            obj.scale = [s * scale for s in obj.scale]
            obj.location = shift
            continue
        arrays.write_positions(obj.data, arrays.read_positions(obj.data) * scale + shift)
        for key in (obj.data.shape_keys.key_blocks if obj.data.shape_keys else ()):
            flat = np.empty(len(key.data) * 3, dtype=np.float32)
            key.data.foreach_get("co", flat)
            arrays.write_shape_key(key, flat.reshape(-1, 3) * scale + shift)


def build(scene_spec, seed):
    """The case's objects in the current (empty) file; returns the roles: name by role."""
    rng = random.Random(seed)
    cage = build_cage(scene_spec["cage"])
    mesh = build_mesh(scene_spec["mesh"], cage, rng)
    place([cage, mesh], scene_spec["placement"])
    if scene_spec["cage"]["rotation"]:
        cage.rotation_euler = scene_spec["cage"]["rotation"]
        if scene_spec["mesh"]["shape"] == "cage_itself":
            mesh.rotation_euler = cage.rotation_euler
    if scene_spec["cage"]["odd_scale"]:
        scale_oddly(cage, scene_spec["cage"]["odd_scale"])
    if scene_spec["mesh"]["odd_scale"]:
        scale_oddly(mesh, scene_spec["mesh"]["odd_scale"])
    roles = {"mesh": mesh.name, "cage": cage.name}
    if scene_spec["mesh"]["twin"]:
        twin = bpy.data.objects.new("Twin", mesh.data)  # Alt+D: the mesh data shared
        twin.matrix_world = mesh.matrix_world
        bpy.context.scene.collection.objects.link(twin)
        roles["twin"] = twin.name
    mesh.gencoords.cage = cage
    bpy.context.view_layer.update()
    return roles

