"""Properties of the named coordinates beyond the paper's statements (those are in
test_paper_statements.py): linear precision, symmetry, similarity invariance, the ridge
order, Wachspress' closed form (any dimension)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import gencoords
from tests.fixtures.polytopes import (cross_polytope, homogeneity_residual, octahedron, polytope_and_points,
                                      random_convex_polytope, random_interior_points, regular_polygon)
from tests.fixtures.strategies import EXAMPLES, SEEDS, SHAPES


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_linear_precision_and_partition_of_unity(seed, dim, count, kind):
    _, vertices, faces, points = polytope_and_points(seed, dim, count)
    coordinates = gencoords.coordinates(points, vertices, faces, kind=kind)
    size = np.ptp(vertices, axis=0).max()
    assert np.isfinite(coordinates).all()
    assert np.abs(coordinates.sum(axis=1) - 1.0).max() < 1e-12
    assert np.abs(coordinates @ vertices - points).max() < 1e-12 * size


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_regular_cross_polytope_centre_has_equal_coordinates(dim):
    vertices, faces = cross_polytope(dim)
    for kind in gencoords.advanced.KINDS:
        centre = gencoords.coordinates(np.zeros(dim), vertices, faces, kind=kind)
        np.testing.assert_allclose(centre, np.full((1, 2 * dim), 1.0 / (2 * dim)), atol=1e-14)


def test_coordinates_are_invariant_under_similarity_transforms():
    rng = np.random.default_rng(3)
    vertices, faces = random_convex_polytope(rng, 3, 12)
    points = random_interior_points(rng, vertices, 30)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rotation *= np.sign(np.linalg.det(rotation))  # keep orientation
    moved = lambda p: 250.0 * p @ rotation.T + [1e3, -2e3, 5e2]  # noqa: E731
    for kind in gencoords.advanced.KINDS:
        np.testing.assert_allclose(gencoords.coordinates(moved(points), moved(vertices), faces, kind=kind),
                                   gencoords.coordinates(points, vertices, faces, kind=kind), atol=1e-11)


def test_ridge_order_matches_the_columns_of_ridge_scalars():
    vertices, faces = regular_polygon(5)
    np.testing.assert_array_equal(gencoords.advanced.ridges(faces), np.arange(5)[:, None])
    vertices, faces = octahedron()
    ridges = gencoords.advanced.ridges(faces)
    assert ridges.shape == (12, 2) and (ridges[:, 0] < ridges[:, 1]).all()
    x = np.array([[0.1, 0.2, -0.1]])
    d = gencoords.advanced.ridge_scalars(x, vertices, faces, "discrete_harmonic")
    e = vertices[ridges] - x  # (r, 2, 3)
    np.testing.assert_allclose(d[0], 0.5 * np.linalg.norm(np.cross(e[:, 0], e[:, 1]), axis=1))


@given(seed=SEEDS, shape=st.sampled_from([(2, 9), (3, 12)]))
@EXAMPLES
def test_wachspress_closed_form_equals_the_construction(seed, shape):
    # The polar dual's closed form (the evaluator of Wachspress in 2D and 3D) against
    # the reciprocal-basis construction fed with the polar dual's ridge scalars: the
    # same homogeneous weights, scale included.
    from gencoords.construction.general import construct_weights, point_frame
    from gencoords.surfaces.named import named_ridge_scalars
    from gencoords.construction.polar_dual import polar_dual_terms, wachspress_polar_weights

    rng, vertices, faces, points = polytope_and_points(seed, *shape)
    cage = gencoords.advanced.validate_cage(vertices, faces)
    frame = point_frame(cage, points)
    closed_form = wachspress_polar_weights(cage, polar_dual_terms(cage), frame)
    construction = construct_weights(cage, frame, named_ridge_scalars("wachspress", frame))
    np.testing.assert_allclose(closed_form, construction, rtol=1e-9, atol=1e-12 * np.abs(construction).max())
    assert homogeneity_residual(closed_form.T, points, vertices) < 1e-12  # (frame units: scale-free)
