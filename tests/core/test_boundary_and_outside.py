"""Boundary limits, point locations and the three outside behaviours."""

import numpy as np
import pytest

import gencoords
import gencoords.evaluation.rows
import gencoords.evaluation.barycentric
from tests.fixtures.polytopes import icosphere, octahedron, random_convex_polytope, random_interior_points, regular_polygon
from reference_formulas import mean_value_3d_ju, normalise

TETRA_LIKE = octahedron((1.0, 1.3, 0.8))


def facet_point(vertices, face, barycentric):
    return np.asarray(barycentric) @ vertices[face]


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
@pytest.mark.parametrize("offset", [0.0, 1e-11, -1e-11])
def test_points_on_or_near_facets_edges_vertices_get_the_linear_limit(kind, offset):
    vertices, faces = TETRA_LIKE
    face = faces[0]
    normal = np.cross(vertices[face[1]] - vertices[face[0]], vertices[face[2]] - vertices[face[0]])
    normal /= np.linalg.norm(normal)
    cases = [(0.2, 0.3, 0.5), (0.5, 0.5, 0.0), (1.0, 0.0, 0.0), (0.0, 0.25, 0.75)]
    points = np.array([facet_point(vertices, face, b) for b in cases]) - offset * normal
    coordinates = gencoords.coordinates(points, vertices, faces, kind=kind)
    expected = np.zeros((len(cases), len(vertices)))
    expected[:, face] = cases
    assert np.isfinite(coordinates).all()
    np.testing.assert_allclose(coordinates, expected, atol=1e-9)
    np.testing.assert_array_equal(gencoords.point_locations(points, vertices, faces), 0)


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_coordinates_approach_the_facet_limit_continuously(kind):
    vertices, faces = TETRA_LIKE
    face = faces[3]
    on_facet = facet_point(vertices, face, (0.3, 0.3, 0.4))
    inward = -on_facet / np.linalg.norm(on_facet)
    limit = gencoords.coordinates(on_facet, vertices, faces, kind=kind)
    previous = np.inf
    for depth in [1e-2, 1e-4, 1e-6, 1e-8]:
        gap = np.abs(gencoords.coordinates(on_facet + depth * inward, vertices, faces, kind=kind) - limit).max()
        assert gap < 50 * depth and gap <= previous
        previous = gap


def test_vertex_gets_exactly_one():
    vertices, faces = icosphere(1)
    coordinates = gencoords.coordinates(vertices, vertices, faces, kind="wachspress")
    np.testing.assert_array_equal(coordinates, np.eye(len(vertices)))


def test_outside_raise_counts_and_names_the_points():
    vertices, faces = octahedron()
    points = np.array([[0, 0, 0], [2, 0, 0], [0.1, 0.1, 0.1], [0, 0, -3]])
    with pytest.raises(gencoords.OutsideCageError) as error:
        gencoords.coordinates(points, vertices, faces, kind="wachspress")
    assert list(error.value.indices) == [1, 3]
    assert "2 of 4 points" in str(error.value) and "1, 3" in str(error.value)


