"""Tests that a mutation check found missing, and a fuzz test over random convex polytopes."""


import numpy as np
import pytest

import gencoords
from polytopes import octahedron, random_convex_polytope, random_interior_points


def test_coordinate_summary_counts_points_with_a_coordinate_below_minus_the_threshold():
    threshold = gencoords.base.tolerances.NEGATIVE
    rows = np.array([[0.5, 0.5, 0.0], [1.0 + threshold / 2, -threshold / 2, 0.0],
                     [1.5, -2 * threshold, -0.5 + 2 * threshold], [1.2, -0.1, -0.1], [0.2, 0.3, 0.5]])
    summary = gencoords.tools.coordinate_summary(rows)
    assert summary["negative_points"] == 2  # rows 2 and 3; rounding noise of row 1 is not
    assert summary["min"] == pytest.approx(-0.5 + 2 * threshold)
    assert summary["max_affine_error"] == pytest.approx(0.0, abs=1e-15)
    assert summary["nbytes"] == rows.nbytes
    assert gencoords.tools.coordinate_summary(np.zeros((0, 3)))["negative_points"] == 0


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_the_outside_threshold_is_the_boundary_tolerance(kind):
    vertices, faces = octahedron()
    tolerance = 1e-6
    size = np.linalg.norm(np.ptp(vertices, axis=0))  # the cage's diagonal
    centre = vertices[faces[0]].mean(axis=0)
    normal = centre / np.linalg.norm(centre)  # outward, through the facet's centre
    offsets = np.array([-3.0, -0.5, 0.0, 0.5, 3.0]) * tolerance * size  # along the outward normal
    points = centre + offsets[:, None] * normal
    where = gencoords.point_locations(points, vertices, faces, tolerance=tolerance)
    np.testing.assert_array_equal(where, [gencoords.INSIDE, gencoords.BOUNDARY, gencoords.BOUNDARY, gencoords.BOUNDARY,
                                          gencoords.OUTSIDE])
    gencoords.coordinates(points[:4], vertices, faces, kind=kind, tolerance=tolerance)  # none outside
    with pytest.raises(gencoords.OutsideCageError) as error:
        gencoords.coordinates(points, vertices, faces, kind=kind, tolerance=tolerance)
    assert list(error.value.indices) == [4]


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_beyond_a_sharp_vertex_within_tolerance_of_its_planes_is_still_outside(kind):
    """Near a sharp apex a point can be within the tolerance of every facet's plane yet
    farther than it from the cage: outside, not boundary (nor inside)."""
    vertices, faces = octahedron((1.0, 1.0, 20.0))  # apex half-angle ~ 0.05 rad
    tolerance = 1e-6
    size = np.linalg.norm(np.ptp(vertices, axis=0))
    beyond = vertices[4] + [0.0, 0.0, 5.0 * tolerance * size]  # ~0.25 tolerance from the planes
    assert gencoords.point_locations(beyond[None], vertices, faces, tolerance=tolerance)[0] == gencoords.OUTSIDE
    with pytest.raises(gencoords.OutsideCageError):
        gencoords.coordinates(beyond, vertices, faces, kind=kind, tolerance=tolerance)


def test_a_cage_with_every_face_flipped_is_reported_inward():
    vertices, faces = octahedron()
    with pytest.raises(gencoords.CageError, match="inward") as error:
        gencoords.advanced.validate_cage(vertices, faces[:, ::-1])
    assert error.value.problem == "inward"
    gencoords.advanced.validate_cage(vertices, faces)  # the same cage the right way out passes


@pytest.mark.parametrize("coordinate_dtype,out_dtype", [(np.float64, np.float64), (np.float64, np.float32),
                                                       (np.float32, np.float32)])
def test_deform_writes_into_out(coordinate_dtype, out_dtype):
    vertices, faces = octahedron()
    points = random_interior_points(np.random.default_rng(1), vertices, 30)
    coordinates = gencoords.coordinates(points, vertices, faces).astype(coordinate_dtype)
    moved = 2.0 * vertices + [1.0, -2.0, 0.5]  # affine: the points move the same way
    out = np.full((len(points), 3), np.nan, dtype=out_dtype)
    result = gencoords.deform(coordinates, moved, out=out)
    assert result is out
    np.testing.assert_allclose(out, 2.0 * points + [1.0, -2.0, 0.5], atol=1e-5 if out_dtype == np.float32 else 1e-12)
    np.testing.assert_allclose(gencoords.deform(coordinates, moved), out, atol=1e-5)


# Fuzz: random convex polytopes in 2D-5D at random scales and offsets, random points in
# them, on their facets, ridges and vertices: linear precision, partition of unity, the
# boundary limit. Fixed seed; sizes keep it to a few seconds.
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


@pytest.mark.parametrize("dim,count", FUZZ_CASES)
def test_fuzz_random_polytopes_scales_and_points(dim, count):
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
