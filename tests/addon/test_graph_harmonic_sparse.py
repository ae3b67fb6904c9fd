"""Harmonic coordinates (local, positive) in sparse storage, bound through the operator as
a script binds (inside ``bpy.context.temp_override``), on the artist's non-convex
character cage: bitwise at rest, translations exact, weights never negative, other limbs
still when one limb moves; strength, mask, two cages, Unbind, Bake to Bones; sparse
storage for the other kinds; and the panel's words for mean value in a non-convex cage."""

import importlib
import re

import bpy
import numpy as np
import pytest

from scene_helpers import (add_icosphere_cage, add_sphere, evaluated_positions, read_positions, update,
                           write_positions)
from tests.fixtures import character

RESOLUTION = 24  # cells along the cage's longest side: quick, and still local


def add_character(detail=0.3):
    """The character's body (about 4,000 vertices at 0.3) and its box-modelled cage."""
    vertices, triangles, labels = character.body_mesh(detail)
    cage_vertices, quads = character.character_cage()
    return (_mesh_object("Body", vertices, triangles), _mesh_object("Cage", cage_vertices, quads),
            labels)


def _mesh_object(name, vertices, faces):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices.tolist(), [], faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def bind(obj, cage, kind="HARMONIC", storage="AUTO", **settings):
    """The Bind operator as a pipeline script calls it: settings, then an override."""
    options = obj.gencoords
    options.cage, options.kind, options.storage = cage, kind, storage
    if kind == "HARMONIC":
        options.resolution = settings.pop("resolution", RESOLUTION)
    for name, value in settings.items():
        setattr(options, name, value)
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_bind()


def unbind(obj):
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_unbind()


def result_of(gc, obj):
    return importlib.import_module(gc.core.__name__.rpartition(".")[0]).binding_result(obj)


def stored_weights(obj, key):
    """Every FLOAT attribute of the binding ``key`` (its weights), concatenated."""
    prefix = f".gencoords_{key}_"
    values = []
    for attribute in obj.data.attributes:
        if attribute.name.startswith(prefix) and attribute.data_type == 'FLOAT':
            column = np.empty(len(attribute.data), dtype=np.float32)
            attribute.data.foreach_get("value", column)
            values.append(column)
    return np.concatenate(values)


def diagonal(cage):
    points = read_positions(cage.data)
    return float(np.linalg.norm(np.ptp(points, axis=0)))


@pytest.fixture
def bound_character(gc):
    obj, cage, labels = add_character()
    rest = read_positions(obj.data).copy()
    assert bind(obj, cage) == {'FINISHED'}
    return obj, cage, labels, rest


def test_harmonic_binding_is_sparse_positive_bitwise_at_rest_and_translates_exactly(gc, bound_character):
    obj, cage, _, rest = bound_character
    result = result_of(gc, obj)
    assert (result.kind, result.storage) == ("HARMONIC", "SPARSE")
    assert result.min_coordinate >= 0.0 and result.negative_points == 0
    assert max(result.deviation_smooth, result.deviation_drag) < 1e-3  # Automatic's target
    weights = stored_weights(obj, gc.binding.binding(obj).key)
    assert len(weights) and (weights >= 0).all()
    np.testing.assert_array_equal(evaluated_positions(obj), rest)  # bitwise
    cage_rest = read_positions(cage.data).copy()
    shift = np.array([0.31, -0.17, 0.44], dtype=np.float32)
    write_positions(cage.data, cage_rest + shift)
    np.testing.assert_allclose(evaluated_positions(obj), rest + shift, atol=2e-6 * diagonal(cage))
    # Linear precision: the cage turned 30 degrees and scaled by 1.2 about its centre moves
    # the mesh by the same map (float32 rounding only), at the cage as deep inside.
    turn = np.radians(30.0)
    affine = 1.2 * np.array([[np.cos(turn), -np.sin(turn), 0.0], [np.sin(turn), np.cos(turn), 0.0], [0, 0, 1]])
    centre = cage_rest.astype(np.float64).mean(axis=0)
    write_positions(cage.data, ((cage_rest - centre) @ affine.T + centre).astype(np.float32))
    expected = (rest.astype(np.float64) - centre) @ affine.T + centre
    assert np.linalg.norm(evaluated_positions(obj) - expected, axis=1).max() < 1e-5 * diagonal(cage)
    write_positions(cage.data, cage_rest)
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    texts = [text for text, _ in gc.status.status_lines(obj)]
    assert "Harmonic" in " ".join(texts)
    # Issue 37 item 8: the nodes stored and the grid nodes solved, each said as what it is.
    data = gc.binding.binding(obj).data
    assert any(f"two levels, 8 nodes a vertex; {data.node_count} nodes stored, {data.node_slot_count} pairs each"
               in text for text in texts), texts
    # Issue 35 item 1: and what the grid resolved.
    assert any(re.search(r"In this cage: .*resolution \d+: \d+ grid nodes solved; (narrowest gap|thinnest part|no gap)"
                         r".*\)$", text) for text in texts), texts


