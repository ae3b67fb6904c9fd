"""Every kind in 4D and 5D, on random convex simplicial polytopes (hulls of random points).

Independent formulas in these dimensions: tests/core/test_reference_formulas.py
(discrete harmonic by energy minimisation, mean value by integrating its definition).
"""

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points

POLYTOPES = [(4, 9), (5, 9)]


def polytope(dim, count, seed):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return rng, vertices, faces, random_interior_points(rng, vertices, 10)


@pytest.mark.parametrize("dim,count", POLYTOPES)
@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_every_kind_has_linear_precision_and_partition_of_unity(dim, count, kind):
    _, vertices, faces, points = polytope(dim, count, seed=dim)
    coordinates = gencoords.coordinates(points, vertices, faces, kind=kind)
    size = np.ptp(vertices, axis=0).max()
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-12)
    assert np.abs(coordinates @ vertices - points).max() < 1e-11 * size
    if kind in ("wachspress", "mean_value"):  # positive in convex polytopes
        assert coordinates.min() > 0.0


@pytest.mark.parametrize("dim,count", POLYTOPES)
@pytest.mark.parametrize("scalars", ["d", "c"])
def test_arbitrary_ridge_or_floater_scalars_give_homogeneous_weights(dim, count, scalars):
    rng, vertices, faces, points = polytope(dim, count, seed=10 + dim)
    values = rng.uniform(-1.0, 2.0, size=(len(points), len(gencoords.advanced.ridges(faces))))
    weights = (gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, values) if scalars == "d"
               else gencoords.advanced.floater_weights(points, vertices, faces, values))
    residual = np.einsum("kn,knN->kN", weights, vertices[None] - points[:, None])
    assert np.abs(residual).max() < 1e-11 * np.abs(weights).max() * np.ptp(vertices, axis=0).max()


@pytest.mark.parametrize("dim,count", POLYTOPES)
def test_power_family_ends_are_wachspress_and_voronoi(dim, count):
    _, vertices, faces, points = polytope(dim, count, seed=20 + dim)
    for gamma, named in ((-1.0, "wachspress"), (1.0, "voronoi")):
        np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="power", gamma=gamma),
                                   gencoords.coordinates(points, vertices, faces, kind=named), atol=1e-11)
