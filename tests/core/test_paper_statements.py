"""The paper's statements, one test each, in 2D, 3D and 4D where they apply.

Propositions 1 and 4 (and their N-D form) are one statement about the general
construction; 3 and 9 one about Floater's form; 10 and the corollaries one about
completeness. Each test is named after the statement it checks; the statements that
hold for any polytope are checked on random ones (hypothesis) in 2D, 3D and 4D.
"""

import numpy as np
import pytest
from hypothesis import given

import gencoords
from gencoords.cages.shapes import cross_polytope, icosphere, irregular_octahedron, octahedron
from tests.fixtures.polytopes import (convex_hull_facets, homogeneity_residual, polytope_and_points,
                                      random_convex_polytope, random_interior_points, regular_polygon)
from tests.fixtures.strategies import EXAMPLES, SEEDS, SHAPES

DIMENSIONS = [2, 3, 4]
VERTEX_COUNTS = {2: 8, 3: 12, 4: 9}


def polytope(dim, seed=0, points=12):
    rng = np.random.default_rng(seed + 10 * dim)
    vertices, faces = random_convex_polytope(rng, dim, VERTEX_COUNTS[dim])
    return rng, vertices, faces, random_interior_points(rng, vertices, points)


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_propositions_1_and_4_any_ridge_scalars_give_homogeneous_weights(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    d = rng.normal(size=(len(points), len(gencoords.advanced.ridges(faces))))  # any sign, any size
    weights = gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, d)
    assert homogeneity_residual(weights, points, vertices) < 1e-11


@pytest.mark.parametrize("dim", DIMENSIONS)
def test_propositions_2_and_5_the_polytope_itself_generates_discrete_harmonic(dim):
    # Projected radially onto P itself, a ridge stays where it is: the surface P gives
    # discrete harmonic coordinates (the polar dual's closed form is checked against its
    # volumes in test_reference_formulas).
    _, vertices, faces, points = polytope(dim, seed=1, points=4)
    cage = gencoords.advanced.validate_cage(vertices, faces)
    normals = cage.facet_normals / np.linalg.norm(cage.facet_normals, axis=1, keepdims=True)
    offsets = np.einsum("mN,mN->m", vertices[faces[:, 0]], normals)

    def boundary(x, u):
        speeds = np.einsum("ksN,mN->ksm", u, normals)
        with np.errstate(divide="ignore"):
            return np.where(speeds > 0, (offsets - x @ normals.T)[:, None] / speeds, np.inf).min(axis=2)

    d = gencoords.advanced.ridge_scalars_from_surface(points, vertices, faces, boundary, levels=3 if dim == 4 else 5)
    weights = gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, d)
    np.testing.assert_allclose(weights / weights.sum(axis=1, keepdims=True),
                               gencoords.coordinates(points, vertices, faces, kind="discrete_harmonic"),
                               atol=1e-4 if dim == 4 else 1e-8)


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_propositions_3_and_9_floater_equals_the_construction_when_d_is_n_factorial_c_over_m(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    c = rng.uniform(0.1, 2.0, size=(len(points), len(gencoords.advanced.ridges(faces))))
    d = gencoords.advanced.ridge_scalars_from_floater(points, vertices, faces, c)
    floater = gencoords.advanced.floater_weights(points, vertices, faces, c)
    general = gencoords.advanced.weights_from_ridge_scalars(points, vertices, faces, d)
    np.testing.assert_allclose(general, floater, rtol=1e-9, atol=1e-9 * np.abs(floater).max())
    back = gencoords.advanced.floater_from_ridge_scalars(points, vertices, faces, d)
    np.testing.assert_allclose(back, c, rtol=1e-12)


@pytest.mark.parametrize("dim,count", SHAPES)
@given(seed=SEEDS)
@EXAMPLES
def test_proposition_8_floater_gives_homogeneous_weights_for_any_scalars(seed, dim, count):
    rng, vertices, faces, points = polytope_and_points(seed, dim, count)
    c = rng.normal(size=(len(points), len(gencoords.advanced.ridges(faces))))
    weights = gencoords.advanced.floater_weights(points, vertices, faces, c)
    assert homogeneity_residual(weights, points, vertices) < 1e-10


@pytest.mark.parametrize("dim", DIMENSIONS)
def test_proposition_10_and_corollaries_1_2_any_coordinates_come_from_some_surface(dim):
    # Coordinates of another method (here: Wachspress, and random homogeneous weights)
    # are reproduced by some Floater scalars c, hence some ridge scalars d.
    rng, vertices, faces, points = polytope(dim, seed=4, points=3)
    target = gencoords.coordinates(points[0], vertices, faces, kind="wachspress")[0]
    c = gencoords.advanced.floater_scalars(points[0], vertices, faces, target)
    rebuilt = gencoords.advanced.floater_weights(points[:1], vertices, faces, c[None])[0]
    np.testing.assert_allclose(rebuilt / rebuilt.sum(), target, atol=1e-10)
    d = gencoords.advanced.ridge_scalars_from_floater(points[:1], vertices, faces, c[None])
    again = gencoords.advanced.weights_from_ridge_scalars(points[:1], vertices, faces, d)[0]
    np.testing.assert_allclose(again / again.sum(), target, atol=1e-10)


@given(seed=SEEDS)
@EXAMPLES
def test_proposition_6_voronoi_equals_discrete_harmonic_in_2d(seed):
    _, vertices, faces, points = polytope_and_points(seed, 2, 7)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="voronoi"),
                               gencoords.coordinates(points, vertices, faces, kind="discrete_harmonic"),
                               atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3, 4])
