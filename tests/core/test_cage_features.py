"""Issue 35, item 1 (the measurement only): the narrowest gap between parts that are not
neighbours on the cage and the thinnest part, from the cage alone, on the artist's scenes."""

import pytest

from gencoords.harmonic.cage_features import narrowest_gap_and_thinnest_part, resolving_resolution
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
