"""Random convex polytopes in 2D-5D at random scales and offsets, random points in them,
on their facets, ridges and vertices: linear precision, partition of unity, the boundary
limit and the point locations hold for every kind. Fixed seed; sizes keep it to a few
seconds."""

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points

FUZZ_CASES = [(2, 8), (3, 10), (4, 8), (5, 8)]


def face_points(rng, vertices, faces, count):
    """Points on random faces of every dimension of random facets, with their limit coordinates."""
    points, limits = [], []
    dim = vertices.shape[1]
    for _ in range(count):
        facet = faces[rng.integers(len(faces))]
        corners = rng.choice(facet, size=rng.integers(1, dim + 1), replace=False)  # vertex .. facet
        mix = rng.dirichlet(np.ones(len(corners)))
        limit = np.zeros(len(vertices))
        limit[corners] = mix
        points.append(mix @ vertices[corners])
        limits.append(limit)
    return np.array(points), np.array(limits)


@pytest.mark.slow
@pytest.mark.parametrize("dim,count", FUZZ_CASES)
def test_precision_unity_and_boundary_limits_hold_on_random_polytopes_at_any_scale(dim, count):
    rng = np.random.default_rng(1100 + dim)
    for _ in range(6):
        vertices, faces = random_convex_polytope(rng, dim, count)
        scale = 10.0 ** rng.uniform(-100, 100)
        offset = rng.normal(size=dim) * 10.0 ** rng.uniform(0, 3)  # in cage sizes
        vertices = (vertices + offset) * scale
        inside = random_interior_points(rng, vertices, 10)
        on_faces, limits = face_points(rng, vertices, faces, 10)
        points = np.concatenate([inside, on_faces])
        for kind in gencoords.advanced.KINDS:
            result = gencoords.coordinates(points, vertices, faces, kind=kind)
            size = np.linalg.norm(np.ptp(vertices, axis=0))
            assert np.isfinite(result).all()
            np.testing.assert_allclose(result.sum(axis=1), 1.0, atol=1e-12, err_msg=kind)
            error = np.abs(result @ vertices - points).max() / size
            assert error < 1e-11, (kind, dim, scale, error)
            np.testing.assert_allclose(result[len(inside):], limits, atol=1e-8, err_msg=kind)
            np.testing.assert_array_equal(gencoords.point_locations(points, vertices, faces),
                                          [gencoords.INSIDE] * len(inside) + [gencoords.BOUNDARY] * len(on_faces))
