"""Properties of the general construction and the named coordinates (any dimension)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gencoords
from polytopes import (cross_polytope, icosphere, octahedron, random_convex_polytope,
                       random_interior_points, regular_polygon)

SEEDS = st.integers(0, 2**32 - 1)
# (dimension, vertex count) of the random polytopes: polygons, polyhedra, 4-polytopes
SHAPES = [(2, 7), (3, 10), (4, 8)]
EXAMPLES = settings(max_examples=15, deadline=None)


def residual(weights, points, vertices):
    """max |sum_i w_i (v_i - x)| relative to the weights' size and the cage's size."""
    spokes = vertices[None, :, :] - points[:, None, :]
    size = np.ptp(vertices, axis=0).max()
    return np.abs(np.einsum("kn,knN->kN", weights, spokes)).max() / (np.abs(weights).max() * size)


def polytope_and_points(seed, dim, count, points=20):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return rng, vertices, faces, random_interior_points(rng, vertices, points)


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_arbitrary_ridge_scalars_give_homogeneous_weights(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    d = rng.normal(size=(len(points), len(gencoords.advanced.ridges(faces))))  # any sign, any size
    weights = gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, d)
    assert residual(weights, points, vertices) < 1e-11


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_arbitrary_floater_scalars_give_homogeneous_weights(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    c = rng.normal(size=(len(points), len(gencoords.advanced.ridges(faces))))
    weights = gencoords.advanced.floater_weights(points, vertices, faces, c)
    assert residual(weights, points, vertices) < 1e-10


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_floater_equals_general_construction_under_the_c_d_map(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    c = rng.uniform(0.1, 2.0, size=(len(points), len(gencoords.advanced.ridges(faces))))
    d = gencoords.advanced.ridge_scalars_from_floater(points, vertices, faces, c)
    floater = gencoords.advanced.floater_weights(points, vertices, faces, c)
    general = gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, d)
    np.testing.assert_allclose(general, floater, rtol=1e-9, atol=1e-9 * np.abs(floater).max())
    back = gencoords.advanced.floater_from_ridge_scalars(points, vertices, faces, d)
    np.testing.assert_allclose(back, c, rtol=1e-12)


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


@pytest.mark.parametrize("kind", ["wachspress", "mean_value"])
@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_wachspress_and_mean_value_are_positive_in_convex_cages(seed, dim, count, kind):
    _, vertices, faces, points = polytope_and_points(seed, dim, count)
    assert gencoords.coordinates(points, vertices, faces, kind=kind).min() > 0.0


def test_discrete_harmonic_is_negative_somewhere_in_the_regular_octahedron():
    vertices, faces = octahedron()
    grid = np.stack(np.meshgrid(*[np.linspace(-1, 1, 21)] * 3), axis=-1).reshape(-1, 3)
    inside = grid[np.abs(grid).sum(axis=1) < 0.98]
    harmonic = gencoords.coordinates(inside, vertices, faces, kind="discrete_harmonic")
    mean_value = gencoords.coordinates(inside, vertices, faces, kind="mean_value")
    assert harmonic.min() < -1e-3
    assert mean_value.min() > 0.0


@given(seed=SEEDS)
@EXAMPLES
def test_voronoi_equals_discrete_harmonic_in_2d(seed):
    _, vertices, faces, points = polytope_and_points(seed, 2, 7)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="voronoi"),
                               gencoords.coordinates(points, vertices, faces, kind="discrete_harmonic"),
                               atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3, 4])
@given(seed=SEEDS)
@EXAMPLES
def test_voronoi_equals_wachspress_exactly_when_vertices_are_cospherical(seed, dim):
    rng = np.random.default_rng(seed)
    count = {2: 7, 3: 10, 4: 8}[dim]
    directions = rng.normal(size=(count, dim))
    on_sphere = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    from polytopes import convex_hull_facets
    faces = convex_hull_facets(on_sphere)
    points = random_interior_points(rng, on_sphere, 20)
    voronoi = gencoords.coordinates(points, on_sphere, faces, kind="voronoi")
    wachspress = gencoords.coordinates(points, on_sphere, faces, kind="wachspress")
    np.testing.assert_allclose(voronoi, wachspress, atol=1e-11)
    # Off the sphere (stretched: still convex, same faces) they differ.
    stretched = on_sphere * np.linspace(0.6, 1.4, dim)
    voronoi = gencoords.coordinates(points * np.linspace(0.6, 1.4, dim), stretched, faces, kind="voronoi")
    wachspress = gencoords.coordinates(points * np.linspace(0.6, 1.4, dim), stretched, faces, kind="wachspress")
    assert np.abs(voronoi - wachspress).max() > 1e-4


def test_voronoi_equals_wachspress_on_an_icosphere_not_on_an_irregular_octahedron():
    rng = np.random.default_rng(7)
    vertices, faces = icosphere(2)
    points = 0.8 * random_interior_points(rng, vertices, 50)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="voronoi"),
                               gencoords.coordinates(points, vertices, faces, kind="wachspress"), atol=1e-12)
    vertices, faces = octahedron((1.0, 1.6, 0.7))
    points = random_interior_points(rng, vertices, 50)
    assert np.abs(gencoords.coordinates(points, vertices, faces, kind="voronoi")
                  - gencoords.coordinates(points, vertices, faces, kind="wachspress")).max() > 1e-3


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
    assert residual(closed_form.T, points, vertices) < 1e-12  # (frame units: scale-free)
