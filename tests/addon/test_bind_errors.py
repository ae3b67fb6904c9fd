"""Bad input and faults after binding: a clear message, the mesh untouched, a way back."""

import re

import bmesh
import bpy
import numpy as np
import pytest

from scene_helpers import (make_active, add_cube_cage, add_icosphere_cage, add_sphere, bind,
                           edit_mesh, evaluated_positions, mesh_state, read_positions,
                           write_positions, update)


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
    before = mesh_state(obj)
    modifiers = [m.name for m in obj.modifiers]
    with pytest.raises(RuntimeError, match=message):
        bind(obj, cage, kind=kind)
    after = mesh_state(obj)
    np.testing.assert_array_equal(after[0], before[0])
    assert after[1] == before[1] and [m.name for m in obj.modifiers] == modifiers


@pytest.mark.parametrize(("change", "message"), [
    (open_hole, "Cage 'Cage' is not closed"),
    (add_fin, "Cage 'Cage' .*(non-manifold|not closed)"),
    (flip_normals, "inside out .*Recalculate Outside"),
])
def test_broken_cages_are_refused(gc, change, message):
    cage = add_icosphere_cage()
    edit_mesh(cage, change)
    assert_bind_refused(add_sphere(), cage, message)


def test_non_convex_cage_suggests_mean_value_and_harmonic(gc):
    cage = add_cube_cage()
    edit_mesh(cage, dent)
    obj = add_sphere(radius=0.5)
    assert_bind_refused(obj, cage, re.escape("not convex, which Wachspress coordinates need: choose "
                                             "Mean Value or Harmonic (they work on any closed cage)"),
                        kind="WACHSPRESS")
    # The faces named are the cage's own (quads an artist can select), around the dent.
    with pytest.raises(RuntimeError) as error:
        bind(obj, cage, kind="WACHSPRESS")
    named = [int(index) for index in re.search(r"faces dent inward: ([\d, ]+);", str(error.value)).group(1).split(",")]
    assert all(0 in cage.data.polygons[face].vertices for face in named)
    assert bind(obj, cage, kind="MEAN_VALUE") == {'FINISHED'}
    assert bind(obj, cage, kind="HARMONIC") == {'FINISHED'}


def test_mesh_with_an_undefined_vertex_is_refused(gc):
    obj = add_sphere()
    broken = read_positions(obj.data).copy()
    broken[5] = np.nan
    write_positions(obj.data, broken)
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
    distances = np.linalg.norm(read_positions(obj.data) + (1.5, 0, 0), axis=1)
    surely_outside = int(np.count_nonzero(distances > 2.0))  # beyond the circumsphere
    assert surely_outside > 0
    assert_bind_refused(obj, cage, r"\d+ of 114 mesh vertices lie outside the cage 'Cage': "
                                   "enlarge the cage, or set Outside to Project or Extrapolate")
    for mode, verb in (("PROJECT", "projected onto the cage"), ("EXTRAPOLATE", "extrapolated")):
        assert bind(obj, cage, outside=mode) == {'FINISHED'}
        info = gc.binding.binding(obj).data
        assert surely_outside <= info.points_outside <= np.count_nonzero(distances > 1.5)
        assert np.isfinite(evaluated_positions(obj)).all()
        assert any(f"outside the cage ({verb})" in text for text, _ in gc.status.status_lines(obj))


@pytest.mark.parametrize("kind", ["MEAN_VALUE", "HARMONIC", "GREEN"])
def test_vertices_outside_are_refused_before_any_coordinates_are_computed(gc, monkeypatch, kind):
    """Issue 37 item 12: Harmonic refused the vertices outside after solving its field
    (8.5 s of an 11.1 s Bind), the others after most of the coordinates: now before."""
    cage = add_icosphere_cage(radius=2.0)
    obj = add_sphere(radius=1.0, location=(1.5, 0, 0))

    def never(*args, **kwargs):
        raise AssertionError("coordinates computed before the refusal")

    for name in ("coordinates", "green_coordinates"):
        monkeypatch.setattr(gc.core.Cage, name, never)
    monkeypatch.setattr(gc.core.planning.bind_plan, "harmonic_field", never)
    assert_bind_refused(obj, cage, r"\d+ of 114 mesh vertices lie outside the cage 'Cage'", kind=kind)