@pytest.mark.parametrize("kind", gencoords.advanced.KINDS)
def test_outside_project_gives_the_nearest_boundary_points_coordinates(kind):
    vertices, faces = octahedron()
    points = np.array([[2.0, 0.0, 0.0], [1.0, 1.0, 1.0], [0.0, -0.8, -0.9]])
    coordinates = gencoords.coordinates(points, vertices, faces, kind=kind, outside="project")
    nearest = coordinates @ vertices
    np.testing.assert_allclose(nearest[0], [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(nearest[1], [1 / 3, 1 / 3, 1 / 3], atol=1e-12)
    np.testing.assert_allclose(np.abs(nearest).sum(axis=1), 1.0, atol=1e-12)  # on the boundary
    assert coordinates.min() >= 0.0


def test_outside_extrapolate_mean_value_is_the_smooth_extension():
    """Outside a convex cage, mean value extrapolation equals Ju et al.'s formula there."""
    vertices, faces = icosphere(1)
    points = np.array([[1.5, 0.2, 0.1], [0.0, -2.0, 3.0], [1.2, 1.2, 0.0]])
    ours = gencoords.coordinates(points, vertices, faces, kind="mean_value", outside="extrapolate")
    theirs = np.array([normalise(mean_value_3d_ju(x, vertices, faces)) for x in points])
    np.testing.assert_allclose(ours, theirs, atol=1e-12)
    np.testing.assert_allclose(ours @ vertices, points, atol=1e-12)


def test_outside_extrapolate_mean_value_is_continuous_across_a_facet_plane():
    vertices, faces = octahedron()
    # (1.5, -0.5, 0): in the plane z=0? No: on the supporting plane of face (0, 2, 4),
    # x + y + z = 1, beyond the face.
    on_plane = np.array([1.5, 0.2, -0.7])
    assert abs(on_plane.sum() - 1.0) < 1e-15
    normal = np.ones(3) / np.sqrt(3)
    values = [gencoords.coordinates(on_plane + s * normal, vertices, faces, kind="mean_value",
                               outside="extrapolate") for s in (-1e-7, 0.0, 1e-7)]
    assert np.isfinite(values[1]).all()
    assert np.abs(values[0] - values[1]).max() < 1e-5 and np.abs(values[2] - values[1]).max() < 1e-5


@pytest.mark.parametrize("kind", ["wachspress", "discrete_harmonic", "voronoi"])
def test_outside_extrapolate_is_finite_and_affine_even_at_poles(kind):
    vertices, faces = octahedron()
    points = np.array([[1.5, 0.2, -0.7], [1.2, 0.3, 0.2], [0.0, 0.0, 1.0 + 1e-3]])
    coordinates = gencoords.coordinates(points, vertices, faces, kind=kind, outside="extrapolate")
    assert np.isfinite(coordinates).all()
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-12)
    regular = np.abs(coordinates).max(axis=1) < 1e6  # away from the pole: the formula itself
    np.testing.assert_allclose(coordinates[regular][1:] @ vertices, points[regular][1:], atol=1e-9)


@pytest.mark.parametrize("kind", ["wachspress", "discrete_harmonic", "voronoi"])
def test_extrapolation_on_a_facet_hyperplane_takes_the_limit(kind):
    """A pole of the weights, not of the coordinates: no snap onto the cage there."""
    vertices = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])  # the square [-1, 1]^2
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
    on_line = np.array([[1.0, 1.5], [-1.0, -3.0]])  # on the lines x = 1 and x = -1, outside
    nearby = on_line + [[1e-9, 0.0], [-1e-9, 0.0]]
    at, near = (gencoords.coordinates(p, vertices, edges, kind=kind, outside="extrapolate") for p in (on_line, nearby))
    np.testing.assert_allclose(at @ vertices, on_line, atol=1e-12)
    np.testing.assert_allclose(at, near, atol=1e-6)
    weights = gencoords.weights(on_line, vertices, edges, kind=kind)
    np.testing.assert_allclose(np.einsum("kn,knN->kN", weights, vertices[None] - on_line[:, None]), 0.0,
                               atol=1e-12)


def test_a_tolerance_that_is_not_positive_is_refused():
    vertices, faces = octahedron()
    for tolerance in (0.0, -1e-9, np.nan):
        with pytest.raises(ValueError, match="tolerance"):
            gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, tolerance=tolerance)


def test_empty_inputs_give_empty_results():
    vertices, faces = octahedron()
    for empty in ([], np.empty((0, 3))):
        assert gencoords.coordinates(empty, vertices, faces).shape == (0, 6)
        assert gencoords.point_locations(empty, vertices, faces).shape == (0,)


def test_point_locations():
    vertices, edges = regular_polygon(6)
    points = np.array([[0.0, 0.0], [1.0, 0.0], [0.75, np.sqrt(3) / 4], [3.0, 0.0], [0.9, 0.5]])
    np.testing.assert_array_equal(gencoords.point_locations(points, vertices, edges), [1, 0, 0, -1, -1])


def test_chunking_and_threads_do_not_change_results(monkeypatch):
    rng = np.random.default_rng(5)
    vertices, faces = random_convex_polytope(rng, 3, 14)
    points = np.concatenate([random_interior_points(rng, vertices, 300), vertices[:3],
                             vertices.mean(axis=0) + 10.0 * np.ones((2, 3))])
    reference = gencoords.coordinates(points, vertices, faces, kind="voronoi", outside="project")
    monkeypatch.setattr(gencoords.evaluation.rows, "_CHUNK_BYTES", 1)  # one point per chunk
    chunked = gencoords.coordinates(points, vertices, faces, kind="voronoi", outside="project")
    np.testing.assert_allclose(chunked, reference, rtol=0, atol=1e-15)  # BLAS rounding only



