"""Generating surfaces of one's own: numerical ridge scalars against the closed forms."""

from math import factorial

import numpy as np
import pytest

import gencoords
from gencoords.construction.general import point_frame
from gencoords.surfaces.numerical import geodesic_pieces, simplex_rule, unit_sphere_ridge_scalars
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


def unit_sphere(points, directions):
    return np.ones(directions.shape[:2])


def polytope_boundary(vertices, faces):
    """The cage's own boundary as a radius function (its discrete harmonic surface)."""
    cage = gencoords.advanced.validate_cage(vertices, faces)
    normals = cage.facet_normals / np.linalg.norm(cage.facet_normals, axis=1, keepdims=True)
    offsets = np.einsum("mN,mN->m", vertices[faces[:, 0]], normals)

    def radius(points, directions):
        heights = offsets[None] - points @ normals.T  # (k, m), positive inside
        speeds = np.einsum("ksN,mN->ksm", directions, normals)
        with np.errstate(divide="ignore"):
            exits = np.where(speeds > 0.0, heights[:, None, :] / speeds, np.inf)
        return exits.min(axis=2)
    return radius


def polytope(dim, count, points, seed=2):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return vertices, faces, random_interior_points(rng, vertices, points)


@pytest.mark.parametrize("corners", range(1, 6))
def test_simplex_rules_have_the_simplex_measure_and_integrate_polynomials(corners):
    barycentric, weights = simplex_rule(corners, 3)
    assert weights.sum() == pytest.approx(1.0 / factorial(corners - 1), rel=1e-13)
    # Dirichlet: the integral of b_0 b_1 over the q-simplex is 1! 1! / (q + 2)!, a degree
    # the rule integrates exactly (with its collapse's Jacobian) up to 4 corners and more.
    if corners >= 2:
        exact = 1.0 / factorial(corners + 1)
        assert weights @ (barycentric[:, 0] * barycentric[:, 1]) == pytest.approx(exact, rel=1e-12)
    pieces = geodesic_pieces(corners, 2)
    assert len(pieces) == 2 ** (2 * (corners - 1))
    np.testing.assert_allclose(pieces.sum(axis=2), 1.0)  # barycentric rows


@pytest.mark.parametrize("dim,count,points,tolerance", [(3, 12, 20, 1e-6), (4, 9, 5, 1e-5)])
def test_the_unit_sphere_gives_mean_value(dim, count, points, tolerance):
    vertices, faces, inside = polytope(dim, count, points)
    numerical = gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, unit_sphere)
    exact = gencoords.advanced.ridge_scalars(inside, vertices, faces, "mean_value")
    np.testing.assert_allclose(numerical, exact, rtol=tolerance)


@pytest.mark.parametrize("dim,count,points,tolerance", [(3, 12, 20, 1e-6), (4, 9, 5, 1e-5)])
def test_the_polytope_itself_gives_discrete_harmonic(dim, count, points, tolerance):
    vertices, faces, inside = polytope(dim, count, points, seed=5)
    numerical = gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, polytope_boundary(vertices, faces))
    exact = gencoords.advanced.ridge_scalars(inside, vertices, faces, "discrete_harmonic")
    np.testing.assert_allclose(numerical, exact, rtol=tolerance)


@pytest.mark.parametrize("dim,count", [(3, 12), (4, 9)])
def test_the_error_shrinks_with_every_level(dim, count):
    vertices, faces, inside = polytope(dim, count, 8, seed=9)
    exact = gencoords.advanced.ridge_scalars(inside, vertices, faces, "mean_value")
    errors = [np.abs(gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, unit_sphere, levels=level)
                     / exact - 1.0).max() for level in range(0, 5)]
    # Once the pieces are small (level 2 on), every level gains at least a factor 3.
    assert errors[2] > 3 * errors[3] > 9 * errors[4] and errors[4] < 1e-3, errors


def test_the_5d_mean_value_path_agrees_with_the_exact_4d_solid_angle():
    # The numerical measure used for mean value above 4D, run where the closed form
    # exists: it converges to it (levels 3, 4, 5: 1.3e-3, 1.6e-5, 3.4e-7 relative).
    vertices, faces, inside = polytope(4, 10, 8, seed=4)
    frame = point_frame(gencoords.advanced.validate_cage(vertices, faces), inside)
    exact = gencoords.advanced.ridge_scalars(inside, vertices, faces, "mean_value")
    errors = [np.abs(unit_sphere_ridge_scalars(frame.ridge_gram, frame.ridge_measure, level).T / exact
                     - 1.0).max() for level in (3, 4, 5)]
    assert errors[0] > 10 * errors[1] > 100 * errors[2] and errors[2] < 1e-5, errors


def test_mean_value_in_5d_converges_and_gives_coordinates():
    vertices, faces, inside = polytope(5, 9, 5, seed=3)
    frame = point_frame(gencoords.advanced.validate_cage(vertices, faces), inside)
    by_level = [unit_sphere_ridge_scalars(frame.ridge_gram, frame.ridge_measure, level) for level in range(1, 5)]
    gaps = [np.abs(d / by_level[-1] - 1.0).max() for d in by_level[:-1]]
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 1e-3, gaps
    coordinates = gencoords.coordinates(inside, vertices, faces, kind="mean_value")
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(coordinates @ vertices, inside, atol=1e-12)
    assert coordinates.min() > 0.0  # mean value is positive in convex polytopes


def test_an_ellipsoid_of_ones_own_gives_coordinates_end_to_end():
    # The docs' example: an ellipsoid around each point, stretched along x.
    vertices, faces, inside = polytope(3, 12, 15, seed=4)
    semi_axes = np.array([2.0, 1.0, 0.5])

    def ellipsoid(points, directions):
        return 1.0 / np.sqrt(((directions / semi_axes) ** 2).sum(axis=-1))

    d = gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, ellipsoid)
    weights = gencoords.advanced.weights_from_ridge_scalars(inside, vertices, faces, d)
    coordinates = weights / weights.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(coordinates @ vertices, inside, atol=1e-12)
    # A sphere of radius 2 is mean value (d scales by 2^2, coordinates do not change):
    sphere = gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, lambda x, u: np.full(u.shape[:2], 2.0))
    np.testing.assert_allclose(sphere, 4.0 * gencoords.advanced.ridge_scalars(inside, vertices, faces, "mean_value"),
                               rtol=1e-6)
    assert np.abs(coordinates - gencoords.coordinates(inside, vertices, faces)).max() > 1e-3  # not mean value


def test_a_bad_radius_function_gets_a_clear_error():
    vertices, faces, inside = polytope(3, 10, 3)
    with pytest.raises(ValueError, match="must return shape"):
        gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, lambda x, u: np.ones(3))
    with pytest.raises(ValueError, match="finite positive distances"):
        gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, lambda x, u: -np.ones(u.shape[:2]))
    with pytest.raises(ValueError, match="radius must be a callable"):
        gencoords.advanced.ridge_scalars_from_surface(inside, vertices, faces, 1.0)
