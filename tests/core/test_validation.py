"""Every cage error names what is wrong and where; mean value handles non-convex cages."""

import re

import numpy as np
import pytest

import gencoords
from tests.fixtures.polytopes import (dented_icosphere, icosphere, l_shape, octahedron, random_convex_polytope,
                       random_interior_points)
from reference_formulas import mean_value_3d_ju, normalise


def cage_error(vertices, faces, kind="wachspress"):
    with pytest.raises(gencoords.CageError) as error:
        gencoords.coordinates(np.zeros((1, np.shape(vertices)[1])), vertices, faces, kind=kind)
    return error.value


def test_too_few_vertices():
    error = cage_error(np.eye(3), [[0, 1, 2], [0, 2, 1]])
    assert error.problem == "too_few_vertices" and "at least 4" in str(error)


def test_open_cage_names_a_boundary_edge_and_its_face():
    vertices, faces = octahedron()
    error = cage_error(vertices, faces[:-1])
    assert error.problem == "open" and error.faces and len(error.vertices) == 2
    assert "open" in str(error) and "edge" in str(error)


def test_non_manifold_edge():
    # Two closed tetrahedra sharing the edge (0, 1): four faces meet there.
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, -1, 0], [0, 0, -1]], float)
    tetra = lambda a, b: [[0, 1, b], [0, a, 1], [0, b, a], [1, a, b]]  # noqa: E731
    faces = np.array(tetra(2, 3) + [[0, 1, 5], [0, 4, 1], [0, 5, 4], [1, 4, 5]])
    error = cage_error(vertices, faces)
    assert error.problem == "non_manifold" and "4 faces" in str(error) and error.vertices == (0, 1)


def test_loose_vertex():
    vertices, faces = octahedron()
    error = cage_error(np.concatenate([vertices, [[0.1, 0.1, 0.1]]]), faces)
    assert error.problem == "loose_vertices" and error.vertices == (6,) and "no face" in str(error)


def test_face_repeating_a_vertex_or_out_of_range():
    vertices, faces = octahedron()
    assert cage_error(vertices, np.concatenate([faces, [[0, 0, 1]]])).problem == "bad_faces"
    assert cage_error(vertices, np.concatenate([faces, [[0, 1, 9]]])).problem == "bad_faces"


def test_degenerate_facet_in_a_closed_cage():
    # A tetrahedron whose apex lies in the plane of... a triangle with collinear vertices.
    vertices = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [1, 1, 0], [1, 0.3, 1]], float)
    faces = np.array([[0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 3, 2]])
    error = cage_error(vertices, faces)
    assert error.problem == "degenerate_facet" and error.faces == (0,)


def test_non_convex_names_the_vertex_and_face_and_suggests_nothing_silently():
    vertices, faces = dented_icosphere()
    for kind in ("wachspress", "discrete_harmonic", "voronoi"):
        error = cage_error(vertices, faces, kind)
        assert error.problem == "non_convex" and len(error.vertices) == 1 and len(error.faces) == 1
        (vertex,), (face,) = error.vertices, error.faces
        assert f"vertex {vertex}" in str(error) and f"face {face}" in str(error)
        # The named vertex really is beyond the named face's plane.
        a, b, c = vertices[faces[face]]
        assert np.dot(vertices[vertex] - a, np.cross(b - a, c - a)) > 0


def test_duplicated_vertices():
    vertices, faces = octahedron()
    doubled = np.concatenate([vertices, vertices[:1]])
    faces = faces.copy()
    faces[0, 0] = 6
    error = cage_error(doubled, faces)
    assert error.problem == "duplicate_vertices" and set(error.vertices) == {0, 6}


@pytest.mark.parametrize("offset,duplicate", [(1e-12, True), (1e-6, False)])
def test_duplicates_are_judged_by_distance_in_a_large_cage(offset, duplicate):
    vertices, faces = icosphere(3)  # 642 vertices
    extra = np.concatenate([vertices, vertices[[200]] + offset])  # relative to a size of ~3.5
    faces = faces.copy()
    row = np.flatnonzero((faces == 200).any(axis=1))[0]
    faces[row, faces[row] == 200] = 642  # the copy replaces vertex 200 in one face
    if duplicate:
        error = cage_error(extra, faces)
        assert error.problem == "duplicate_vertices" and set(error.vertices) == {200, 642}
    else:
        with pytest.raises(gencoords.CageError) as error:  # not a duplicate: the cage is bent there
            gencoords.advanced.validate_cage(extra, faces)
        assert error.value.problem != "duplicate_vertices"


