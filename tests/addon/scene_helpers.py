"""Building test scenes with bpy, shared by the tests and their subprocess scripts."""

import os

import bmesh
import bpy
import numpy as np


def activate(obj):
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def add_icosphere_cage(radius=2.0, subdivisions=1, name="Cage"):
    """A convex, closed, triangulated cage around the origin."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=radius)
    cage = bpy.context.active_object
    cage.name = name
    return cage


def add_cube_cage(size=4.0, name="Cage"):
    """A convex cage made of quads (the add-on triangulates it)."""
    bpy.ops.mesh.primitive_cube_add(size=size)
    cage = bpy.context.active_object
    cage.name = name
    return cage


def add_sphere(radius=1.0, name="Mesh", location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, segments=16, ring_count=8,
                                         location=location)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def add_subdivided_sphere(levels, name="Mesh"):
    """``add_sphere`` with ``levels`` of subdivision applied (1922 vertices at 2)."""
    obj = add_sphere(name=name)
    modifier = obj.modifiers.new("Subdivision", 'SUBSURF')
    modifier.levels = levels
    activate(obj)
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    return obj


def positions(mesh):
    """Vertex positions of a mesh datablock, (k, 3) float32."""
    flat = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", flat)
    return flat.reshape(-1, 3)


def evaluated_cage_positions(cage):
    """Vertex positions of the cage with modifiers and shape keys, in its local space."""
    evaluated = cage.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return positions(mesh)
    finally:
        evaluated.to_mesh_clear()


def set_positions(mesh, new_positions):
    mesh.attributes["position"].data.foreach_set(
        "vector", np.ascontiguousarray(new_positions, dtype=np.float32).reshape(-1))
    mesh.update()


def update():
    """Evaluate the depsgraph, which runs the add-on's depsgraph_update_post handler."""
    bpy.context.evaluated_depsgraph_get().update()


def bind(obj, cage, kind="MEAN_VALUE", outside="RAISE"):
    obj.gencoords.cage = cage
    obj.gencoords.kind = kind
    obj.gencoords.outside = outside
    activate(obj)
    return bpy.ops.object.gencoords_bind()


def load_user_preferences():
    """Start like the ``blender`` executable, which loads the user's preferences (they
    enable installed extensions); bpy as a module starts with factory preferences."""
    if not os.path.exists(bpy.utils.user_resource('CONFIG', path="userpref.blend")):
        return
    # Set by conftest where read_userpref crashes (bpy 4.2): enable what it saved instead.
    enable_instead = os.environ.get("GENCOORDS_TEST_ENABLE_INSTEAD_OF_READ_USERPREF")
    if enable_instead:
        import addon_utils

        for module in enable_instead.split(","):
            addon_utils.enable(module, default_set=True, handle_error=None)
    else:
        bpy.ops.wm.read_userpref()


def edit_mesh(obj, change):
    """Apply ``change(bm)`` to the object's mesh through bmesh."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    change(bm)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def evaluated_positions(obj):
    """Positions of ``obj``'s evaluated mesh (its modifiers applied), (k, 3) float32."""
    bpy.context.view_layer.update()
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return positions(evaluated.data)


def mesh_state(obj):
    """Everything Bind must leave and Unbind must restore: positions and attribute names."""
    return positions(obj.data).copy(), sorted(a.name for a in obj.data.attributes)