def test_harmonic_refuses_extrapolation_in_blenders_words_before_solving_its_field(gc, monkeypatch):
    """Found by the fuzz (seed 81): Harmonic with Outside Extrapolate was refused after its
    field was solved, in the core's words ("use outside='raise' or outside='project'")."""
    def never(*args, **kwargs):
        raise AssertionError("the field solved before the refusal")

    monkeypatch.setattr(gc.core.planning.bind_plan, "harmonic_field", never)
    obj = add_sphere(radius=0.5)
    before = mesh_state(obj)
    with pytest.raises(RuntimeError, match=re.escape(
            "Harmonic coordinates do not extrapolate outside the cage: set Outside to Report Error or Project, "
            "then Bind")):
        bind(obj, add_icosphere_cage(), kind="HARMONIC", outside="EXTRAPOLATE")
    np.testing.assert_array_equal(mesh_state(obj)[0], before[0])
    assert not obj.modifiers


def fault_text(gc, obj):
    return "\n".join(text for text, icon in gc.status.status_lines(obj) if icon == 'ERROR')


def bound(gc, **cage_options):
    """A sphere bound to an icosphere cage, and the cage."""
    cage = add_icosphere_cage(**cage_options)
    obj = add_sphere()
    assert bind(obj, cage) == {'FINISHED'}
    assert fault_text(gc, obj) == ""
    return obj, cage