def test_automatic_keeps_every_pair_of_few_nodes_deep_in_a_convex_cage(gc):
    """A 39,600-vertex sphere deep inside a 162-vertex icosphere: harmonic coordinates are
    not local there (128 pairs per node would deviate 3e-3), its 1,180 grid nodes are few, so
    Automatic keeps all 162 pairs per node (2 stored columns); a dragged cage vertex then
    moves the mesh as the exact coordinates do."""
    cage = add_icosphere_cage(subdivisions=3)  # Blender's third: 162 vertices
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.4, segments=200, ring_count=199)
    obj = bpy.context.active_object
    rest, cage_rest = read_positions(obj.data).copy(), read_positions(cage.data).copy()
    assert bind(obj, cage, resolution=16) == {'FINISHED'}
    result = result_of(gc, obj)
    assert (result.storage, result.node_slot_count, len(cage_rest)) == ("SPARSE", 162, 162)
    assert max(result.deviation_smooth, result.deviation_drag) < 1e-6
    assert "162 largest coordinates" in result.metadata["storage_choice"]
    moved = cage_rest.copy()
    moved[7] += np.float32(0.2 * diagonal(cage))
    write_positions(cage.data, moved)
    cage_world = cage_rest.astype(np.float64)
    triangles = np.array([tuple(polygon.vertices) for polygon in cage.data.polygons])  # an icosphere's
    field = gc.core.harmonic_field(cage_world, triangles, resolution=16, workers=1)
    expected = rest + field.coordinates(rest.astype(np.float64)) @ (moved - cage_rest).astype(np.float64)
    assert np.abs(evaluated_positions(obj) - expected).max() < 2e-5 * diagonal(cage)


@pytest.mark.parametrize("limb", ["left_arm", "right_arm", "right_leg"])
def test_moving_one_limb_leaves_the_other_limbs_still(gc, bound_character, limb):
    obj, cage, labels, rest = bound_character
    cage_rest = read_positions(cage.data).astype(np.float64)
    moved = cage_rest.copy()
    size = diagonal(cage)
    moved[character.cage_limb_vertices(cage_rest, limb)] += (0.0, -0.2 * size, 0.1 * size)
    write_positions(cage.data, moved)
    now = evaluated_positions(obj)
    others = np.isin(labels, ("left_arm", "right_arm", "left_leg", "right_leg", "head")) & (labels != limb)
    assert np.linalg.norm(now[others] - rest[others], axis=1).max() < 1e-5 * size
    assert np.linalg.norm(now[labels == limb] - rest[labels == limb], axis=1).max() > 0.05 * size


def test_strength_and_mask_scale_the_harmonic_displacement(gc, bound_character):
    obj, cage, _, rest = bound_character
    cage_rest = read_positions(cage.data).copy()
    write_positions(cage.data, cage_rest * np.float32(1.2))
    full = evaluated_positions(obj).copy()
    modifier = gc.binding.binding(obj).modifier
    gc.compat.set_modifier_input(modifier, "Strength", 0.5)
    obj.data.update()
    np.testing.assert_allclose(evaluated_positions(obj), rest + 0.5 * (full - rest), atol=1e-5)
    gc.compat.set_modifier_input(modifier, "Strength", 1.0)
    group = obj.vertex_groups.new(name="Upper")
    upper = np.flatnonzero(rest[:, 2] > 1.0)
    group.add(upper.tolist(), 1.0, 'REPLACE')
    gc.compat.set_modifier_input_attribute(modifier, "Mask", "Upper")
    obj.data.update()
    now = evaluated_positions(obj)
    lower = np.setdiff1d(np.arange(len(rest)), upper)
    np.testing.assert_array_equal(now[lower], rest[lower])  # masked out: bitwise
    np.testing.assert_allclose(now[upper], full[upper], atol=1e-6)
    gc.compat.set_modifier_input(modifier, "Invert Mask", True)
    obj.data.update()
    now = evaluated_positions(obj)
    np.testing.assert_array_equal(now[upper], rest[upper])
    np.testing.assert_allclose(now[lower], full[lower], atol=1e-6)


