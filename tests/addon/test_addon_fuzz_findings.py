"""What the operator fuzz found (scripts/fuzz, seeds 2000-2299), each through the operator
an artist or a script uses (inside ``bpy.context.temp_override``)."""

import importlib

import bmesh
import bpy
import numpy as np
import pytest

import gencoords
from fresh_process import PACKAGE
from scene_helpers import bind, edit_mesh, evaluated_positions, read_positions, write_positions

TOLERANCE = 1e-6


def make_cage(obj, **options):
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_make_cage(**options)


def world_arrays(obj):
    """World positions (float64) of ``obj``'s mesh data and its triangles as Bind reads them."""
    mesh_io = importlib.import_module(f"{PACKAGE}.gencoords_addon.blender_io.mesh_io")
    local = read_positions(obj.data)
    triangles, _ = mesh_io.read_triangles(obj.data, local)
    matrix = np.array(obj.matrix_world)
    return local.astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3], triangles


def world_positions(obj):
    """The evaluated mesh's vertices in world space ((k, 3) float64)."""
    matrix = np.array(obj.matrix_world)
    return evaluated_positions(obj).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def test_tight_cage_of_8_vertices_at_offset_0_around_a_monkey_with_holes_encloses_it(gc):
    """Seed 2217: the voxel remesh broke the open monkey into 363 pieces, each decimated to
    two back-to-back triangles: bmesh refused them ("face already exists"), an internal
    error. The coarsest voxels keep it in one piece: a valid cage."""
    bpy.ops.mesh.primitive_monkey_add(size=0.7)
    monkey = bpy.context.active_object
    for _ in range(2):  # the fuzz's Edit Mode step: three vertices deleted, twice
        edit_mesh(monkey, lambda bm: bmesh.ops.delete(bm, geom=list(bm.verts)[:3], context='VERTS'))
    assert make_cage(monkey, shape='TIGHT', target_vertices=8, offset=0.0) == {'FINISHED'}
    cage = monkey.gencoords.cage
    cage_points, cage_triangles = world_arrays(cage)
    gencoords.advanced.validate_cage(cage_points, cage_triangles, convex=False, tolerance=TOLERANCE)
    where = gencoords.point_locations(world_arrays(monkey)[0], cage_points, cage_triangles, tolerance=TOLERANCE)
    assert (where == gencoords.INSIDE).all()
    assert 4 <= len(cage_points) <= 40


def dented_box_far_from_the_origin():
    """The fuzz's dented cube (26 vertices, its top's centre pushed in), its data 3.2e5
    from its object's origin (float32 steps of 0.03 there), the object turned."""
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    obj = bpy.context.active_object
    edit_mesh(obj, lambda bm: bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True))
    positions = read_positions(obj.data).astype(np.float64)
    positions[np.all(np.abs(positions - (0.0, 0.0, 1.0)) < 1e-6, axis=1), 2] = 0.3
    write_positions(obj.data, positions + (-315616.03, 157808.01, -105205.34))
    obj.rotation_euler = (0.917, -0.494, 2.605)
    bpy.context.view_layer.update()
    return obj


@pytest.mark.parametrize("options", [dict(shape='TIGHT', target_vertices=20, offset=0.01),
                                     dict(shape='CONVEX', target_vertices=20, margin=0.0)])
def test_a_cage_made_around_mesh_data_far_from_its_origin_binds(gc, options):
    """Seed 2163: Make Cage checked the cage in its own frame; Bind reads it in the mesh's
    local space, where float32 steps are 0.03 (3.2e5 from the origin) and the tight
    cage's clearance 0.009: one vertex ended outside and Bind refused the made cage."""
    obj = dented_box_far_from_the_origin()
    assert make_cage(obj, **options) == {'FINISHED'}
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bind(obj, obj.gencoords.cage, kind='MEAN_VALUE', outside='RAISE') == {'FINISHED'}


def test_a_small_mesh_far_from_the_origin_binds_to_its_made_cage_and_follows_it(gc):
    """Seed 3128: a 2 mm cube 6.2e4 from the origin (object scale 0.001), its convex made
    cage refused by Bind (5 of 8 vertices outside). The deformer (and Bind, reading the
    cage through it) moved the cage into the mesh's space by (mesh world)^-1 (cage world)
    in float32, whose translation (6.2e7) cancelled to within 4 mesh units. The cage now
    lands where it is, and the mesh follows a translation of it."""
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    obj = bpy.context.active_object
    obj.location, obj.scale = (-62131.585, 31065.79, -20710.53), (0.001, 0.001, 0.001)
    obj.rotation_euler = (-1.784, -3.149, 3.054)
    bpy.context.view_layer.update()
    assert make_cage(obj, shape='CONVEX', target_vertices=300, margin=0.5) == {'FINISHED'}
    cage = obj.gencoords.cage
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj]):
        assert bind(obj, cage, kind='MEAN_VALUE', outside='RAISE') == {'FINISHED'}
    before, start = world_positions(obj), np.array(cage.matrix_world)[:3, 3]
    cage.location = start + (2 ** -7, -(2 ** -8), 2 ** -8)  # float32 steps there are 2^-8
    bpy.context.view_layer.update()
    shift = np.array(cage.matrix_world)[:3, 3] - start
    assert np.linalg.norm(shift) > 0.004
    np.testing.assert_allclose(world_positions(obj) - before, np.tile(shift, (8, 1)), atol=1e-7)
