"""Building test scenes with bpy, shared by the tests and their subprocess scripts.

Mesh arrays (the add-on's own ``gencoords_addon/blender_io/mesh_arrays.py``, loaded by path: some
subprocess scripts run without the extension installed), ``make_active`` and ``bind``
(through the operator, as a user binds) are the scripts' own, from
``scripts.common.blender_objects``: one helper per idea for scripts and tests.
"""

import os
import sys
from pathlib import Path

import bmesh
import bpy


sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common.blender_objects import arrays, bind, make_active  # noqa: E402, F401 (tests import them from here)

read_positions = arrays.read_positions
write_positions = arrays.write_positions
write_shape_key = arrays.write_shape_key
evaluated_positions = arrays.evaluated_positions


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
    make_active(obj)
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    return obj


def evaluated_cage_positions(cage):
    """Vertex positions of the cage with modifiers and shape keys, in its local space
    (``to_mesh``: also in edit mode)."""
    evaluated = cage.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return read_positions(mesh).copy()
    finally:
        evaluated.to_mesh_clear()


def update():
    """Evaluate the depsgraph, which runs the add-on's depsgraph_update_post handler."""
    bpy.context.evaluated_depsgraph_get().update()


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


def mesh_state(obj):
    """Everything Bind must leave and Unbind must restore: positions and attribute names."""
    return read_positions(obj.data).copy(), sorted(a.name for a in obj.data.attributes)