def test_two_harmonic_cages_compose_and_unbind_restores_bitwise(gc):
    obj, cage, _ = add_character()
    outer = add_icosphere_cage(radius=2.5, subdivisions=2, name="Outer")
    outer.location = (0.0, 0.0, 0.9)
    bpy.context.view_layer.update()
    rest = read_positions(obj.data).copy()
    before = {a.name for a in obj.data.attributes}
    assert bind(obj, cage) == {'FINISHED'}
    assert bind(obj, outer) == {'FINISHED'}
    assert [m.type for m in obj.modifiers] == ['NODES', 'NODES']
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    outer.location = (0.3, 0.0, 0.9)  # the outer cage moves the whole body with it
    bpy.context.view_layer.update()
    np.testing.assert_allclose(evaluated_positions(obj), rest + (0.3, 0.0, 0.0), atol=2e-6 * 5)
    outer.location = (0.0, 0.0, 0.9)
    bpy.context.view_layer.update()
    assert unbind(obj) == {'FINISHED'}  # Unbind All
    assert list(obj.modifiers) == [] and {a.name for a in obj.data.attributes} == before
    np.testing.assert_array_equal(read_positions(obj.data), rest)
    np.testing.assert_array_equal(evaluated_positions(obj), rest)


def test_bake_to_bones_takes_a_harmonic_binding(gc, bound_character):
    obj, cage, _, rest = bound_character
    cage_rest = read_positions(cage.data).copy()
    moved = cage_rest * np.float32(1.1) + np.float32(0.05)
    write_positions(cage.data, moved)
    bound = evaluated_positions(obj).copy()
    write_positions(cage.data, cage_rest)
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bake_bones(keyframes=False) == {'FINISHED'}
    assert [m.type for m in obj.modifiers] == ['ARMATURE']
    write_positions(cage.data, moved)
    np.testing.assert_allclose(evaluated_positions(obj), bound, atol=1e-4 * diagonal(cage))


@pytest.mark.parametrize("kind", ["MEAN_VALUE", "WACHSPRESS"])
def test_sparse_storage_keeps_the_largest_pairs_and_translations_exact(gc, kind):
    cage = add_icosphere_cage(subdivisions=2)  # 42 vertices
    obj = add_sphere()
    rest = read_positions(obj.data).copy()
    assert bind(obj, cage, kind=kind, storage="SPARSE", sparse_size=8) == {'FINISHED'}
    result = result_of(gc, obj)
    assert (result.storage, result.slot_count) == ("SPARSE", 8)
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    cage_rest = read_positions(cage.data).copy()
    write_positions(cage.data, cage_rest + np.float32(0.25))
    np.testing.assert_allclose(evaluated_positions(obj), rest + 0.25, atol=1e-6)
    # The deformation is the stored pairs' own, as the core computes them (placing each point).
    sparse = gc.core.storage.sparse
    coordinates = gc.core.coordinates(rest.astype(np.float64), cage_rest.astype(np.float64),
                                      np.array([p.vertices[:] for p in cage.data.polygons]),
                                      kind=kind.lower(), workers=1)
    indices, weights = sparse.placed_pairs(coordinates, 8, cage_rest.astype(np.float64))
    moved = cage_rest * np.float32(1.3)
    write_positions(cage.data, moved)
    expected = rest + np.einsum("pk,pkc->pc", weights, (moved - cage_rest)[indices])
    np.testing.assert_allclose(evaluated_positions(obj), expected, atol=1e-5)
    assert result.deviation_drag > 0.0  # 8 of 42 pairs: not exact, and said so


