"""The reference scenes (tests/fixtures/artist_cages.py): each cage closed, consistently
and outward oriented, around its whole mesh; the edits move only what they name; the hand
and the quadruped as close and thin as issue 35 asks."""

from collections import Counter

import numpy as np
import pytest

import gencoords
from tests.fixtures import artist_cages


@pytest.fixture(scope="module", params=sorted(artist_cages.FIXTURES))
def scene(request):
    return artist_cages.fixture(request.param, detail=0.3)


def test_cage_is_closed_consistently_outward_and_encloses_its_mesh(scene):
    triangles = scene.cage_triangles
    edges = Counter(map(tuple, np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])))
    # Each directed edge once and its reverse too: closed, manifold, consistently oriented.
    assert max(edges.values()) == 1 and all((b, a) in edges for a, b in edges)
    a, b, c = (scene.cage_vertices[triangles[:, corner]] for corner in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6 > 1e-3  # outward: positive volume
    locations = gencoords.point_locations(scene.mesh_vertices, scene.cage_vertices, triangles)
    assert (locations == gencoords.INSIDE).all()
    assert len(scene.mesh_parts) == len(scene.mesh_vertices) and scene.mesh_faces.max() < len(scene.mesh_vertices)


def test_edits_move_some_cage_vertices_and_name_mesh_vertices_that_stay(scene):
    for edit in scene.edits.values():
        moved = np.linalg.norm(edit.cage_vertices - scene.cage_vertices, axis=1) > 1e-9
        assert 0 < moved.sum() < len(moved) // 2
        assert 0 < edit.still.sum() < len(edit.still)


def _gaps(cage, planes):
    """Per pair of neighbouring finger columns, the gap between their cage vertices at
    each height of ``planes``."""
    gaps = []
    for height in planes:
        x = np.sort(cage[np.isclose(cage[:, 2], height), 0])
        steps = np.diff(np.unique(x.round(9)))
        gaps.append(steps[1::2])  # finger width, gap, finger width, ...
    return np.array(gaps)


def test_the_hand_has_five_fingers_1_60_apart_at_the_knuckles_and_1_30_at_the_tips():
    hand = artist_cages.hand(detail=0.3)
    knuckles, tips = _gaps(hand.cage_vertices, (1.0, 2.0)) / hand.diagonal
    assert len(knuckles) == 4 and np.allclose(tips, tips[0])
    assert 1 / 62 < knuckles.min() <= knuckles.max() < 1 / 58 and 1 / 32 < tips.min() < tips.max() < 1 / 28
    assert len({part for part in hand.mesh_parts if part.startswith("finger")}) == 5


def test_the_quadruped_front_legs_are_1_40_apart_and_the_tail_1_80_thick():
    animal = artist_cages.quadruped(detail=0.3)
    cage = animal.cage_vertices
    legs = cage[(cage[:, 2] < 0.3) & (cage[:, 0] > 0.4)]
    gap = 2 * np.abs(legs[:, 1]).min()  # the left legs' cage at y < 0, the right ones' at y > 0
    assert (legs[:, 1] < 0).sum() == (legs[:, 1] > 0).sum()
    assert 1 / 45 < gap / animal.diagonal < 1 / 35
    tail = cage[cage[:, 0] < -0.71]
    assert 1 / 90 < np.ptp(tail[:, 2]) / animal.diagonal < 1 / 70
    assert 1 / 90 < np.ptp(tail[:, 1]) / animal.diagonal < 1 / 70
