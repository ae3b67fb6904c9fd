"""Binding and live deformation, driven through the operators as a script would."""

import bmesh
import bpy
import numpy as np
import pytest
from mathutils import Matrix

from scene_helpers import (activate, add_cube_cage, add_icosphere_cage, add_sphere,
                           add_subdivided_sphere, bind, edit_mesh, evaluated_cage_positions,
                           positions, set_positions, update)

KINDS = ("WACHSPRESS", "MEAN_VALUE", "DISCRETE_HARMONIC", "VORONOI")
CAGE_LINK = "GenCoords cage link"
CAGE_LINK_GROUP = ".GenCoords cage link"  # hidden from the artist's node-group menus


def random_affine(seed):
    rng = np.random.default_rng(seed)
    return np.eye(3) + 0.3 * rng.standard_normal((3, 3)), rng.standard_normal(3)


def apply_matrix(matrix, points):
    affine = np.array(matrix)
    return points @ affine[:3, :3].T + affine[:3, 3]


def to_world(obj, points):
    return apply_matrix(obj.matrix_world, points)


def test_bind_keeps_rest_and_deformation_is_coordinates_times_cage(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    assert bind(obj, cage) == {'FINISHED'}
    data = gc.storage.load(obj)
    assert data.coordinates.shape == (len(rest), len(cage.data.vertices))
    np.testing.assert_array_equal(data.rest_positions, rest)
    np.testing.assert_allclose(data.coordinates.sum(axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(positions(obj.data), rest, atol=1e-5)  # cage at rest

    noise = np.random.default_rng(0).normal(0, 0.2, (len(cage.data.vertices), 3))
    set_positions(cage.data, positions(cage.data) + noise)
    update()
    deformed = positions(obj.data)
    assert np.isfinite(deformed).all()
    np.testing.assert_array_equal(deformed, data.coordinates @ evaluated_cage_positions(cage))
    assert np.abs(deformed - rest).max() > 0.05


@pytest.mark.parametrize("kind", KINDS)
def test_affine_cage_motion_moves_the_mesh_affinely(gc, kind):
    cage = add_icosphere_cage()
    obj = add_sphere(radius=0.8)
    rest = positions(obj.data).astype(np.float64)
    assert bind(obj, cage, kind=kind) == {'FINISHED'}
    linear, shift = random_affine(1)
    set_positions(cage.data, positions(cage.data) @ linear.T + shift)
    update()
    np.testing.assert_allclose(positions(obj.data), rest @ linear.T + shift, atol=1e-5)


def test_coordinates_match_the_core_in_the_cage_space(gc):
    """Object transforms: mesh world positions are bound in the cage's local space."""
    cage = add_cube_cage(size=2.0)
    cage.matrix_world = Matrix.LocRotScale((0.5, -1.0, 2.0), Matrix.Rotation(0.4, 3, 'Z'),
                                           (2.0, 3.0, 1.5))
    obj = add_sphere(radius=0.5, location=(0.6, -0.9, 2.1))
    obj.scale = (1.2, 0.8, 1.0)
    update()
    rest = positions(obj.data).copy()
    assert bind(obj, cage, kind="WACHSPRESS") == {'FINISHED'}
    data = gc.storage.load(obj)
    world = to_world(obj, rest)
    in_cage = apply_matrix(cage.matrix_world.inverted(), world)
    triangles = np.array([t.vertices[:] for t in cage.data.loop_triangles])
    expected = gc.core.coordinates(in_cage, positions(cage.data).astype(np.float64), triangles,
                                   kind="wachspress")
    np.testing.assert_allclose(data.coordinates, expected, atol=1e-6)
    np.testing.assert_allclose(positions(obj.data), rest, atol=1e-5)
    status = [text for text, _ in gc.status.status_lines(obj)]
    assert "Cage triangulated (6 quads/n-gons)" in status

    # Moving the cage object carries the mesh along, in world space.
    cage.location.x += 1.0
    update()
    moved = to_world(obj, positions(obj.data))
    np.testing.assert_allclose(moved - world, np.tile([1.0, 0.0, 0.0], (len(world), 1)), atol=1e-5)


def test_unbind_restores_rest_bitwise_and_removes_bind_data(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    bind(obj, cage)
    text_name = obj.gencoords.bind_data.name
    set_positions(cage.data, positions(cage.data) * 1.3)
    update()
    assert not np.array_equal(positions(obj.data), rest)
    assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
    np.testing.assert_array_equal(positions(obj.data), rest)
    assert obj.gencoords.bind_data is None and text_name not in bpy.data.texts
    assert not obj.modifiers and CAGE_LINK_GROUP not in bpy.data.node_groups
    set_positions(cage.data, positions(cage.data) * 0.5)
    update()
    np.testing.assert_array_equal(positions(obj.data), rest)  # no longer follows


@pytest.mark.parametrize("corner", range(8))
def test_a_quad_cage_with_a_dragged_corner_stays_convex(gc, corner):
    """Bent quads are split along their convex diagonal, whatever Blender's own choice."""
    cage = add_cube_cage()
    cage.data.vertices[corner].co *= 1.3  # outward: the three quads at it bend
    cage.data.update()
    obj = add_sphere()
    assert bind(obj, cage, kind="WACHSPRESS") == {'FINISHED'}
    data = gc.storage.load(obj)
    np.testing.assert_allclose(data.coordinates @ positions(cage.data), positions(obj.data), atol=1e-5)


def test_a_hook_and_an_armature_on_the_cage_drive_the_mesh(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    coordinates = gc.storage.load(obj).coordinates

    handle = bpy.data.objects.new("Handle", None)
    bpy.context.scene.collection.objects.link(handle)
    hook = cage.modifiers.new("Hook", 'HOOK')
    hook.object = handle
    hook.vertex_indices_set([0, 1, 2])
    handle.location = (0.4, -0.2, 0.3)  # moving the empty moves the hooked cage vertices
    update()
    moved = evaluated_cage_positions(cage)
    assert not np.allclose(moved, positions(cage.data))
    np.testing.assert_array_equal(positions(obj.data), coordinates @ moved)
    cage.modifiers.remove(hook)

    skeleton = bpy.data.armatures.new("Skeleton")
    rig = bpy.data.objects.new("Rig", skeleton)
    bpy.context.scene.collection.objects.link(rig)
    activate(rig)
    bpy.ops.object.mode_set(mode='EDIT')
    bone = skeleton.edit_bones.new("Bone")
    bone.head, bone.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    bpy.ops.object.mode_set(mode='OBJECT')
    group = cage.vertex_groups.new(name="Bone")
    group.add(range(len(cage.data.vertices)), 1.0, 'REPLACE')
    cage.modifiers.new("Armature", 'ARMATURE').object = rig
    rig.pose.bones["Bone"].rotation_mode = 'XYZ'
    rig.pose.bones["Bone"].rotation_euler = (0.0, 0.0, 0.5)  # the whole cage turns
    update()
    posed = evaluated_cage_positions(cage)
    assert not np.allclose(posed, positions(cage.data))
    np.testing.assert_array_equal(positions(obj.data), coordinates @ posed)


def test_float32_cages_bind_a_rotated_subdivided_cube_and_a_mesh_on_the_cage(gc):
    """Flat faces after Apply Rotation are flat only to float32 precision (~1e-7)."""
    cage = add_cube_cage()
    edit_mesh(cage, lambda bm: bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=2,
                                                         use_grid_fill=True))
    cage.rotation_euler = (0.3, 0.7, 1.1)
    activate(cage)
    bpy.ops.object.transform_apply(rotation=True)
    obj = add_sphere()
    assert bind(obj, cage, kind="WACHSPRESS") == {'FINISHED'}

    # A duplicate of the cage: every vertex on its surface (boundary, not outside).
    skin = cage.copy()
    skin.data = cage.data.copy()
    bpy.context.scene.collection.objects.link(skin)
    assert bind(skin, cage, kind="WACHSPRESS") == {'FINISHED'}
    assert gc.storage.load(skin).points_on_boundary == len(skin.data.vertices)
    set_positions(cage.data, positions(cage.data) * (1.2, 0.9, 1.1))
    update()
    np.testing.assert_allclose(positions(skin.data), positions(cage.data), atol=1e-5)


def test_picking_another_cage_takes_effect_only_on_the_next_bind(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    other = cage.copy()  # same topology: a silent switch would go unnoticed
    other.data = cage.data.copy()
    bpy.context.scene.collection.objects.link(other)
    obj.gencoords.cage = other
    set_positions(other.data, positions(other.data) * 1.5)
    update()
    data = gc.storage.load(obj)
    np.testing.assert_allclose(positions(obj.data), data.coordinates @ positions(cage.data), atol=1e-6)
    assert any("Bind again" in text for text, _ in gc.status.status_lines(obj))
    assert bind(obj, other) == {'FINISHED'}
    link = obj.modifiers[CAGE_LINK]
    assert obj.gencoords.bound_cage == other
    assert link[link.node_group.interface.items_tree["Cage"].identifier] == other
    set_positions(other.data, positions(other.data) * 1.1)
    update()
    data = gc.storage.load(obj)
    np.testing.assert_allclose(positions(obj.data), data.coordinates @ positions(other.data), atol=1e-5)


def test_cage_link_makes_a_cage_hidden_from_the_depsgraph_drive_the_mesh(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    bind(obj, cage)  # rebinding replaces the link
    (link,) = obj.modifiers
    assert (link.name, link.type, link.node_group.name) == (CAGE_LINK, 'NODES', CAGE_LINK_GROUP)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    np.testing.assert_array_equal(positions(evaluated.data), positions(obj.data))

    # Disabled in viewports, the cage is evaluated only because the mesh depends on it.
    cage.hide_viewport = True
    cage.shape_key_add(name="Basis")
    key = cage.shape_key_add(name="Stretch")
    stretched = positions(cage.data) * (1.5, 1.0, 1.0)
    key.data.foreach_set("co", stretched.reshape(-1))
    key.value = 1.0
    update()
    coordinates = gc.storage.load(obj).coordinates
    np.testing.assert_allclose(positions(obj.data), coordinates @ stretched, atol=1e-6)


def test_rebind_keeps_the_original_rest_shape(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    bind(obj, cage)
    set_positions(cage.data, positions(cage.data) * 1.2)
    update()
    bind(obj, cage, kind="WACHSPRESS")  # the deformed shape is not baked in
    np.testing.assert_array_equal(gc.storage.load(obj).rest_positions, rest)
    assert len([t for t in bpy.data.texts if t.name.startswith(".GenCoords")]) == 1


def test_live_toggle_shows_rest_then_deformation(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    rest = positions(obj.data).copy()
    bind(obj, cage)
    set_positions(cage.data, positions(cage.data) * 1.5)
    update()
    deformed = positions(obj.data).copy()
    obj.gencoords.live = False
    np.testing.assert_array_equal(positions(obj.data), rest)
    set_positions(cage.data, positions(cage.data) * 1.1)
    update()
    np.testing.assert_array_equal(positions(obj.data), rest)
    obj.gencoords.live = True
    assert np.abs(positions(obj.data) - deformed * 1.1).max() < 1e-5


def test_modifiers_and_keyframed_shape_keys_on_the_cage_drive_the_mesh(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    coordinates = gc.storage.load(obj).coordinates

    displace = cage.modifiers.new("Displace", 'DISPLACE')
    displace.strength = 0.3
    update()
    expected = coordinates @ evaluated_cage_positions(cage)
    np.testing.assert_array_equal(positions(obj.data), expected)
    cage.modifiers.remove(displace)

    cage.shape_key_add(name="Basis")
    key = cage.shape_key_add(name="Stretch")
    stretched = positions(cage.data) * (1.5, 1.0, 1.0)
    key.data.foreach_set("co", stretched.reshape(-1))
    key.value = 0.0
    key.keyframe_insert("value", frame=1)
    key.value = 1.0
    key.keyframe_insert("value", frame=10)
    bpy.context.scene.frame_set(10)  # runs frame_change_post only
    np.testing.assert_allclose(positions(obj.data), coordinates @ stretched, atol=1e-6)
    bpy.context.scene.frame_set(1)
    np.testing.assert_allclose(positions(obj.data), gc.storage.load(obj).rest_positions, atol=1e-5)


def test_cage_edit_mode_changes_are_followed(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage)
    activate(cage)
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='SELECT')
    bpy.ops.transform.resize(value=(1.4, 1.4, 1.4))
    update()
    expected = gc.storage.load(obj).rest_positions * 1.4
    np.testing.assert_allclose(positions(obj.data), expected, atol=1e-5)
    bpy.ops.object.mode_set(mode='OBJECT')


def test_show_coordinate_paints_the_core_field(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage, kind="DISCRETE_HARMONIC")
    obj.gencoords.field_vertex = 3
    assert bpy.ops.object.gencoords_show_field() == {'FINISHED'}
    attribute = obj.data.color_attributes["GenCoords Field"]
    assert (attribute.domain, attribute.data_type) == ('POINT', 'FLOAT_COLOR')
    assert obj.data.color_attributes.active_color_name == "GenCoords Field"
    colors = np.empty(len(obj.data.vertices) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colors)
    expected = gc.core.field_colors(gc.storage.load(obj).coordinates[:, 3])
    np.testing.assert_array_equal(colors.reshape(-1, 4), expected)
    obj.gencoords.field_vertex = 5  # repaints while shown
    attribute.data.foreach_get("color", colors)
    expected = gc.core.field_colors(gc.storage.load(obj).coordinates[:, 5])
    np.testing.assert_array_equal(colors.reshape(-1, 4), expected)

    obj.gencoords.field_vertex = 99
    with pytest.raises(RuntimeError, match="Cage Vertex must be below 12"):
        bpy.ops.object.gencoords_show_field()
    assert bpy.ops.object.gencoords_clear_field() == {'FINISHED'}
    assert "GenCoords Field" not in obj.data.color_attributes


def test_status_reports_the_core_summary(gc):
    cage = add_icosphere_cage()
    obj = add_sphere()
    bind(obj, cage, kind="VORONOI")
    data = gc.storage.load(obj)
    summary = gc.core.coordinate_summary(data.coordinates)
    assert data.min_coordinate == summary["min"] and data.nbytes == summary["nbytes"]
    text = "\n".join(line for line, _ in gc.status.status_lines(obj))
    assert "Bound to 'Cage' (Voronoi)" in text
    assert f"Cage 12 vertices, mesh {len(obj.data.vertices)} vertices" in text
    assert f"Smallest coordinate {summary['min']:.4g}" in text
    assert "MB" in text and "Bind time" in text


def test_bind_data_is_stored_and_reported_as_float32(gc):
    cage = add_icosphere_cage(subdivisions=2)
    obj = add_subdivided_sphere(levels=2)
    bind(obj, cage)
    float32_bytes = len(obj.data.vertices) * len(cage.data.vertices) * 4
    stored = obj.gencoords.bind_data["coordinates"]
    assert stored.typecode == 'f' and len(stored) * 4 == float32_bytes
    data = gc.storage.load(obj)
    assert data.coordinates.dtype == np.float32 and data.nbytes == float32_bytes
    text = "\n".join(line for line, _ in gc.status.status_lines(obj))
    assert f"data {float32_bytes / 2**20:.2f} MB" in text


def test_bind_reports_progress_as_the_core_computes(gc):
    cage = add_icosphere_cage()
    obj = add_subdivided_sphere(levels=2)  # several of the core's chunks
    obj.gencoords.cage = cage
    fractions = []
    gc.binding.bind(obj, bpy.context.evaluated_depsgraph_get(), fractions.append)
    assert len(fractions) > 1 and fractions == sorted(fractions) and fractions[-1] == 1.0


def test_every_edit_of_a_large_cage_is_followed_on_a_dense_mesh(gc):
    """Speed is measured by scripts/bench_blender.py, not asserted here."""
    cage = add_icosphere_cage(subdivisions=3, radius=2.5)  # 642 vertices
    obj = add_subdivided_sphere(levels=3)
    bind(obj, cage)
    coordinates = gc.storage.load(obj).coordinates
    for step in range(10):
        set_positions(cage.data, positions(cage.data) * 1.01)
        update()
        np.testing.assert_array_equal(positions(obj.data), coordinates @ evaluated_cage_positions(cage))


def test_undo_and_redo_of_bind_and_unbind(gc):
    """Global undo as in the UI: the headless window's context lets ``ed.undo`` run, and
    the step the UI pushes after an undoable operator is pushed here explicitly (operators
    called from Python push none)."""
    preferences = bpy.context.preferences.edit
    preferences.use_global_undo, preferences.undo_steps = True, 32
    with bpy.context.temp_override(window=bpy.context.window_manager.windows[0]):
        cage = add_icosphere_cage()
        obj = add_sphere()
        rest = positions(obj.data).copy()
        bpy.ops.ed.undo_push(message="scene ready")
        assert bind(obj, cage) == {'FINISHED'}
        bpy.ops.ed.undo_push(message="Bind")

        assert bpy.ops.ed.undo() == {'FINISHED'}
        obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]  # undo rebuilds IDs
        assert obj.gencoords.bind_data is None and not obj.modifiers
        assert not [text for text in bpy.data.texts if text.name.startswith(".GenCoords")]
        np.testing.assert_array_equal(positions(obj.data), rest)

        assert bpy.ops.ed.redo() == {'FINISHED'}
        obj, cage = bpy.data.objects["Mesh"], bpy.data.objects["Cage"]
        assert obj.gencoords.bind_data is not None and obj.gencoords.bound_cage == cage
        set_positions(cage.data, positions(cage.data) * 1.2)
        update()
        np.testing.assert_allclose(positions(obj.data), rest * 1.2, atol=1e-5)  # live again

        activate(obj)
        assert bpy.ops.object.gencoords_unbind() == {'FINISHED'}
        bpy.ops.ed.undo_push(message="Unbind")
        np.testing.assert_array_equal(positions(obj.data), rest)
        assert bpy.ops.ed.undo() == {'FINISHED'}
        obj = bpy.data.objects["Mesh"]
        assert obj.gencoords.bind_data is not None  # bound again
        assert bpy.ops.ed.redo() == {'FINISHED'}
        obj = bpy.data.objects["Mesh"]
        assert obj.gencoords.bind_data is None
        np.testing.assert_array_equal(positions(obj.data), rest)


def test_bind_says_when_it_turns_on_lock_interface(gc, capfd):
    """Renders run frame handlers on their own thread; the artist should know why the
    interface locks during renders."""
    cage = add_icosphere_cage()
    obj = add_sphere()
    render = bpy.context.scene.render
    assert not render.use_lock_interface
    bind(obj, cage)
    assert render.use_lock_interface
    assert ("Render > Lock Interface turned on so renders read the cage safely"
            in capfd.readouterr().out)
    bind(obj, cage)
    assert "Lock Interface" not in capfd.readouterr().out
