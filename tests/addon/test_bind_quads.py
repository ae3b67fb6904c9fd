"""Quad Mean Value and Harmonic through the operator: a box cage's quads bound as quads,
so the mesh does not depend on which corner each quad lists first (issue 36)."""

import bpy
import numpy as np
import pytest

from scene_helpers import (add_sphere, evaluated_positions, make_active, mesh_state, read_positions, update,
                           write_positions)

CUBE = np.array([[x, y, z] for x in (-2.0, 2.0) for y in (-2.0, 2.0) for z in (-2.0, 2.0)])
# Outward, counter-clockwise seen from outside (vertex index = 4 x + 2 y + z, each 0 or 1).
QUADS = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
DIAGONAL = float(np.linalg.norm(CUBE.max(axis=0) - CUBE.min(axis=0)))


def add_box_cage(name, shift=0):
    """The six-quad box cage, each quad's corners listed ``shift`` positions later."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(CUBE.tolist(), [], [list(np.roll(quad, -shift)) for quad in QUADS])
    mesh.update()
    cage = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(cage)
    return cage


def bind(obj, cage, kind):
    """Bind as a pipeline script does: the settings, then the operator in temp_override."""
    obj.gencoords.cage, obj.gencoords.kind = cage, kind
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_bind()


def move_cage_vertex(cage, vertex, offset):
    positions = read_positions(cage.data).copy()
    positions[vertex] += offset
    write_positions(cage.data, positions)


def bent_meshes(kind):
    """Two spheres bound with ``kind`` to the box cage and to its relabelled twin, both
    cages then given the same non-planar edit (one corner dragged): their positions."""
    meshes = []
    for shift in (0, 1):
        cage = add_box_cage(f"Cage{shift}", shift)
        obj = add_sphere(name=f"Mesh{shift}")
        assert bind(obj, cage, kind=kind) == {'FINISHED'}
        move_cage_vertex(cage, 7, [0.8, 0.6, 1.2])
        meshes.append(obj)
    update()
    return [evaluated_positions(obj) for obj in meshes]


def test_quad_mean_value_does_not_depend_on_each_quads_first_corner(gc):
    first, relabelled = bent_meshes("MEAN_VALUE_QUADS")
    assert np.abs(first - relabelled).max() <= 1e-5 * DIAGONAL


def test_split_mean_value_does_depend_on_it(gc):  # what the quads' kind is for
    first, relabelled = bent_meshes("MEAN_VALUE")
    assert np.abs(first - relabelled).max() > 1e-2 * DIAGONAL


def test_harmonic_does_not_depend_on_each_quads_first_corner(gc):
    first, relabelled = bent_meshes("HARMONIC")
    assert np.abs(first - relabelled).max() <= 1e-5 * DIAGONAL


def test_harmonic_reads_the_quads_whole(gc):  # none split: the status counts no triangulated face
    cage = add_box_cage("Cage")
    obj = add_sphere()
    assert bind(obj, cage, kind="HARMONIC") == {'FINISHED'}
    data = gc.binding.binding(obj).data
    assert data.kind == "harmonic" and data.cage_non_triangles == 0


def test_the_mesh_follows_the_cages_translation(gc):
    cage = add_box_cage("Cage")
    obj = add_sphere()
    rest = read_positions(obj.data).copy()
    assert bind(obj, cage, kind="MEAN_VALUE_QUADS") == {'FINISHED'}
    update()
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    move_cage_vertex(cage, slice(None), [0.3, -1.1, 0.7])
    update()
    assert np.abs(evaluated_positions(obj) - (rest + [0.3, -1.1, 0.7])).max() <= 1e-5 * DIAGONAL
    assert gc.binding.binding(obj).data.kind == "mean_value_quads"


def test_a_folded_quad_is_refused_naming_its_face(gc):
    cage = add_box_cage("Cage")
    move_cage_vertex(cage, 7, [-3.0, -3.0, 0.0])  # across its top quads' opposite diagonals
    obj = add_sphere(radius=0.5)
    before = mesh_state(obj)
    make_active(obj)
    with pytest.raises(RuntimeError, match=r"Cage .Cage. has a quad folded over itself .*\(faces [135]"):
        bind(obj, cage, "MEAN_VALUE_QUADS")
    after = mesh_state(obj)
    np.testing.assert_array_equal(after[0], before[0])
    assert after[1] == before[1] and not obj.modifiers


def test_faces_of_more_corners_are_split_and_counted(gc):
    # A vertex on the top front edge: the top and front faces have five corners.
    vertices = np.vstack([CUBE, [[0.0, -2.0, 2.0]]])
    faces = [list(q) for q in QUADS]
    faces[2] = [0, 4, 5, 8, 1]  # y = -2, through the new vertex between 5 and 1
    faces[5] = [1, 8, 5, 7, 3]  # z = +2
    mesh = bpy.data.meshes.new("Cage")
    mesh.from_pydata(vertices.tolist(), [], faces)
    cage = bpy.data.objects.new("Cage", mesh)
    bpy.context.scene.collection.objects.link(cage)
    obj = add_sphere()
    rest = read_positions(obj.data).copy()
    assert bind(obj, cage, kind="MEAN_VALUE_QUADS") == {'FINISHED'}
    assert gc.binding.binding(obj).data.cage_non_triangles == 2
    move_cage_vertex(cage, slice(None), [0.5, 0.25, -0.75])
    update()
    assert np.abs(evaluated_positions(obj) - (rest + [0.5, 0.25, -0.75])).max() <= 1e-5 * DIAGONAL