def test_a_point_on_a_facets_plane_leaves_the_other_rows_of_its_chunk_as_they_are():
    """Mean value's formula is 0/0 for a facet whose plane passes through the point (off
    the facet, inside a non-convex cage): that point's row takes the form that drops the
    facet, and is the limit; the other points of its chunk keep Floater's form, bitwise
    as computed without it (a row depends only on its point)."""
    occupied = np.zeros((2, 2, 1), dtype=bool)
    occupied[0, 0] = occupied[1, 0] = occupied[0, 1] = True  # an L of three cubes
    vertices, quads = gencoords.cages.shapes.block_cage(occupied)
    faces = gencoords.cages.triangulate_quads(vertices, quads)
    on_plane = np.array([[0.5, 1.0, 0.5]])  # on y = 1, the plane of the inner corner's facet
    others = np.array([[0.3, 0.4, 0.6], [1.5, 0.5, 0.5], [0.5, 1.5, 0.2]])
    alone = gencoords.coordinates(others, vertices, faces, kind="mean_value", workers=1)
    together = gencoords.coordinates(np.vstack([others, on_plane]), vertices, faces, kind="mean_value", workers=1)
    np.testing.assert_array_equal(together[:3], alone)
    beside = gencoords.coordinates(on_plane + [0.0, 1e-7, 0.0], vertices, faces, kind="mean_value", workers=1)
    np.testing.assert_allclose(together[3], beside[0], atol=1e-6)
    np.testing.assert_allclose(together[3] @ vertices, on_plane[0], atol=1e-12)

def test_progress_is_reported_in_order_up_to_one(monkeypatch):
    vertices, faces = icosphere(1)
    points = 0.5 * random_interior_points(np.random.default_rng(0), vertices, 500)
    monkeypatch.setattr(gencoords.evaluation.rows, "_CHUNK_BYTES", 1 << 16)
    fractions = []
    gencoords.coordinates(points, vertices, faces, progress=fractions.append)
    assert len(fractions) > 2 and fractions == sorted(fractions) and fractions[-1] == 1.0


def test_float32_result_is_the_rounded_float64_result():
    vertices, faces = icosphere(1)
    points = 0.5 * random_interior_points(np.random.default_rng(4), vertices, 200)
    single = gencoords.coordinates(points, vertices, faces, kind="voronoi", dtype=np.float32)
    assert single.dtype == np.float32
    np.testing.assert_array_equal(single, gencoords.coordinates(points, vertices, faces, kind="voronoi")
                                  .astype(np.float32))


def test_weights_are_homogeneous_and_finite_on_the_boundary():
    vertices, faces = octahedron()
    points = np.array([[0.2, 0.1, 0.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.1, 0.2, 0.3]])
    for kind in gencoords.advanced.KINDS:
        weights = gencoords.weights(points, vertices, faces, kind=kind)
        assert np.isfinite(weights).all()
        np.testing.assert_allclose(np.einsum("kn,knN->kN", weights, vertices[None] - points[:, None]),
                                   0.0, atol=1e-12)


def test_locations_come_with_the_coordinates():
    vertices, faces = octahedron()
    points = np.array([[0.1, 0.1, 0.1], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.5, 0.5, 0.0]])
    locations = np.full(len(points), 7, dtype=np.int8)
    gencoords.coordinates(points, vertices, faces, outside="project", locations=locations)
    np.testing.assert_array_equal(locations, gencoords.point_locations(points, vertices, faces))
    np.testing.assert_array_equal(locations, [1, 0, -1, 0])


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


@pytest.mark.parametrize("resolution", [4, 16, 128])
def test_points_looked_up_on_the_grid_are_inside_where_their_winding_number_says(resolution):
    from gencoords.construction import boundary
    from gencoords.construction.validation import validate_cage
    from gencoords.cages.shapes import block_cage, t_pose_blocks

    vertices, quads = block_cage(t_pose_blocks())  # non-convex: arms, legs, gaps between them
    cage = validate_cage(vertices, gencoords.cages.triangulate_quads(vertices, quads), convex=False)
    rng = np.random.default_rng(7)
    low, high = vertices.min(axis=0) - 0.5, vertices.max(axis=0) + 0.5
    points = np.vstack([rng.uniform(low, high, (4000, 3)),  # and points on the faces' planes:
                        np.round(rng.uniform(low, high, (1000, 3)) * 2.0) / 2.0 + [0.0, 0.0, 1e-9]])
    expected = boundary.winding_numbers(cage, points) >= 0.5
    inside, crossed = boundary.inside_by_grid(cage, cage.local(points), *boundary.inside_lookup(cage, resolution))
    np.testing.assert_array_equal(inside, expected)
    assert 0 < len(crossed) < len(points)  # the others were decided by their cell alone
    np.testing.assert_array_equal(boundary.inside_points(cage, points), expected)


