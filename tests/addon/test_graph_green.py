"""Green coordinates as a deformer type: bound through the operator as a script binds
(inside ``bpy.context.temp_override``), checked against the repository's core computed
independently, for exact and compact storage."""

import importlib

import bpy
import numpy as np
import pytest

import gencoords
from gencoords.construction.green_deform import green_displacements
from gencoords.storage.compact import smooth_test_motion
from scene_helpers import (add_icosphere_cage, add_subdivided_sphere, evaluated_positions, read_positions,
                           write_positions)


def bind_green(obj, cage, storage="EXACT", compact_size=36, outside="RAISE"):
    """The Bind operator as a pipeline script calls it: settings, then an override."""
    settings = obj.gencoords
    settings.cage, settings.kind, settings.outside = cage, "GREEN", outside
    settings.storage, settings.compact_size = storage, compact_size
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return bpy.ops.object.gencoords_bind()


def cage_arrays(cage):
    faces = np.array([list(polygon.vertices) for polygon in cage.data.polygons])
    return read_positions(cage.data).astype(np.float64), faces


def similarity(points, seed=3):
    rng = np.random.default_rng(seed)
    rotation, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    return 1.4 * points @ rotation.T + np.array([0.3, -0.2, 0.5])


def assert_bitwise_at_rest_and_follows_a_similarity(obj, cage, rest):
    """The bound mesh ``obj`` (``rest``: its vertices) is unchanged bitwise with ``cage`` at
    rest, follows a similarity of the cage exactly, and is bitwise back with it."""
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    vertices, _ = cage_arrays(cage)
    write_positions(cage.data, similarity(vertices))
    np.testing.assert_allclose(evaluated_positions(obj), similarity(rest), atol=2e-5)
    write_positions(cage.data, vertices)
    np.testing.assert_array_equal(evaluated_positions(obj), rest)


@pytest.mark.parametrize("storage", ["EXACT", "COMPACT"])
def test_green_binding_is_bitwise_at_rest_and_follows_similarities_exactly(gc, storage):
    cage = add_icosphere_cage(subdivisions=2)  # 42 vertices, 80 triangles
    obj = add_subdivided_sphere(levels=2)  # 1922 vertices
    rest = read_positions(obj.data).astype(np.float64)
    assert bind_green(obj, cage, storage=storage, compact_size=24) == {'FINISHED'}
    info = gc.binding.binding(obj).data
    result = importlib.import_module(gc.core.__name__.rpartition(".")[0]).binding_result(obj)
    assert (result.kind, result.storage, result.gamma) == ("GREEN", storage, None)
    slots = 42 + 80 if storage == "EXACT" else 24
    assert (info.kind, info.storage, info.slot_count, info.cage_face_count) == \
        ("green", storage, slots, 80)
    assert_bitwise_at_rest_and_follows_a_similarity(obj, cage, rest)


def test_green_deformation_equals_the_core_and_keeps_shape_better_than_mean_value(gc):
    cage = add_icosphere_cage(subdivisions=1)
    obj = add_subdivided_sphere(levels=1)
    rest = read_positions(obj.data).astype(np.float64)
    vertices, faces = cage_arrays(cage)
    assert bind_green(obj, cage) == {'FINISHED'}
    moved = vertices * [1.6, 1.0, 1.0] + np.random.default_rng(0).normal(0.0, 0.05, vertices.shape)
    write_positions(cage.data, moved)
    phi, psi = gencoords.green_coordinates(rest, vertices, faces)  # independently, in float64
    expected = gencoords.green_deform(phi, psi, vertices, moved, faces)
    deformed = evaluated_positions(obj)
    np.testing.assert_allclose(deformed, expected, atol=5e-6 * np.ptp(vertices, axis=0).max())
    # Mean value follows the same cage affinely: the stretch shears the sphere's details.
    mean_value = gencoords.coordinates(rest, vertices, faces) @ moved
    assert np.abs(deformed - mean_value).max() > 0.01


