"""What the operator fuzz found (scripts/fuzz, seeds 2000-2299), each through the operator
an artist or a script uses (inside ``bpy.context.temp_override``)."""

import importlib

import bmesh
import bpy
import numpy as np
import pytest

import gencoords
from fresh_process import PACKAGE
from scene_helpers import bind, edit_mesh, read_positions, write_positions

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
