"""Issue 35, item 1: the narrowest gap between parts that are not neighbours on the cage
and the thinnest part, from the cage alone, on the artist's scenes, and the automatic
grid Bind takes from them."""

import numpy as np
import pytest

from gencoords.harmonic import harmonic_quad_field
from gencoords.harmonic.cage_features import (CELLS_ACROSS_GAP, automatic_resolution, narrowest_gap_and_thinnest_part,
                                              resolving_resolution)
from tests.fixtures import artist_cages


@pytest.mark.parametrize("name,gap,thickness", [
    ("hand", (1 / 60, 1 / 45), (1 / 20, 1 / 10)),  # the fingers' gaps widen from 1/60 to 1/30
    ("quadruped", (1 / 41, 1 / 39), (1 / 81, 1 / 78)),  # the front legs; the tail
    ("cup", (1 / 3, 1), (1 / 71, 1 / 68)),  # across the cup's inside; its wall
    ("cape", (None, None), (1 / 29, 1 / 27)),  # one part: no gap
])
def test_gaps_and_thin_parts_are_measured_from_the_cage(name, gap, thickness):
    scene = artist_cages.fixture(name, detail=0.1)
    found_gap, found_thickness = narrowest_gap_and_thinnest_part(scene.cage_vertices, scene.cage_triangles)
    if gap[0] is None:
        assert found_gap == float("inf")
    else:
        assert gap[0] < found_gap / scene.diagonal < gap[1]
    assert thickness[0] < found_thickness / scene.diagonal < thickness[1]
    # Two cells across the smaller: finer grids for close or thin parts.
    assert resolving_resolution(scene.cage_vertices, scene.cage_triangles) > 40


def _leak(scene, edit, resolution):
    field = harmonic_quad_field(scene.cage_vertices, scene.cage_faces, resolution=resolution)
    moved = field.coordinates(scene.mesh_vertices) @ scene.edits[edit].cage_vertices - scene.mesh_vertices
    return np.linalg.norm(moved[scene.edits[edit].still], axis=1).max() / scene.diagonal


def test_an_automatic_grid_puts_enough_cells_across_the_gap_for_close_legs_to_stay_apart():
    """The rule measured on the quadruped: at 32 cells its front legs (0.95 cells apart)
    pull each other; the automatic grid (asked for from a floor of 24) puts 1.25 cells
    across and a bent leg leaves the other still."""
    scene = artist_cages.fixture("quadruped", detail=0.1)
    choice = automatic_resolution(scene.cage_vertices, scene.cage_triangles, floor=24)
    assert choice.gap_cells >= CELLS_ACROSS_GAP and 24 < choice.resolution <= 48 and not choice.capped
    assert choice.thinnest_cells < 1.0  # the tail, reported: thin parts need no cells of their own
    assert _leak(scene, "bend leg", 32) > 1e-3
    assert _leak(scene, "bend leg", choice.resolution) < 1e-5


def test_a_gap_finer_than_the_ceiling_allows_is_said_to_be_capped():
    scene = artist_cages.fixture("hand", detail=0.1)
    capped = automatic_resolution(scene.cage_vertices, scene.cage_triangles, ceiling=32)
    assert capped.resolution == 32 and capped.capped and capped.gap_cells < 1.0
    assert "parts this close may pull each other" in capped.words()
    free = automatic_resolution(scene.cage_vertices, scene.cage_triangles)
    assert free.resolution == 59 and not free.capped and "narrowest gap 1.3 cells across" == free.words()