def test_compact_green_reports_the_deviation_of_what_it_wrote(gc):
    cage = add_icosphere_cage(subdivisions=2)
    obj = add_subdivided_sphere(levels=2)
    rest = read_positions(obj.data).astype(np.float64)
    vertices, faces = cage_arrays(cage)
    assert bind_green(obj, cage, storage="COMPACT", compact_size=36) == {'FINISHED'}
    info = gc.binding.binding(obj).data
    moved = smooth_test_motion(vertices)
    write_positions(cage.data, moved)
    phi, psi = gencoords.green_coordinates(rest, vertices, faces)
    exact = rest + np.hstack([phi, psi]) @ green_displacements(vertices, moved, faces)
    diagonal = np.linalg.norm(np.ptp(vertices, axis=0))
    measured = np.linalg.norm(evaluated_positions(obj) - exact, axis=1).max() / diagonal
    assert 0.0 < info.deviation_smooth and abs(measured - info.deviation_smooth) < 1e-5
    text = "\n".join(line for line, _ in gc.status.status_lines(obj))
    assert "Coordinates: Green" in text and "Storage: Compact, 36 per vertex" in text


def test_green_works_in_a_non_convex_cage_and_in_a_mirrored_object(gc):
    cage = add_icosphere_cage(subdivisions=2)
    vertices, faces = cage_arrays(cage)
    dented = vertices.copy()
    dented[0] *= 0.6  # a dent: the cage is no longer convex
    write_positions(cage.data, dented)
    obj = add_subdivided_sphere(levels=1)
    obj.scale = (-1.0, 1.0, 1.0)  # mirrored: the cage is inside out in the mesh's space
    bpy.context.view_layer.update()
    rest = read_positions(obj.data).astype(np.float64)
    assert bind_green(obj, cage) == {'FINISHED'}
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    write_positions(cage.data, dented * 1.3)  # a uniform scale, seen mirrored from the mesh
    np.testing.assert_allclose(evaluated_positions(obj), rest * 1.3, atol=2e-5)


def test_green_refuses_extrapolation_and_bake_to_bones_with_clear_messages(gc):
    cage = add_icosphere_cage(subdivisions=1)
    obj = add_subdivided_sphere(levels=1)
    with pytest.raises(RuntimeError, match="Green coordinates do not extrapolate"):
        bind_green(obj, cage, outside="EXTRAPOLATE")
    assert not obj.modifiers
    assert bind_green(obj, cage) == {'FINISHED'}
    modifiers = [m.type for m in obj.modifiers]
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        with pytest.raises(RuntimeError, match="Green coordinates.*Bind with another Type"):
            bpy.ops.object.gencoords_bake_bones()
    assert [m.type for m in obj.modifiers] == modifiers and not bpy.data.armatures


def test_show_coordinate_paints_green_phi_and_a_second_cage_composes(gc):
    cage = add_icosphere_cage(subdivisions=2)
    obj = add_subdivided_sphere(levels=1)
    rest = read_positions(obj.data).astype(np.float64)
    vertices, faces = cage_arrays(cage)
    assert bind_green(obj, cage) == {'FINISHED'}
    obj.gencoords.field_vertex = 4
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        assert bpy.ops.object.gencoords_show_field() == {'FINISHED'}
    colors = np.empty(len(obj.data.vertices) * 4, dtype=np.float32)
    obj.data.color_attributes["GenCoords Field"].data.foreach_get("color", colors)
    phi, _ = gencoords.green_coordinates(rest, vertices, faces)
    np.testing.assert_allclose(colors.reshape(-1, 4), gc.core.reports.field_colors(phi[:, 4]), atol=2e-3)
    # A second Green binding, to an outer cage, after the first: at rest both change nothing.
    second = add_icosphere_cage(subdivisions=2, radius=2.5, name="Outer")
    assert bind_green(obj, second) == {'FINISHED'}
    assert [m.type for m in obj.modifiers] == ['NODES', 'NODES']
    np.testing.assert_array_equal(evaluated_positions(obj), rest)
    write_positions(second.data, read_positions(second.data) + (0.0, 0.5, 0.0))
    write_positions(cage.data, similarity(vertices))
    np.testing.assert_allclose(evaluated_positions(obj), similarity(rest) + (0.0, 0.5, 0.0), atol=3e-5)


