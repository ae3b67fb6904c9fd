"""gencoords.cages.shapes: the example cages are valid, outward-oriented convex cages."""

import numpy as np

import gencoords
from gencoords.cages.shapes import irregular_octahedron, octahedron


def test_irregular_octahedron_is_a_valid_convex_cage_with_no_circumsphere():
    vertices, faces = irregular_octahedron()
    gencoords.advanced.validate_cage(vertices, faces, convex=True)  # raises on inward or non-convex faces
    # no sphere through all six vertices: the least-squares sphere misses some of them
    rows = np.column_stack([2.0 * vertices, np.ones(len(vertices))])
    solution, *_ = np.linalg.lstsq(rows, (vertices ** 2).sum(axis=1), rcond=None)
    centre = solution[:3]
    radii = np.linalg.norm(vertices - centre, axis=1)
    assert radii.max() - radii.min() > 0.1
    # same combinatorics as the regular one, vertex 0 (v of figures 9 and 10) near +x
    np.testing.assert_array_equal(faces, octahedron()[1])
    assert vertices[0, 0] == vertices[:, 0].max()