def assert_passed_through_and_unbind_restores(obj):
    """The deformer shows the mesh as it is, and Unbind gives back the mesh data."""
    before = mesh_state(obj)
    np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))
    make_active(obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    np.testing.assert_array_equal(mesh_state(obj)[0], before[0])
    assert not obj.modifiers


def test_bind_data_of_another_format_is_reported_not_misread(gc):
    obj, cage = bound(gc)
    gc.binding.binding(obj).group["gencoords"]["format"] = 99  # as another version wrote
    assert "another version of GenCoords: Bind again or Unbind" in fault_text(gc, obj)
    make_active(obj)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    assert not obj.modifiers


def test_deleting_the_cage_passes_the_mesh_through_and_unbind_restores(gc):
    obj, cage = bound(gc)
    write_positions(cage.data, read_positions(cage.data) * 1.2)
    assert not np.array_equal(evaluated_positions(obj), read_positions(obj.data))
    bpy.data.objects.remove(cage)
    update()
    assert "The cage 'Cage' was deleted: the mesh is not deformed" in fault_text(gc, obj)
    assert_passed_through_and_unbind_restores(obj)


@pytest.mark.parametrize(("change", "message"), [
    (subdivide, "The cage 'Cage' now has 42 vertices \\(bound with 12\\)"),
    (rotate_an_edge, "The faces of cage 'Cage' changed since Bind"),
])
def test_cage_topology_change_is_reported_until_rebind(gc, change, message):
    obj, cage = bound(gc)
    edit_mesh(cage, change)
    update()
    assert re.search(message, fault_text(gc, obj))
    if change is subdivide:  # the deformer sees the count and passes the mesh through
        np.testing.assert_array_equal(evaluated_positions(obj), read_positions(obj.data))
    assert bind(obj, cage) == {'FINISHED'}
    assert fault_text(gc, obj) == ""
    assert gc.binding.binding(obj).data.cage_vertex_count == len(cage.data.vertices)


def test_mesh_topology_change_is_reported_and_passed_through(gc):
    obj, cage = bound(gc)
    edit_mesh(obj, lambda bm: bmesh.ops.delete(bm, geom=[bm.verts[:][0]], context='VERTS'))
    write_positions(cage.data, read_positions(cage.data) * 1.3)
    assert "Mesh edited since Bind: 1 vertices deleted" in fault_text(gc, obj)
    with pytest.raises(RuntimeError, match="edited since Bind"):
        bpy.ops.object.gencoords_show_field()
    assert_passed_through_and_unbind_restores(obj)


def test_non_finite_cage_positions_leave_the_mesh_alone(gc):
    obj, cage = bound(gc)
    broken = read_positions(cage.data).copy()
    broken[0] = np.nan
    write_positions(cage.data, broken)
    update()
    assert "undefined (NaN or infinite)" in fault_text(gc, obj)
    assert np.isfinite(evaluated_positions(obj)).all()
    assert_passed_through_and_unbind_restores(obj)


def test_cage_with_a_loose_vertex_is_refused(gc):
    cage = add_icosphere_cage()
    edit_mesh(cage, lambda bm: bm.verts.new((0.0, 0.0, 0.1)))
    assert_bind_refused(add_sphere(), cage, re.escape(
        "Cage 'Cage' has vertices that belong to no face: use Mesh > Clean Up > Delete Loose "
        "(vertices 12)"))


@pytest.mark.parametrize("keep", ["edges", "nothing"])
def test_a_cage_without_faces_is_refused(gc, keep):
    cage = add_icosphere_cage()
    context = 'FACES_ONLY' if keep == "edges" else 'VERTS'
    edit_mesh(cage, lambda bm: bmesh.ops.delete(
        bm, geom=bm.faces[:] if keep == "edges" else bm.verts[:], context=context))
    assert_bind_refused(add_sphere(), cage, "The cage 'Cage' has no faces")


def test_a_mesh_and_its_cage_cannot_drive_each_other(gc):
    outer = add_icosphere_cage(name="Outer")
    inner = add_sphere(name="Inner")
    assert bind(inner, outer) == {'FINISHED'}
    assert_bind_refused(outer, inner, re.escape(
        "'Inner' is itself bound to 'Outer': a mesh and its cage cannot drive each other"))


def test_a_linked_library_object_is_refused(gc, tmp_path):
    add_icosphere_cage()
    add_sphere()
    library = str(tmp_path / "library.blend")
    bpy.data.libraries.write(library, set(bpy.data.objects))
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(library, link=True) as (source, target):
        target.objects = ["Mesh"]
    linked = target.objects[0]
    bpy.context.scene.collection.objects.link(linked)
    make_active(linked)
    with pytest.raises(RuntimeError, match="'Mesh' is linked from the library .* and cannot "
                                           "be changed: use Object > Library Override"):
        bpy.ops.object.gencoords_bind()
    assert not linked.modifiers


def test_status_names_negative_coordinates_only_when_there_are_some(gc):
    cage = add_icosphere_cage(radius=2.0)
    obj = add_sphere(radius=1.0, location=(1.5, 0, 0))  # partly outside: extrapolated, negative
    assert bind(obj, cage, outside="EXTRAPOLATE") == {'FINISHED'}
    info = gc.binding.binding(obj).data
    assert info.negative_points > 0 and info.min_coordinate < 0.0
    lines = gc.status.status_lines(obj)
    share = 100 * info.negative_points / info.mesh_vertex_count
    of_all = 100 * info.negative_entries / (info.mesh_vertex_count * info.cage_vertex_count)
    expected = (f"{share:.3g} % of vertices have negative weights, {of_all:.3g} % of all coordinates "
                f"(smallest {info.min_coordinate:.3g})")
    assert (expected, 'INFO') in lines
    assert ("Vertices outside the cage are extrapolated: parts of the mesh may move against the cage",
            'BLANK1') in lines
    assert not [text for text, icon in lines if icon == 'ERROR']  # a bound mesh that deforms
    inside = add_sphere(radius=0.5)  # well inside: mean value coordinates are positive
    assert bind(inside, cage) == {'FINISHED'}
    info = gc.binding.binding(inside).data
    assert info.negative_points == 0 and info.min_coordinate > 0.0
    lines = gc.status.status_lines(inside)
    assert (f"Smallest coordinate: {info.min_coordinate:.4g}", 'CHECKMARK') in lines
    assert not any("negative" in text for text, _ in lines)


def test_scripts_bind_through_the_service_and_catch_one_error_family(gc):
    obj = add_sphere()
    with pytest.raises(gc.errors.GenCoordsError, match="Choose a cage for 'Mesh' first"):
        gc.service.bind(obj, bpy.context)
    assert not obj.modifiers
    cage = add_icosphere_cage()
    obj.gencoords.cage = cage
    report = gc.service.bind(obj, bpy.context)
    assert report.level == 'INFO' and report.message.startswith("Bound 'Mesh' (")
    assert gc.binding.binding(obj, cage).data.mesh_vertex_count == len(obj.data.vertices)
    for error in (gc.errors.BindError, gc.errors.BakeError, gc.errors.CageError):
        assert issubclass(error, gc.errors.GenCoordsError)


def test_a_harmonic_grid_too_large_for_memory_is_refused_before_solving(gc):
    """Resolution 512 in a 162-vertex cage would need hundreds of GiB: Bind says so and
    offers a Resolution that fits, instead of failing inside the solve (issue 35)."""
    cage = add_icosphere_cage(subdivisions=3)
    obj = add_sphere()
    obj.gencoords.resolution = 512
    assert_bind_refused(obj, cage, r"Resolution 512 would need about [\d.]+ GiB.* GiB are free: Resolution \d+ fits",
                        kind="HARMONIC")