def test_the_group_does_not_grow_with_the_slots_and_big_bindings_deform_exactly(gc):
    """Green exact storage in cages of 42 and 162 vertices (122 and 482 slots: chunks of
    64, 16, 4 and 1 triples, graph/chunks.py): the binding's group keeps its size (Bind
    builds it in a fraction of a second) and deforms as a small one does."""
    size = {}
    for subdivisions, slots in ((2, 42 + 80), (3, 162 + 320)):
        cage = add_icosphere_cage(subdivisions=subdivisions, name=f"Cage {slots}")
        obj = add_subdivided_sphere(levels=2, name=f"Mesh {slots}")
        rest = read_positions(obj.data).astype(np.float64)
        assert bind_green(obj, cage) == {'FINISHED'}
        found = gc.binding.binding(obj)
        assert found.data.slot_count == slots
        # Blender 4.2's Remove Named Attribute has no wildcard: there the group strips its
        # attributes one node each (compat.set_wildcard_removal), which the count leaves out.
        removals = [n for n in found.group.nodes if n.bl_idname == 'GeometryNodeRemoveAttribute']
        assert len(removals) == 1 or "Pattern Mode" not in removals[0].inputs
        # The cage's constants (its rest positions, its triangles) grow with it, 64 to an
        # Index Switch (Builder.index_switch): left out, as the nodes choosing among them.
        switches = [n for n in found.group.nodes if n.bl_idname == 'GeometryNodeIndexSwitch']
        assert max(len(n.index_switch_items) for n in switches) <= 64
        # The rest cage, 162 vertices over three switches and one choosing, reads back whole.
        np.testing.assert_array_equal(found.rest_cage, read_positions(cage.data))
        constants = set(switches) | {link.from_node for n in switches for link in n.inputs[0].links
                                     if link.from_node.bl_idname == 'ShaderNodeMath'}
        constants |= {link.from_node for n in list(constants) if n.bl_idname == 'ShaderNodeMath'
                      for link in n.inputs[0].links if link.from_node.bl_idname == 'ShaderNodeMath'}
        size[slots] = (len(found.group.nodes) - len(removals) - len(constants),
                       len(found.group.links) - len(removals) - sum(link.to_node in constants
                                                                    for link in found.group.links))
        assert_bitwise_at_rest_and_follows_a_similarity(obj, cage, rest)
    (small_nodes, small_links), (big_nodes, big_links) = size[122], size[482]
    assert big_nodes - small_nodes <= 6 and big_links - small_links <= 12  # 4 times the slots


def test_a_low_poly_prop_in_a_detailed_cage_binds_green_and_follows_similarities_exactly(gc):
    """50 mesh vertices in a 162-vertex cage of 320 triangles: the group keeps the cage's
    triangles itself (they were kept on the mesh's first m vertices, so the mesh needed
    320), exact storage (compact keeps its basis on the mesh: nothing to save)."""
    cage = add_icosphere_cage(subdivisions=3)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=5, radius=1.0)
    obj = bpy.context.active_object
    rest = read_positions(obj.data).astype(np.float64)
    assert len(rest) == 50
    assert bind_green(obj, cage, storage="AUTO") == {'FINISHED'}
    info = gc.binding.binding(obj).data
    assert (info.storage, info.slot_count, info.cage_face_count) == ('EXACT', 162 + 320, 320)
    assert not [a.name for a in obj.data.attributes if a.name == info.triangle_name]
    assert_bitwise_at_rest_and_follows_a_similarity(obj, cage, rest)


def test_constants_over_many_index_switches_choose_through_every_level(gc, monkeypatch):
    """With 4 constants to an Index Switch (64 in the add-on), a 42-vertex cage's rest
    positions and 80 triangles take three levels of switches choosing among switches:
    the binding is bitwise at rest, follows a similarity, and its rest cage reads back."""
    builder = importlib.import_module(gc.core.__name__.rpartition(".")[0] + ".gencoords_addon.graph.builder")
    monkeypatch.setattr(builder, "SWITCH_ITEMS", 4)
    cage = add_icosphere_cage(subdivisions=2)
    obj = add_subdivided_sphere(levels=2)
    rest = read_positions(obj.data).astype(np.float64)
    assert bind_green(obj, cage) == {'FINISHED'}
    found = gc.binding.binding(obj)
    switches = [n for n in found.group.nodes if n.bl_idname == 'GeometryNodeIndexSwitch']
    assert max(len(n.index_switch_items) for n in switches) <= 4 and len(switches) > 11 + 3 + 1
    np.testing.assert_array_equal(found.rest_cage, read_positions(cage.data))
    assert_bitwise_at_rest_and_follows_a_similarity(obj, cage, rest)