def test_mean_value_in_a_non_convex_cage_states_its_negative_share_and_points_to_harmonic(gc):
    obj, cage, _ = add_character(detail=0.2)
    assert bind(obj, cage, kind="MEAN_VALUE") == {'FINISHED'}
    lines = " ".join(text for text, _ in gc.status.status_lines(obj))
    assert "negative" in lines and "%" in lines and "Harmonic" in lines


def test_a_hidden_cage_drives_and_auto_rebind_binds_harmonic_again(gc):
    from test_bind_and_deform import subdivide_in_edit_mode

    cage = add_icosphere_cage(subdivisions=2)
    obj = add_sphere()
    obj.gencoords.auto_rebind = True
    assert bind(obj, cage, resolution=32) == {'FINISHED'}
    subdivide_in_edit_mode(obj)  # Auto Rebind binds again, with the same settings
    data = gc.binding.binding(obj).data
    assert (data.kind, data.resolution) == ("harmonic", 32)
    assert data.mesh_vertex_count == len(obj.data.vertices)
    # A few hundred vertices use more grid nodes than they are: exact storage, and why.
    assert data.storage == 'EXACT' and "fewer than the grid nodes" in data.storage_choice
    rest = read_positions(obj.data).copy()
    cage.hide_viewport = cage.hide_render = True  # hidden, it still drives the mesh
    write_positions(cage.data, read_positions(cage.data) + np.float32(0.2))
    np.testing.assert_allclose(evaluated_positions(obj), rest + 0.2, atol=1e-5)


@pytest.mark.parametrize("name,resolution", [("needle", 48), ("quadruped", 48), ("cup", 24)])
def test_the_deformer_follows_a_similarity_and_the_panel_says_how_closely(gc, name, resolution):
    """Issue 35: a needle and a quadruped's thin tail missed a turned, scaled cage by 1e-3
    of its size while the panel said 5e-9; now Blender's own evaluation of what Bind wrote
    follows it within 1e-5, and the panel's Similarity line is what a probe measures."""
    from tests.fixtures import artist_cages
    from gencoords.planning.similarity import probe_similarity
    scene = artist_cages.fixture(name, detail=0.2)
    obj = _mesh_object(name, scene.mesh_vertices, scene.mesh_faces)
    cage = _mesh_object(name + "Cage", scene.cage_vertices, scene.cage_faces)
    assert bind(obj, cage, resolution=resolution) == {'FINISHED'}
    rest = evaluated_positions(obj).astype(np.float64)
    rotation, scale, shift = probe_similarity(scene.cage_vertices)
    write_positions(cage.data, scale * scene.cage_vertices @ rotation.T + shift)
    update()
    moved = evaluated_positions(obj).astype(np.float64)
    error = np.linalg.norm(moved - (scale * rest @ rotation.T + shift), axis=1).max() / (scale * scene.diagonal)
    assert error < 1e-5
    reported = result_of(gc, obj).similarity_deviation  # as a script reads it
    assert reported == result_of(gc, obj).metadata["similarity_deviation"]
    assert reported < 1e-5 and error == pytest.approx(reported, abs=2e-6)  # float32 evaluation beside float64
    assert any(text.startswith("Similarity: ") for text, _ in gc.status.status_lines(obj))


def _other_parts_move(obj, cage, scene, edit_name):
    """Bend the cage as the edit does (through the cage's mesh, as an artist's tool writes
    it), the still vertices' largest move of the diagonal; the cage put back after."""
    rest = evaluated_positions(obj).astype(np.float64)
    edit = scene.edits[edit_name]
    write_positions(cage.data, edit.cage_vertices)
    update()
    moved = evaluated_positions(obj).astype(np.float64)
    write_positions(cage.data, scene.cage_vertices)
    update()
    return np.linalg.norm(moved[edit.still] - rest[edit.still], axis=1).max() / scene.diagonal


