"""gencoords.tools.coordinate_summary's counts and gencoords.deform's output buffer."""

import numpy as np
import pytest

import gencoords
from polytopes import octahedron, random_interior_points


def test_coordinate_summary_counts_points_with_a_coordinate_below_minus_the_threshold():
    threshold = gencoords.base.tolerances.NEGATIVE
    rows = np.array([[0.5, 0.5, 0.0], [1.0 + threshold / 2, -threshold / 2, 0.0],
                     [1.5, -2 * threshold, -0.5 + 2 * threshold], [1.2, -0.1, -0.1], [0.2, 0.3, 0.5]])
    summary = gencoords.tools.coordinate_summary(rows)
    assert summary["negative_points"] == 2  # rows 2 and 3; rounding noise of row 1 is not
    assert summary["negative_entries"] == 4  # (2, 1), (2, 2), (3, 1), (3, 2)
    assert summary["min"] == pytest.approx(-0.5 + 2 * threshold)
    assert summary["max_affine_error"] == pytest.approx(0.0, abs=1e-15)
    assert summary["nbytes"] == rows.nbytes
    assert gencoords.tools.coordinate_summary(np.zeros((0, 3)))["negative_points"] == 0
    assert gencoords.tools.coordinate_summary(np.zeros((0, 3)))["negative_entries"] == 0


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
