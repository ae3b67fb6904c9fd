"""Completeness (Proposition 10): any homogeneous weights come from some c, hence some d."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gencoords
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points

SEEDS = st.integers(0, 2**32 - 1)


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10), (4, 8)])
@pytest.mark.parametrize("target", gencoords.advanced.KINDS)
@given(seed=SEEDS)
@settings(max_examples=8, deadline=None)
def test_coordinates_of_any_kind_round_trip_through_floater_and_ridge_scalars(seed, dim, count, target):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    x = random_interior_points(rng, vertices, 1)
    wanted = gencoords.coordinates(x, vertices, faces, kind=target)[0]
    c = gencoords.advanced.floater_scalars(x[0], vertices, faces, wanted)
    np.testing.assert_allclose(gencoords.advanced.floater_weights(x, vertices, faces, c[None])[0], wanted, atol=1e-11)
    d = gencoords.advanced.ridge_scalars_from_floater(x, vertices, faces, c[None])
    np.testing.assert_allclose(gencoords.advanced.weights_from_ridge_scalars(x, vertices, faces, d)[0], wanted, atol=1e-11)


@given(seed=SEEDS)
@settings(max_examples=8, deadline=None)
def test_random_homogeneous_weights_are_reproduced(seed):
    """Not only named coordinates: a random element of the (n - N)-dim space of homogeneous weights."""
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, 3, 11)
    x = random_interior_points(rng, vertices, 1)[0]
    spokes = (vertices - x).T  # (3, n): homogeneous weights are its null space
    null_space = np.linalg.svd(spokes)[2][3:]
    wanted = rng.normal(size=len(null_space)) @ null_space
    c = gencoords.advanced.floater_scalars(x, vertices, faces, wanted)
    np.testing.assert_allclose(gencoords.advanced.floater_weights(x[None], vertices, faces, c[None])[0], wanted, atol=1e-11)


def test_non_homogeneous_weights_are_refused():
    """The check above can fail: weights outside the space leave a residual, which is an error."""
    rng = np.random.default_rng(1)
    vertices, faces = random_convex_polytope(rng, 3, 11)
    x = random_interior_points(rng, vertices, 1)[0]
    wanted = rng.uniform(size=len(vertices))
    with pytest.raises(ValueError, match="not homogeneous"):
        gencoords.advanced.floater_scalars(x, vertices, faces, wanted)
