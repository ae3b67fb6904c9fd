"""The artist's character fixture (tests/fixtures/character.py): a closed, outward,
non-convex quad cage with every body vertex strictly inside it."""

from collections import Counter

import numpy as np
import pytest

import gencoords
from tests.fixtures import character


def _triangles():
    vertices, quads = character.character_cage()
    return vertices, gencoords.cages.triangulate_quads(vertices, quads)


def test_cage_is_closed_manifold_and_outward():
    vertices, triangles = _triangles()
    assert 150 <= len(vertices) <= 300
    edges = Counter(map(tuple, np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                                triangles[:, [2, 0]]])))
    assert max(edges.values()) == 1 and all((b, a) in edges for a, b in edges)
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6 > 0.1  # outward: positive volume


def test_cage_is_not_convex():
    vertices, triangles = _triangles()
    a, b, c = (vertices[triangles[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    heights = np.einsum("vj,fj->vf", vertices, normals) - np.einsum("fj,fj->f", a, normals)
    assert (heights.max(axis=0) > 1e-9).any()  # some vertex lies beyond some face's plane


def test_body_is_inside_the_cage_and_labelled():
    vertices, triangles = _triangles()
    body, body_triangles, labels = character.body_mesh(detail=0.3)
    assert (gencoords.point_locations(body, vertices, triangles) == gencoords.INSIDE).all()
    assert set(labels) == set(character.LIMBS)
    assert (character.limb_labels(body) == labels).mean() > 0.9  # the shells overlap at the joints
    points = character.body_points(500, seed=1)
    assert (gencoords.point_locations(points, vertices, triangles) == gencoords.INSIDE).all()
    for limb in ("left_arm", "right_arm", "left_leg", "right_leg", "head"):
        assert len(character.cage_limb_vertices(vertices, limb)) >= 8


def test_the_bent_forearm_turns_only_the_forearm_rigidly_about_the_elbow():
    vertices, _ = character.character_cage()
    bent, rotation = character.bent_forearm(vertices, 60.0)
    moved = np.flatnonzero(np.linalg.norm(bent - vertices, axis=1) > 1e-12)
    assert set(moved) <= set(character.cage_limb_vertices(vertices, "left_arm"))
    assert np.allclose(rotation @ rotation.T, np.eye(3)) and np.isclose(np.linalg.det(rotation), 1.0)
    distances = np.linalg.norm(vertices[moved] - character.ELBOW, axis=1)
    assert np.allclose(np.linalg.norm(bent[moved] - character.ELBOW, axis=1), distances)
    assert (bent[moved, 2] > vertices[moved, 2]).all()  # the hand goes up


@pytest.mark.parametrize("pose", ["bent knee", "swung leg"])
def test_the_leg_poses_turn_the_lower_leg_rigidly_about_its_joint_on_float32_cages_too(pose):
    """Issue 35's knee and groin: the left leg's vertices below the joint's plane (and the
    knee's own plane) turn about the x axis through the joint, the rest stay; the same
    vertices move when the cage is read back from Blender as float32."""
    function, joint = character.LEG_POSES[pose]
    vertices, _ = character.character_cage()
    bent, rotation = function(vertices)
    moved = np.flatnonzero(np.linalg.norm(bent - vertices, axis=1) > 1e-12)
    assert set(moved) <= set(character.cage_limb_vertices(vertices, "left_leg", beyond=1.0))
    assert len(moved) == (16 if pose == "bent knee" else 24)  # at and below z 0.4, and 0.6
    assert np.allclose(rotation @ rotation.T, np.eye(3)) and np.allclose(rotation[0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(bent[moved] - joint, (vertices[moved] - joint) @ rotation.T, atol=1e-12)
    low = vertices[moved, 2] < joint[2] - 0.1
    assert ((bent[moved, 1] > 0.1) if pose == "bent knee" else (bent[moved, 1] < -0.1))[low].all()  # foot back, leg forward
    float32, _ = function(vertices.astype(np.float32).astype(np.float64))  # 0.6 reads back 2.4e-8 above
    assert np.array_equal(np.flatnonzero(np.linalg.norm(float32 - vertices, axis=1) > 1e-6), moved)
