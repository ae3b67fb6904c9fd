"""Skinning weights from coordinates (gencoords.skinning.skinning): what Bake to Bones writes."""

import numpy as np
import pytest

import gencoords
from gencoords.skinning import skinning
from gencoords.storage import deviations
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


@pytest.fixture
def cage():
    rng = np.random.default_rng(4)
    vertices, faces = random_convex_polytope(rng, 3, 14)
    points = random_interior_points(rng, vertices, 60)
    return vertices, faces, points


def test_all_weights_on_the_bind_time_cage_skin_exactly(cage):
    vertices, faces, points = cage
    coordinates = gencoords.coordinates(points, vertices, faces, kind="mean_value")
    moved = deviations.smooth_test_motion(vertices)
    assert skinning.deviation(coordinates, vertices, coordinates, vertices, moved) < 1e-12
    np.testing.assert_allclose(points + skinning.skin(coordinates, vertices, moved),
                               coordinates @ moved, atol=1e-12)


def test_bones_resting_elsewhere_than_the_bind_time_cage_deviate(cage):
    """Issue 19 item 1: bones on the cage as it is now, not as it was at Bind."""
    vertices, faces, points = cage
    coordinates = gencoords.coordinates(points, vertices, faces, kind="mean_value")
    edited = deviations.smooth_test_motion(vertices)
    moved = edited + 0.1
    assert skinning.deviation(coordinates, vertices, coordinates, edited, moved) > 0.05


def test_truncation_keeps_the_largest_weights_renormalised(cage):
    vertices, faces, points = cage
    coordinates = gencoords.coordinates(points, vertices, faces, kind="wachspress")
    weights = skinning.truncate(coordinates, 4)
    assert (np.count_nonzero(weights, axis=1) <= 4).all()
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    largest = np.sort(np.argsort(-coordinates, axis=1)[:, :4], axis=1)
    kept = np.sort(np.argsort(-weights, axis=1)[:, :4], axis=1)
    np.testing.assert_array_equal(kept, largest)
    np.testing.assert_array_equal(skinning.truncate(coordinates, 0), coordinates)
    moved = deviations.smooth_test_motion(vertices)
    assert skinning.deviation(coordinates, vertices, weights, vertices, moved) == pytest.approx(
        deviations.deviation(coordinates, weights, np.eye(len(vertices)), vertices, moved))


def test_negative_weights_are_counted_beyond_the_tolerance():
    weights = np.array([[0.5, 0.6, -0.1], [1.0, 0.0, -1e-7], [0.2, 0.8, 0.0]])
    assert skinning.negative_weights(weights) == (1, pytest.approx(-0.1))
    assert skinning.negative_weights(np.zeros((0, 3))) == (0, 0.0)


def test_clamped_weights_skin_as_blender_normalises_them(cage):
    """Vertex groups clamp negative weights to 0; Blender's Armature modifier divides by
    the row sum, and so does ``skin``; rows with no weight stay put."""
    vertices, _, _ = cage
    weights = np.array([[0.6, 0.6] + [0.0] * 12, [0.0] * 14])
    moved = vertices + np.arange(14)[:, None]
    displacement = skinning.skin(weights, vertices, moved)
    np.testing.assert_allclose(displacement, [[0.5, 0.5, 0.5], [0.0, 0.0, 0.0]])


def test_truncation_on_the_cage_places_the_points_that_their_bones_surround(cage):
    vertices, faces, points = cage
    coordinates = gencoords.coordinates(points, vertices, faces, kind="wachspress")
    plain, placed = skinning.truncate(coordinates, 8), skinning.truncate(coordinates, 8, vertices)
    np.testing.assert_array_equal(placed != 0, plain != 0)  # the same bones
    assert placed.min() >= 0.0
    np.testing.assert_allclose(placed.sum(axis=1), 1.0, atol=1e-12)
    # A turned and scaled cage: the placed skin follows exactly where the kept bones
    # surround the point, and never worse than the plain truncation.
    turn = np.linalg.qr(np.array([[1.0, 2.0, 0.5], [-2.0, 1.0, 0.3], [0.2, -1.0, 1.0]]))[0] * 1.3
    moved = vertices @ turn.T
    miss = np.linalg.norm(placed @ moved - points @ turn.T, axis=1)
    plain_miss = np.linalg.norm(plain @ moved - points @ turn.T, axis=1)
    assert (miss <= plain_miss + 1e-12).all() and np.mean(miss < 1e-12) > 0.5 and plain_miss.min() > 1e-6
