"""The operator fuzz's short run (``make fuzz`` is the long one): fixed seeds, each case
in its own fresh Blender process with the built zip installed, every invariant checked
after every step (scripts/fuzz: no internal error, no NaN, the panel draws, refusals
change nothing, Unbind restores bitwise, a translated cage translates the mesh, a moved
mesh stays with its cage, rest and reload unchanged, a made cage binds)."""

import bpy
import numpy as np
import pytest

from scene_helpers import add_sphere, read_positions, write_positions
from scripts.fuzz import checks, run

# Cases that pass, chosen (from seeds 0-119) so that between them every step is done and
# refused, every kind binds, both bakes run, a cage translation is followed by a mesh, a
# moved mesh stays with its cage, a tight made cage binds (24), and the stories play: a
# micro cage moved by less than 1e-6 (19), the cage deleted (40), a linked copy (45), a
# bake (57); a failure prints the case's steps and its replay command.
SEEDS = (19, 24, 32, 40, 45, 57, 58, 63, 91, 93, 97, 101, 116)


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