def test_close_fingers_stay_apart_on_the_automatic_grid_and_a_coarser_one_set_from_a_script(gc):
    """Issue 35, item 1: the hand's closest fingers are 1.0 cells apart on the automatic
    grid (48 cells; it took 59 to put 1.25 cells across before the grid parted close parts
    itself) and 0.7 at a Resolution of 32 set from a script: the panel says so, and
    bending one finger leaves the others still on both."""
    from tests.fixtures import artist_cages
    scene = artist_cages.fixture("hand", detail=0.1)
    obj = _mesh_object("Hand", scene.mesh_vertices, scene.mesh_faces)
    cage = _mesh_object("HandCage", scene.cage_vertices, scene.cage_faces)
    obj.gencoords.cage, obj.gencoords.kind = cage, "HARMONIC"
    assert obj.gencoords.automatic_resolution
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    data = gc.binding.binding(obj).data
    assert data.resolution == 48 and result_of(gc, obj).resolution == 48
    status = " ".join(text for text, _ in gc.status.status_lines(obj))
    assert "narrowest gap 1.0 cells across" in status
    assert _other_parts_move(obj, cage, scene, "bend finger") < 1e-5
    obj.gencoords.resolution = 32  # as a pipeline script sets it
    assert not obj.gencoords.automatic_resolution
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    assert gc.binding.binding(obj).data.resolution == 32
    status = " ".join(text for text, _ in gc.status.status_lines(obj))
    assert "narrowest gap 0.7 cells across" in status
    assert _other_parts_move(obj, cage, scene, "bend finger") < 1e-5


@pytest.mark.parametrize("arguments", [dict(gap=0.005), dict(gap=0.05, middle=0.05, turned=30)], ids=str)
def test_parts_pressed_together_do_not_pull_each_other_through_bpy_ops(gc, arguments):
    """Issue 35: two prongs a twentieth of a cell apart (closed lips, pressed fingers),
    and three with a part thinner than a cell between two gaps, turned across the grid:
    bound at default settings from a script, bending each prong leaves the others
    still (before: 2e-2 to 8e-2 of the diagonal)."""
    from tests.fixtures import artist_cages
    scene = artist_cages.prongs(detail=0.1, **arguments)
    obj = _mesh_object("Prongs", scene.mesh_vertices, scene.mesh_faces)
    cage = _mesh_object("ProngsCage", scene.cage_vertices, scene.cage_faces)
    obj.gencoords.cage, obj.gencoords.kind = cage, "HARMONIC"
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_bind() == {'FINISHED'}
    for name in scene.edits:
        assert _other_parts_move(obj, cage, scene, name) < 1e-5, name


def test_automatic_binds_thin_walls_with_few_pairs_a_vertex_within_the_reported_deviation(gc):
    """Issue 35 item 2: nearly every vertex of the cup lies in a cell its thin walls cut,
    so two levels would store more nodes than vertices and Automatic wrote exact storage,
    322 slots a vertex (playback 37x Mesh Deform p5's). Now it weighs each storage's
    playback estimate and writes a few pairs a vertex; Blender's evaluation of them moves
    the mesh as the core's coordinates do, within the drag deviation the panel reports."""
    from tests.fixtures import artist_cages
    scene = artist_cages.fixture("cup", detail=0.3)
    obj = _mesh_object("Cup", scene.mesh_vertices, scene.mesh_faces)
    cage = _mesh_object("CupCage", scene.cage_vertices, scene.cage_faces)
    assert bind(obj, cage, resolution=24) == {'FINISHED'}
    result = result_of(gc, obj)
    assert (result.storage, result.node_count or 0) == ("SPARSE", 0) and result.slot_count <= 16
    assert f"sparse, {result.slot_count} pairs" in result.metadata["storage_choice"]
    rest, size = evaluated_positions(obj).astype(np.float64), scene.diagonal
    field = gc.core.harmonic_field(scene.cage_vertices, scene.cage_triangles, resolution=24, workers=1,
                                   solver_tolerance=1e-6)  # Bind's
    dragged = np.zeros_like(scene.cage_vertices)
    dragged[result.metadata["deviation_drag_vertex"]] = (0.1 * size, 0.0, 0.0)  # the deviations' drag: a tenth of the diagonal
    write_positions(cage.data, scene.cage_vertices + dragged)
    update()
    expected = rest + field.coordinates(rest) @ dragged
    error = np.linalg.norm(evaluated_positions(obj) - expected, axis=1).max() / size
    assert error <= result.deviation_drag + 2e-6  # float32 evaluation
    assert error > 0.5 * result.deviation_drag  # the reported figure is this drag's