def test_non_finite_vertex_and_points():
    vertices, faces = octahedron()
    broken = vertices.copy()
    broken[3, 1] = np.nan
    error = cage_error(broken, faces)
    assert error.problem == "non_finite" and error.vertices == (3,)
    with pytest.raises(ValueError, match="non-finite"):
        gencoords.coordinates([[np.nan, 0, 0]], vertices, faces)


def test_unknown_kind_and_outside_mode():
    vertices, faces = octahedron()
    with pytest.raises(ValueError, match="kind"):  # "harmonic" is a kind now (test_harmonic_kind.py)
        gencoords.coordinates([[0, 0, 0]], vertices, faces, kind="harmonics")
    with pytest.raises(ValueError, match="outside"):
        gencoords.coordinates([[0, 0, 0]], vertices, faces, outside="clamp")


def test_flat_regions_of_triangulated_quads_count_as_convex():
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    triangles = np.array([[q[0], q[1], q[2]] for q in quads] + [[q[0], q[2], q[3]] for q in quads])
    points = np.random.default_rng(0).uniform(0.05, 0.95, size=(50, 3))
    for kind in gencoords.advanced.KINDS:
        coordinates = gencoords.coordinates(points, cube, triangles, kind=kind)
        np.testing.assert_allclose(coordinates @ cube, points, atol=1e-13)


@pytest.mark.parametrize("corner", range(8))
def test_quads_of_a_cube_with_a_dragged_corner_split_into_a_convex_cage(corner):
    cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    cube[corner] += 0.3 * (cube[corner] - 0.5)  # outward: the three quads at it bend
    triangles = gencoords.cages.triangulate_quads(cube, quads)
    gencoords.advanced.validate_cage(cube, triangles)  # convex
    # Each quad's other diagonal folds the bent quads inward: then it is not convex.
    pairs = triangles.reshape(-1, 2, 3)
    kept_first = np.all(pairs[:, 0] == quads[:, [0, 1, 2]], axis=1)[:, None, None]
    other = np.where(kept_first, np.stack([quads[:, [0, 1, 3]], quads[:, [1, 2, 3]]], axis=1),
                     np.stack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]], axis=1))
    with pytest.raises(gencoords.CageError, match="not convex"):
        gencoords.advanced.validate_cage(cube, other.reshape(-1, 3))


def test_mean_value_on_a_non_convex_cage_inside_and_outside():
    vertices, faces = dented_icosphere()
    rng = np.random.default_rng(2)
    inside = 0.3 * random_interior_points(rng, vertices, 40)
    inside = inside[gencoords.point_locations(inside, vertices, faces) == 1]
    dent = 0.7 * vertices[0] / np.linalg.norm(vertices[0])  # beyond the pushed-in vertex
    outside = np.array([dent, [1.4, 0.3, 0.2], [0.0, 2.0, -1.0]])
    assert list(gencoords.point_locations(outside, vertices, faces)) == [-1, -1, -1]
    ours = gencoords.coordinates(np.concatenate([inside, outside]), vertices, faces,
                            kind="mean_value", outside="extrapolate")
    np.testing.assert_allclose(ours @ vertices, np.concatenate([inside, outside]), atol=1e-12)
    theirs = np.array([normalise(mean_value_3d_ju(x, vertices, faces))
                       for x in np.concatenate([inside, outside])])
    np.testing.assert_allclose(ours, theirs, atol=1e-11)


def test_mean_value_on_a_non_convex_polygon():
    vertices, edges = l_shape()
    points = np.array([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [0.9, 0.9]])
    coordinates = gencoords.coordinates(points, vertices, edges, kind="mean_value")
    np.testing.assert_allclose(coordinates @ vertices, points, atol=1e-13)
    with pytest.raises(gencoords.OutsideCageError):
        gencoords.coordinates([[1.5, 1.5]], vertices, edges, kind="mean_value")
    with pytest.raises(gencoords.CageError, match="not convex"):
        gencoords.coordinates(points, vertices, edges, kind="wachspress")


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10), (4, 8)])
def test_facets_of_a_hull_in_any_order_are_oriented_outward(dim, count):
    rng = np.random.default_rng(dim)
    vertices, faces = random_convex_polytope(rng, dim, count)
    scrambled = np.array([rng.permutation(face) for face in faces])
    with pytest.raises(gencoords.CageError):
        gencoords.advanced.validate_cage(vertices, scrambled)
    oriented = gencoords.cages.orient_facets_outward(vertices, scrambled)
    gencoords.advanced.validate_cage(vertices, oriented)
    np.testing.assert_array_equal(np.sort(oriented, axis=1), np.sort(scrambled, axis=1))


