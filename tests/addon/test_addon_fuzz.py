"""The operator fuzz's short run (``make fuzz`` is the long one): fixed seeds, each case
in its own fresh Blender process with the built zip installed, every invariant checked
after every step (scripts/fuzz: no internal error, no NaN, the panel draws, refusals
change nothing, Unbind restores bitwise, a translated cage translates the mesh, a moved
mesh stays with its cage, rest and reload unchanged, a made cage binds)."""

import bmesh
import bpy
import numpy as np
import pytest

from scene_helpers import add_icosphere_cage, add_sphere, bind, edit_mesh, read_positions, write_positions
from scripts.fuzz import checks, run, steps

# Cases that pass, chosen again when the fuzz began to draw issue 37's features (from
# seeds 0-59 and a few later ones picked by their steps) so that between them every step
# is done; Bind, Rebind, Unbind, Apply, Bake, Show Coordinate and Make Cage are refused
# (199: a mesh object scaled to zero); every kind binds (Harmonic at resolution 4 on the
# character cage (26); Compact (14, 23), Exact (23, 41), Automatic (14, 19) and Sparse
# (43, 57); Sparse for other kinds (43: Green, 57: Wachspress)); both bakes run, Fitted
# too (23, 41, 43), and a Fitted frame range ending before it starts is refused (43); a
# tight cage is made of a tiny mesh (24) and of a flat one, and binds (272); and the
# stories play: linked copies (19, 52), the cage deleted (19), a micro cage moved by less
# than 1e-6 (23), a bake (31, 57), two Fitted bakes of one mesh (41: a second cage; 43: a
# rebind), a flat mesh object (48). A failure prints the case's steps and its replay
# command.
SEEDS = (1, 14, 19, 23, 24, 26, 31, 41, 43, 48, 52, 57, 199, 272)


def test_fixed_seeds_keep_every_invariant(package):
    results = run.play_all(list(SEEDS), jobs=2, zip_path=package)
    assert sorted(r["seed"] for r in results) == sorted(SEEDS)
    failures = [run.failure_text(r) for r in results if r["status"] != "pass"]
    assert not failures, "\n\n".join(failures)


def test_the_checks_see_a_bit_changed_a_wrong_move_and_an_internal_error(gc):
    sphere = add_sphere()
    before, positions = checks.file_state(), checks.world_positions()
    moved = read_positions(sphere.data).copy()
    moved[3, 1] = np.nextafter(moved[3, 1], np.float32(np.inf))  # one float32 step
    write_positions(sphere.data, moved)
    assert any(line.startswith(f"/meshes/{sphere.data.name}/attribute position") for line in
               checks.differences(before, checks.file_state()))
    sphere.location.x += 0.5
    bpy.context.view_layer.update()
    after = checks.world_positions()
    checks.check_moved(["Mesh"], positions, after, np.array([0.5, 0.0, 0.0]), 2.0, "moved")
    with pytest.raises(checks.Violation, match="off by 0.5"):
        checks.check_moved(["Mesh"], positions, after, np.zeros(3), 2.0, "moved")
    with pytest.raises(checks.Violation, match="no internal error"):
        checks.check_output("Error: GenCoords internal error, nothing was changed")


def test_a_follower_far_from_its_cage_is_allowed_the_cages_float32_rounding_in_its_space(gc, tmp_path):
    """Seed 2130 (before Harmonic joined the kinds): a mesh at the origin bound (Project)
    to a cage 1.7e5 away followed a translation of the cage's vertices to 0.0095, the
    float32 step there being 0.016: its deformer reads the cage in the mesh's local space
    (as Blender's Mesh Deform does). The check allows that rounding, not a wrong move."""
    cage = add_icosphere_cage(radius=1.2)
    cage.location = (-172578.1, 86289.05, -57526.03)
    mesh = add_sphere(radius=0.6)
    assert bind(mesh, cage, kind='GREEN', outside='PROJECT', storage='COMPACT') == {'FINISHED'}
    state = steps.CaseState({"mesh": mesh.name, "cage": cage.name}, tmp_path)
    move = {"op": "translate_cage", "cage": "cage", "how": "vertices", "back": True, "amount": 0.0065,
            "direction": [-0.9, 0.04, 0.8]}
    assert steps.run(state, move) == "done, followers ['Mesh']"
    before = checks.world_positions()
    with pytest.raises(checks.Violation, match="off by 0.5"):
        checks.check_moved(["Mesh"], before, before, np.array([0.5, 0.0, 0.0]), 3.8, "moved",
                           cage=before[cage.name])


def test_a_mesh_baked_to_a_reshaped_cage_and_bound_again_follows_twice_and_is_not_checked(gc):
    """Seed 2180 (before Harmonic joined the kinds): Bake to Bones, the cage subdivided, Bind
    to it again: the rig's bones still follow the cage (their vertex groups travel with
    the subdivision), so the mesh follows it along two paths, moving twice as far. The
    fuzz took the reshaped cage's rig for one that no longer follows, and the mesh for a
    single follower."""
    cage = add_icosphere_cage(radius=1.2)
    mesh = add_sphere(radius=0.6)
    assert bind(mesh, cage) == {'FINISHED'}
    with bpy.context.temp_override(object=mesh, active_object=mesh, selected_objects=[mesh]):
        assert bpy.ops.object.gencoords_bake_bones(max_influences=0) == {'FINISHED'}
    edit_mesh(cage, lambda bm: bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True))
    assert bind(mesh, cage) == {'FINISHED'}
    assert [d.name for d in steps.drivers_of(mesh)] == [cage.name, cage.name]
    assert steps.single_followers(cage, {cage.name}) == []
    before = checks.world_positions()
    cage.location.x += 0.05
    bpy.context.view_layer.update()
    checks.check_moved(["Mesh"], before, checks.world_positions(), np.array([0.1, 0.0, 0.0]), 2.4, "twice")