@given(seed=SEEDS)
@EXAMPLES
def test_proposition_7_wachspress_equals_voronoi_exactly_when_the_vertices_are_cospherical(seed, dim):
    rng = np.random.default_rng(seed)
    count = {2: 7, 3: 10, 4: 8}[dim]
    directions = rng.normal(size=(count, dim))
    on_sphere = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    faces = convex_hull_facets(on_sphere)
    points = random_interior_points(rng, on_sphere, 20)
    voronoi = gencoords.coordinates(points, on_sphere, faces, kind="voronoi")
    wachspress = gencoords.coordinates(points, on_sphere, faces, kind="wachspress")
    np.testing.assert_allclose(voronoi, wachspress, atol=1e-11)
    # Off the sphere (stretched: still convex, same faces) they differ.
    stretched = on_sphere * np.linspace(0.6, 1.4, dim)
    voronoi = gencoords.coordinates(points * np.linspace(0.6, 1.4, dim), stretched, faces, kind="voronoi")
    wachspress = gencoords.coordinates(points * np.linspace(0.6, 1.4, dim), stretched, faces, kind="wachspress")
    assert np.abs(voronoi - wachspress).max() > 1e-4


@pytest.mark.parametrize("dim", DIMENSIONS)
@pytest.mark.parametrize("kind", ["wachspress", "mean_value"])
def test_figures_9_to_11_wachspress_and_mean_value_are_positive(dim, kind):
    for seed in range(3):
        _, vertices, faces, _ = polytope(dim, seed=seed)
        assert gencoords.reports.coordinate_report(vertices, faces, kind, samples=600).positive


def test_figure_9_discrete_harmonic_is_negative_somewhere_in_a_regular_octahedron():
    vertices, faces = octahedron()
    report = gencoords.reports.coordinate_report(vertices, faces, "discrete_harmonic", samples=600)
    assert not report.positive and report.smallest < -1e-3
    assert gencoords.reports.coordinate_report(vertices, faces, "mean_value", samples=600).positive


@pytest.mark.parametrize("shape", ["octahedron", "icosahedron", "icosphere", "16-cell"])
def test_figure_9_voronoi_equals_wachspress_in_regular_polytopes(shape):
    vertices, faces = {"octahedron": octahedron(), "icosahedron": icosphere(0), "icosphere": icosphere(2),
                       "16-cell": cross_polytope(4)}[shape]
    points = random_interior_points(np.random.default_rng(7), vertices, 30)
    np.testing.assert_allclose(gencoords.coordinates(points, vertices, faces, kind="voronoi"),
                               gencoords.coordinates(points, vertices, faces, kind="wachspress"), atol=1e-12)


def test_figure_10_voronoi_differs_from_wachspress_in_an_irregular_octahedron():
    vertices, faces = irregular_octahedron()
    points = random_interior_points(np.random.default_rng(8), vertices, 30)
    gap = np.abs(gencoords.coordinates(points, vertices, faces, kind="voronoi")
                 - gencoords.coordinates(points, vertices, faces, kind="wachspress")).max()
    assert gap > 1e-2


def test_figure_11_voronoi_goes_negative_in_this_convex_polyhedron():
    # Found by searching random 7-vertex hulls (seed 3 of tests.fixtures.polytopes.random_convex_polytope),
    # rounded and kept: Voronoi reaches about -0.06 where Wachspress stays positive.
    vertices = np.array([[-2.72, 0.531, -2.229], [-1.946, 1.614, 0.14], [-1.415, 1.668, 0.358],
                         [-2.048, 0.301, -3.077], [-1.956, 1.777, -1.014], [-0.797, 1.233, -0.319],
                         [-2.318, 0.266, -2.982]])
    faces = convex_hull_facets(vertices)
    voronoi = gencoords.reports.coordinate_report(vertices, faces, "voronoi", samples=800)
    assert voronoi.smallest < -0.02
    assert gencoords.reports.coordinate_report(vertices, faces, "wachspress", samples=800).positive


def test_regular_polygons_are_handled_like_the_paper_figures():
    # 2D counterpart of figure 9: in a regular hexagon all four kinds agree at the centre.
    vertices, edges = regular_polygon(6)
    centre = np.zeros((1, 2))
    for kind in gencoords.advanced.KINDS:
        np.testing.assert_allclose(gencoords.coordinates(centre, vertices, edges, kind=kind), 1 / 6, atol=1e-14)
