"""gencoords.reports.coordinate_summary's counts and gencoords.deform's output buffer."""

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import octahedron, random_interior_points


def test_coordinate_summary_counts_points_with_a_coordinate_below_minus_the_threshold():
    threshold = gencoords.base.tolerances.NEGATIVE
    rows = np.array([[0.5, 0.5, 0.0], [1.0 + threshold / 2, -threshold / 2, 0.0],
                     [1.5, -2 * threshold, -0.5 + 2 * threshold], [1.2, -0.1, -0.1], [0.2, 0.3, 0.5]])
    summary = gencoords.reports.coordinate_summary(rows)
    assert summary["negative_points"] == 2  # rows 2 and 3; rounding noise of row 1 is not
    assert summary["negative_entries"] == 4  # (2, 1), (2, 2), (3, 1), (3, 2)
    assert summary["min"] == pytest.approx(-0.5 + 2 * threshold)
    assert summary["max_affine_error"] == pytest.approx(0.0, abs=1e-15)
    assert summary["nbytes"] == rows.nbytes
    assert gencoords.reports.coordinate_summary(np.zeros((0, 3)))["negative_points"] == 0
    assert gencoords.reports.coordinate_summary(np.zeros((0, 3)))["negative_entries"] == 0


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


def test_linear_precision_is_zero_for_exact_coordinates_and_finds_float32_losses():
    """Independent of the construction: float64 coordinates place their points; power
    coordinates with gamma -16 reach -1700 inside a cube, where float32 storage loses
    more than tolerances.LINEAR_PRECISION, and gamma -1 (Wachspress) stays far below it."""
    vertices, faces = octahedron()
    points = random_interior_points(np.random.default_rng(2), vertices, 50)
    coordinates = gencoords.coordinates(points, vertices, faces)
    assert gencoords.reports.linear_precision(coordinates, vertices, points) < 1e-14
    assert gencoords.reports.linear_precision(coordinates, vertices, points + [0.0, 0.0, 0.1]) == \
        pytest.approx(0.1 / np.linalg.norm(np.ptp(vertices, axis=0)))
    cube = np.array([[x, y, z] for x in (-2, 2) for y in (-2, 2) for z in (-2, 2)], dtype=np.float64)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    triangles = gencoords.cages.orient_facets_outward(cube, gencoords.cages.triangulate_quads(cube, quads))
    spot = np.array([[-0.64592897, -0.72009573, -0.31435936]])
    limit = gencoords.base.tolerances.LINEAR_PRECISION
    for gamma, fails in ((-16.0, True), (-1.0, False)):
        stored = gencoords.coordinates(spot, cube, triangles, kind="power", gamma=gamma).astype(np.float32)
        assert (gencoords.reports.linear_precision(stored, cube, spot) > limit) == fails


def test_linear_precision_does_not_depend_on_where_the_cage_is():
    vertices, faces = octahedron()
    points = random_interior_points(np.random.default_rng(3), vertices, 20)
    stored = gencoords.coordinates(points, vertices, faces).astype(np.float32)
    near = gencoords.reports.linear_precision(stored, vertices, points)
    far = gencoords.reports.linear_precision(stored, vertices * 1e-6 + 1000.0, points * 1e-6 + 1000.0)
    assert near < 1e-6 and far < 1e-6  # about the origin, float32 rounding of sums ~ 1 would give 50
