"""The power family: one exponent through Wachspress, mean value (2D) and Voronoi."""

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points

SHAPES = [(2, 8), (3, 14), (4, 9)]


def polytope(dim, count, seed=1):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return vertices, faces, random_interior_points(rng, vertices, 40)


@pytest.mark.parametrize("dim,count", SHAPES)
@pytest.mark.parametrize("gamma,named", [(-1.0, "wachspress"), (1.0, "voronoi")])
def test_power_minus_one_is_wachspress_and_one_is_voronoi(dim, count, gamma, named):
    vertices, faces, points = polytope(dim, count)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="power", gamma=gamma),
                               gencoords.coordinates(points, vertices, faces, kind=named), atol=1e-12)


def test_power_zero_is_mean_value_in_2d():
    vertices, faces, points = polytope(2, 9)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="power", gamma=0.0),
                               gencoords.coordinates(points, vertices, faces, kind="mean_value"), atol=1e-12)
    # ... and its ridge scalars are l^gamma for every gamma (2D ridges are vertices).
    lengths = np.linalg.norm(vertices[None] - points[:, None], axis=-1)
    np.testing.assert_allclose(gencoords.advanced.ridge_scalars(points, vertices, faces, "power", gamma=0.7),
                               lengths[:, gencoords.advanced.ridges(faces)[:, 0]] ** 0.7, rtol=1e-12)


def test_power_zero_is_not_mean_value_in_3d():
    vertices, faces, points = polytope(3, 14)
    gap = np.abs(gencoords.coordinates(points, vertices, faces, kind="power", gamma=0.0)
                 - gencoords.coordinates(points, vertices, faces, kind="mean_value")).max()
    assert gap > 1e-3


@pytest.mark.parametrize("dim,count", SHAPES)
@pytest.mark.parametrize("gamma", [-16.0, -2.0, -0.5, 0.0, 0.37, 2.0, 16.0])
def test_power_coordinates_have_linear_precision_and_partition_of_unity(dim, count, gamma):
    vertices, faces, points = polytope(dim, count, seed=int(10 * gamma) + 200 + dim)
    coordinates = gencoords.coordinates(points, vertices, faces, kind="power", gamma=gamma)
    size = np.ptp(vertices, axis=0).max()
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-12)
    assert np.abs(coordinates @ vertices - points).max() < 1e-11 * size
    weights = gencoords.weights(points, vertices, faces, kind="power", gamma=gamma)
    residual = np.einsum("kn,knN->kN", weights, vertices[None] - points[:, None])
    assert np.abs(residual).max() < 1e-11 * np.abs(weights).max() * size


def test_power_default_is_gamma_minus_a_half_and_other_kinds_refuse_gamma():
    vertices, faces, points = polytope(3, 12)
    np.testing.assert_array_equal(gencoords.coordinates(points, vertices, faces, kind="power"),
                                  gencoords.coordinates(points, vertices, faces, kind="power", gamma=-0.5))
    with pytest.raises(ValueError, match="gamma applies to kind='power' only"):
        gencoords.coordinates(points, vertices, faces, kind="voronoi", gamma=1.0)
    for gamma in (float("nan"), float("inf"), -17.0, 1000.0):  # beyond +-16 float64 overflows
        with pytest.raises(ValueError, match=r"gamma must be a real number in \[-16, 16\]"):
            gencoords.coordinates(points, vertices, faces, kind="power", gamma=gamma)
        with pytest.raises(ValueError, match=r"gamma must be a real number in \[-16, 16\]"):
            gencoords.weights(points, vertices, faces, kind="power", gamma=gamma)


def test_power_ridge_scalars_scale_with_their_length_degree():
    # Heights l^(gamma+1): d has length degree (N-1) gamma in any N (2D: l^gamma).
    vertices, faces, points = polytope(3, 12)
    gamma, factor = 0.6, 4.0
    d = gencoords.advanced.ridge_scalars(points, vertices, faces, "power", gamma=gamma)
    scaled = gencoords.advanced.ridge_scalars(points * factor, vertices * factor, faces, "power", gamma=gamma)
    np.testing.assert_allclose(scaled, d * factor ** (2 * gamma), rtol=1e-10)