def test_validate_cage_accepts_a_good_cage_and_returns_it():
    vertices, faces = icosphere(2)
    cage = gencoords.advanced.validate_cage(vertices, faces)
    assert cage.size > 0 and len(cage.topology.ridges) == 3 * len(faces) // 2


def test_a_flat_cage_is_called_flat_not_coincident():
    vertices, faces = icosphere()
    with pytest.raises(gencoords.CageError) as error:
        gencoords.Cage(vertices * (1.0, 1.0, 0.0), faces)  # an object scaled to zero on Z
    assert error.value.problem == "flat"
    assert "the cage is flat: all its vertices lie in one plane" in str(error.value)
    assert "coincide" not in str(error.value)


def test_a_cage_flat_within_its_tolerance_is_flat_and_a_thin_one_is_a_volume():
    vertices, faces = icosphere()
    size = np.linalg.norm(np.ptp(vertices, axis=0))
    with pytest.raises(gencoords.CageError) as error:  # 1e-7 of its size thick, tolerance 1e-6
        gencoords.Cage(vertices * (1.0, 1.0, 0.5e-7 * size), faces, tolerance=1e-6)
    assert error.value.problem == "flat"
    assert re.search(r"thickness 1\.\d+e-07 of its size", str(error.value))  # of the flat cage's size
    assert gencoords.Cage(vertices * (1.0, 1.0, 1e-2), faces, tolerance=1e-6).convex


def test_transposed_vertices_are_said_to_look_transposed():
    vertices, faces = icosphere()
    with pytest.raises(gencoords.CageError) as error:
        gencoords.Cage(vertices.T, faces)
    assert error.value.problem == "transposed"
    message = str(error.value)
    assert f"got (3, {len(vertices)})" in message and "look transposed: pass vertices.T" in message
    assert "faces must be" not in message


def test_a_tolerance_passed_to_a_cage_method_says_where_it_belongs():
    vertices, faces = icosphere()
    cage = gencoords.Cage(vertices, faces)
    with pytest.raises(TypeError, match=r"Cage\.coordinates\(\): .*unexpected keyword argument "
                                        r"'tolerance'; the tolerance belongs to the cage.*"
                                        r"Cage\(vertices, faces, tolerance=\.\.\.\)"):
        cage.coordinates(np.zeros((1, 3)), tolerance=1e-6)
    with pytest.raises(TypeError, match="unexpected keyword argument 'tolernce'") as error:
        cage.coordinates(np.zeros((1, 3)), tolernce=1e-6)
    assert "belongs to the cage" not in str(error.value)


def test_a_cage_with_every_face_flipped_is_reported_inward():
    vertices, faces = octahedron()
    with pytest.raises(gencoords.CageError, match="inward") as error:
        gencoords.advanced.validate_cage(vertices, faces[:, ::-1])
    assert error.value.problem == "inward"
    gencoords.advanced.validate_cage(vertices, faces)  # the same cage the right way out passes


def test_concave_facets_are_the_triangles_around_a_dented_corner():
    """A cube's corner pushed inward bends the edges at that corner inward: the
    triangles flagged are exactly those touching it; a convex cube has none."""
    cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    triangles = gencoords.cages.orient_facets_outward(cube, gencoords.cages.triangulate_quads(cube, quads))
    assert gencoords.advanced.concave_facets(cube, triangles).tolist() == []
    dented = cube.copy()
    dented[0] *= 0.2
    flagged = gencoords.advanced.concave_facets(dented, triangles)
    touching = np.flatnonzero((triangles == 0).any(axis=1))
    assert set(flagged.tolist()) <= set(touching.tolist()) and len(flagged) >= 3
    with pytest.raises(gencoords.CageError, match="not convex"):
        gencoords.advanced.validate_cage(dented, triangles, convex=True)
