"""Bad input and live faults: a clear message, the mesh untouched, and a way back."""

import re

import bmesh
import bpy
import numpy as np
import pytest

from scene_helpers import (activate, add_cube_cage, add_icosphere_cage, add_sphere, bind,
                           edit_mesh, positions, set_positions, update)


def open_hole(bm):
    bm.faces.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.faces[0]], context='FACES_ONLY')


def add_fin(bm):
    """A third face on an existing edge: that edge becomes non-manifold."""
    bm.edges.ensure_lookup_table()
    edge = bm.edges[0]
    tip = bm.verts.new((edge.verts[0].co + edge.verts[1].co) * 0.5 + edge.verts[0].co * 0.2)
    bm.faces.new((edge.verts[0], edge.verts[1], tip))


def flip_normals(bm):
    bmesh.ops.reverse_faces(bm, faces=bm.faces[:])


def dent(bm):
    bm.verts.ensure_lookup_table()
    bm.verts[0].co *= 0.2


def subdivide(bm):
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True)


def rotate_an_edge(bm):
    """Same vertices and face count, other faces: only the connectivity changes."""
    bm.edges.ensure_lookup_table()
    bmesh.ops.rotate_edges(bm, edges=[bm.edges[0]], use_ccw=True)


def add_triangle_object():
    mesh = bpy.data.meshes.new("Triangle")
    mesh.from_pydata([(-3, -3, -3), (3, -3, -3), (0, 3, 3)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new("Triangle", mesh)
    bpy.context.collection.objects.link(obj)
    return obj


def assert_bind_refused(obj, cage, message, kind="MEAN_VALUE"):
    rest = positions(obj.data).copy()
    with pytest.raises(RuntimeError, match=message):
        bind(obj, cage, kind=kind)
    np.testing.assert_array_equal(positions(obj.data), rest)
    assert obj.gencoords.bind_data is None


@pytest.mark.parametrize(("change", "message"), [
    (open_hole, "Cage 'Cage' is not closed"),
    (add_fin, "Cage 'Cage' .*(non-manifold|not closed)"),
    (flip_normals, "inside out .*Recalculate Outside"),
])
def test_broken_cages_are_refused(gc, change, message):
    cage = add_icosphere_cage()
    edit_mesh(cage, change)
    assert_bind_refused(add_sphere(), cage, message)


def test_non_convex_cage_suggests_mean_value(gc):
    cage = add_cube_cage()
    edit_mesh(cage, dent)
    obj = add_sphere(radius=0.5)
    assert_bind_refused(obj, cage, "not convex, which Wachspress coordinates need: choose "
                                   "Mean Value", kind="WACHSPRESS")
    # The faces named are the cage's own (quads an artist can select), around the dent.
    with pytest.raises(RuntimeError) as error:
        bind(obj, cage, kind="WACHSPRESS")
    named = [int(index) for index in re.search(r"\(faces ([\d, ]+)", str(error.value)).group(1).split(",")]
    assert all(0 in cage.data.polygons[face].vertices for face in named)
    assert bind(obj, cage, kind="MEAN_VALUE") == {'FINISHED'}


def test_mesh_with_an_undefined_vertex_is_refused(gc):
    obj = add_sphere()
    broken = positions(obj.data).copy()
    broken[5] = np.nan
    set_positions(obj.data, broken)
    assert_bind_refused(obj, add_icosphere_cage(), re.escape(
        "'Mesh' has 1 vertices at undefined (NaN or infinite) positions (first: vertex 5)"))


def test_cage_with_three_vertices_is_refused(gc):
    assert_bind_refused(add_sphere(), add_triangle_object(), "Cage 'Triangle' needs at least 4")


def test_missing_self_and_non_mesh_cages_are_refused(gc):
    obj = add_sphere()
    assert_bind_refused(obj, None, "Choose a cage for 'Mesh' first")
    assert_bind_refused(obj, obj, "'Mesh' cannot be its own cage")
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.collection.objects.link(empty)
    assert_bind_refused(obj, empty, "The cage 'Empty' must be a mesh object")


def test_vertices_outside_are_counted_and_project_or_extrapolate_bind(gc):
    cage = add_icosphere_cage(radius=2.0)
    obj = add_sphere(radius=1.0, location=(1.5, 0, 0))
    distances = np.linalg.norm(positions(obj.data) + (1.5, 0, 0), axis=1)
    surely_outside = int(np.count_nonzero(distances > 2.0))  # beyond the circumsphere
    assert surely_outside > 0
    assert_bind_refused(obj, cage, r"\d+ of 114 mesh vertices lie outside the cage 'Cage': "
                                   "enlarge the cage, or set Outside to Project or Extrapolate")
    for mode, verb in (("PROJECT", "projected onto the cage"), ("EXTRAPOLATE", "extrapolated")):
        assert bind(obj, cage, outside=mode) == {'FINISHED'}
        data = gc.storage.load(obj)
        assert surely_outside <= data.points_outside <= np.count_nonzero(distances > 1.5)
        assert np.isfinite(positions(obj.data)).all()
        assert any(f"outside the cage ({verb})" in text for text, _ in gc.status.status_lines(obj))


def fault_text(gc, obj):
    return "\n".join(text for text, icon in gc.status.status_lines(obj) if icon == 'ERROR')


def test_bind_data_of_another_format_is_reported_not_misread(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    shape = positions(obj.data).copy()
    obj.gencoords.bind_data["gencoords_format"] = 99  # as written by another version
    gc.storage.clear_cache()
    set_positions(cage.data, positions(cage.data) * 1.2)
    update()
    assert "another version of GenCoords" in fault_text(gc, obj)
    np.testing.assert_array_equal(positions(obj.data), shape)  # nothing written
    activate(obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    assert obj.gencoords.bind_data is None and not obj.modifiers
    np.testing.assert_array_equal(positions(obj.data), shape)


def test_deleting_the_cage_stops_deformation_and_unbind_restores(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    bind(obj, cage)
    set_positions(cage.data, positions(cage.data) * 1.2)
    update()
    deformed = positions(obj.data).copy()
    bpy.data.objects.remove(cage)
    update()
    assert "The cage was deleted" in fault_text(gc, obj)
    np.testing.assert_array_equal(positions(obj.data), deformed)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    np.testing.assert_array_equal(positions(obj.data), rest)
    assert fault_text(gc, obj) == ""


@pytest.mark.parametrize("change", [subdivide, rotate_an_edge])
def test_cage_topology_change_is_reported_until_rebind(gc, change):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    before = positions(obj.data).copy()
    edit_mesh(cage, change)
    update()
    assert "The topology of cage 'Cage' changed" in fault_text(gc, obj)
    np.testing.assert_array_equal(positions(obj.data), before)
    assert bind(obj, cage) == {'FINISHED'}
    assert fault_text(gc, obj) == ""
    assert gc.storage.load(obj).cage_vertex_count == len(cage.data.vertices)


def test_mesh_topology_change_never_writes_mismatched_arrays(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    edit_mesh(obj, lambda bm: bmesh.ops.delete(bm, geom=[bm.verts[:][0]], context='VERTS'))
    update()
    edited = positions(obj.data).copy()
    set_positions(cage.data, positions(cage.data) * 1.3)
    update()
    assert "now has 113 vertices but was bound with 114" in fault_text(gc, obj)
    np.testing.assert_array_equal(positions(obj.data), edited)
    with pytest.raises(RuntimeError, match="Cage Vertex|now has 113"):
        bpy.ops.object.gencoords_show_field()
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}  # a warning, not an error
    np.testing.assert_array_equal(positions(obj.data), edited)
    assert obj.gencoords.bind_data is None


def test_non_finite_cage_positions_leave_the_mesh_alone(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    before = positions(obj.data).copy()
    broken = positions(cage.data).copy()
    broken[0] = np.nan
    set_positions(cage.data, broken)
    update()
    assert "undefined (NaN or infinite)" in fault_text(gc, obj)
    np.testing.assert_array_equal(positions(obj.data), before)


def test_cage_with_a_loose_vertex_is_refused(gc):
    cage = add_icosphere_cage()
    edit_mesh(cage, lambda bm: bm.verts.new((0.0, 0.0, 0.1)))
    assert_bind_refused(add_sphere(), cage, re.escape(
        "Cage 'Cage' has vertices that belong to no face: use Mesh > Clean Up > Delete Loose "
        "(vertices 12)"))


def test_mesh_with_shape_keys_is_refused(gc):
    obj = add_sphere()
    obj.shape_key_add(name="Basis")
    assert_bind_refused(obj, add_icosphere_cage(), re.escape(
        "'Mesh' has shape keys, which would hide the cage's deformation: apply or remove them "
        "(Object Data properties > Shape Keys), then Bind"))


def test_shape_keys_added_after_binding_stop_deformation_until_removed(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    obj.shape_key_add(name="Basis")
    update()
    assert "'Mesh' has shape keys, which hide the cage's deformation" in fault_text(gc, obj)
    before = positions(obj.data).copy()
    set_positions(cage.data, positions(cage.data) * 1.2)
    update()
    np.testing.assert_array_equal(positions(obj.data), before)  # nothing written
    obj.shape_key_clear()
    set_positions(cage.data, positions(cage.data) * 1.1)
    update()
    assert fault_text(gc, obj) == ""
    np.testing.assert_allclose(positions(obj.data), before * 1.32, atol=1e-5)


def test_linked_duplicates_are_refused(gc):
    obj = add_sphere()
    duplicate = bpy.data.objects.new("Duplicate", obj.data)  # as Alt+D makes
    bpy.context.collection.objects.link(duplicate)
    assert_bind_refused(obj, add_icosphere_cage(), re.escape(
        "'Mesh' shares its mesh with other objects (linked duplicates): use Object > "
        "Relations > Make Single User, then Bind"))


def test_a_mesh_and_its_cage_cannot_drive_each_other(gc):
    outer = add_icosphere_cage(name="Outer")
    inner = add_sphere(name="Inner")
    assert bind(inner, outer) == {'FINISHED'}
    assert_bind_refused(outer, inner, re.escape(
        "'Inner' is itself bound to 'Outer': a mesh and its cage cannot drive each other"))


def move_first_vertex(bm):
    bm.verts.ensure_lookup_table()
    bm.verts[0].co *= 1.3


def bound_and_deformed(gc):
    """A mesh bound to a cage that has moved since (several writes), with no fault."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    bind(obj, cage)
    for _ in range(3):
        set_positions(cage.data, positions(cage.data) * 1.1)
        update()
    assert fault_text(gc, obj) == ""  # our own writes are not edits
    return obj, cage, rest


def test_an_edit_of_the_bound_mesh_is_kept_and_bind_again_binds_it(gc):
    obj, cage, _ = bound_and_deformed(gc)
    edit_mesh(obj, move_first_vertex)  # as a script would
    update()
    edited = positions(obj.data).copy()
    assert ("'Mesh' was edited while bound, so it no longer follows the cage: Bind again to "
            "bind the edited shape, or Unbind to restore the shape it was bound with"
            in fault_text(gc, obj))
    set_positions(cage.data, positions(cage.data) * 1.1)
    update()
    obj.gencoords.live = False
    np.testing.assert_array_equal(positions(obj.data), edited)  # nothing overwrote the edit
    obj.gencoords.live = True
    assert bind(obj, cage) == {'FINISHED'}
    np.testing.assert_array_equal(gc.storage.load(obj).rest_positions, edited)
    assert fault_text(gc, obj) == ""
    set_positions(cage.data, positions(cage.data) * 1.2)
    update()
    np.testing.assert_allclose(positions(obj.data), edited * 1.2, atol=1e-5)


def test_unbind_after_an_edit_mode_edit_restores_the_bound_shape(gc):
    obj, cage, rest = bound_and_deformed(gc)
    activate(obj)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.transform.translate(value=(0.1, 0.0, 0.0))
    bpy.ops.object.mode_set(mode='OBJECT')
    update()
    assert "'Mesh' was edited while bound" in fault_text(gc, obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    np.testing.assert_array_equal(positions(obj.data), rest)
    assert fault_text(gc, obj) == "" and not obj.gencoords.edited_while_bound