def test_a_cage_of_long_slanted_facets_builds_no_lookup_grid_and_still_locates_points():
    """A cylinder along (1, 1, 1): each long side facet's box covers most grid columns, so
    the grid would test about a billion bytes' worth of (facet, column) pairs: winding
    numbers for every point instead, the same answers."""
    from gencoords.construction import boundary
    from gencoords.construction.validation import validate_cage

    segments, turn = 256, np.linalg.qr(np.array([[1.0, 1.0, 1.0], [1.0, -1.0, 0.0], [1.0, 1.0, -2.0]]).T)[0]
    angles = 2.0 * np.pi * np.arange(segments) / segments
    ring = np.column_stack([np.zeros(segments), 0.1 * np.cos(angles), 0.1 * np.sin(angles)])
    vertices = np.vstack([ring, ring + [1.0, 0.0, 0.0], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]])
    i, j = np.arange(segments), (np.arange(segments) + 1) % segments
    faces = np.vstack([np.column_stack([i, j, segments + j]), np.column_stack([i, segments + j, segments + i]),
                       np.column_stack([2 * segments + np.zeros_like(i), j, i]),
                       np.column_stack([2 * segments + 1 + np.zeros_like(i), segments + i, segments + j])])
    cage = validate_cage(vertices @ turn.T, faces, convex=False)
    assert boundary.inside_lookup(cage) is None
    points = (np.random.default_rng(3).uniform(-0.15, 1.15, (500, 3)) * [1.0, 0.2, 0.2]) @ turn.T
    expected = boundary.winding_numbers(cage, points) >= 0.5
    assert 0 < expected.sum() < len(points)
    np.testing.assert_array_equal(boundary.inside_points(cage, points), expected)


@pytest.mark.parametrize("shape", ["t_pose", "icosphere"])
def test_outside_points_are_those_point_locations_calls_outside(shape):
    """``Cage.outside_points`` (no coordinates, no plane distances of every pair for a
    non-convex cage) finds what ``outside="raise"`` refuses: points at the tolerance's
    threshold along facets' normals, beyond sharp apices, in the gaps of a non-convex
    cage and far away; those it found inside (``inside``) are those of winding number
    at least 1/2, of whatever the points' locations say is inside or on the cage."""
    from gencoords.cages.shapes import block_cage, t_pose_blocks
    from gencoords.construction import boundary

    tolerance = 1e-6
    if shape == "t_pose":  # non-convex: arms, legs, gaps between them
        vertices, quads = block_cage(t_pose_blocks())
        faces = gencoords.cages.triangulate_quads(vertices, quads)
    else:
        vertices, faces = icosphere(2)
    size = np.linalg.norm(np.ptp(vertices, axis=0))
    rng = np.random.default_rng(11)
    low, high = vertices.min(axis=0) - 0.5, vertices.max(axis=0) + 0.5
    triangle = vertices[faces[:200]]
    centres = triangle.mean(axis=1)
    normals = np.cross(triangle[:, 1] - triangle[:, 0], triangle[:, 2] - triangle[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    offsets = rng.choice([-3.0, -0.5, 0.5, 3.0], len(centres))[:, None] * tolerance * size
    points = np.vstack([rng.uniform(low, high, (3000, 3)), centres + offsets * normals, vertices * 1.0001])
    with gencoords.Cage(vertices, faces, tolerance=tolerance) as cage:
        assert cage.convex == (shape == "icosphere")
        locations = cage.point_locations(points)
        expected = np.flatnonzero(locations == gencoords.OUTSIDE)
        inside = np.empty(len(points), dtype=bool)
        found = cage.outside_points(points, inside)
        winding = boundary.winding_numbers(cage._prepared, points)
    np.testing.assert_array_equal(found, expected)
    assert 0 < len(expected) < len(points)
    assert not inside[found].any() and (locations[inside] != gencoords.OUTSIDE).all()
    confident = np.abs(winding - 0.5) > 0.25  # not on the surface, where rounding may say either
    np.testing.assert_array_equal(inside[confident], winding[confident] >= 0.5)
    assert 0 < inside.sum() < len(points)


def test_outside_points_beyond_a_sharp_apex_within_tolerance_of_its_planes():
    tolerance = 1e-6
    apex_vertices, apex_faces = octahedron((1.0, 1.0, 20.0))
    beyond = apex_vertices[4] + [0.0, 0.0, 5.0 * tolerance * np.linalg.norm(np.ptp(apex_vertices, axis=0))]
    with gencoords.Cage(apex_vertices, apex_faces, tolerance=tolerance) as cage:
        assert list(cage.outside_points(np.vstack([beyond, [0.0, 0.0, 0.0]]))) == [0]
