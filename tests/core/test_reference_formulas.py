"""The general construction against independent formulas from the literature."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import gencoords
from gencoords.construction.general import point_frame, prepare_cage
from gencoords.surfaces.named import power_dual, power_dual_by_subsets
from tests.fixtures.polytopes import cross_polytope, octahedron, random_convex_polytope, random_interior_points
from reference_formulas import (discrete_harmonic_2d_cotangent, discrete_harmonic_3d_cotangent,
                                discrete_harmonic_by_stiffness,
                                floater_2d, mean_value_2d_trigonometric, mean_value_3d_ju,
                                mean_value_by_integration, normalise, wachspress_3d_polar_dual,
                                wachspress_by_polar_dual_volumes)

SEEDS = st.integers(0, 2**32 - 1)
EXAMPLES = settings(max_examples=10, deadline=None)


def random_case(seed, dim, count, points=8):
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return vertices, faces, random_interior_points(rng, vertices, points)


def polygon_order(vertices, faces):
    """Vertex order around a polygon given as counter-clockwise edges."""
    following = dict(faces.tolist())
    order = [int(faces[0, 0])]
    while len(order) < len(vertices):
        order.append(following[order[-1]])
    return np.array(order)


@pytest.mark.parametrize("kind,reference,tolerance", [
    ("mean_value", mean_value_2d_trigonometric, 1e-13),  # Floater's formula (4)
    ("discrete_harmonic", discrete_harmonic_2d_cotangent, 1e-12),  # cotangent form (13)
])
@given(seed=SEEDS)
@EXAMPLES
def test_2d_coordinates_equal_independent_formulas(seed, kind, reference, tolerance):
    vertices, faces, points = random_case(seed, 2, 7)
    order = polygon_order(vertices, faces)
    ours = gencoords.coordinates(points, vertices, faces, kind=kind)[:, order]
    theirs = np.array([normalise(reference(x, vertices[order])) for x in points])
    np.testing.assert_allclose(ours, theirs, atol=tolerance)


@pytest.mark.parametrize("kind,power", [("wachspress", 0), ("mean_value", 1), ("discrete_harmonic", 2)])
@given(seed=SEEDS)
@EXAMPLES
def test_2d_floater_with_c_equal_to_powers_of_the_distance_14(seed, kind, power):
    vertices, faces, points = random_case(seed, 2, 7)
    order = polygon_order(vertices, faces)
    ours = gencoords.coordinates(points, vertices, faces, kind=kind)[:, order]
    polygon = vertices[order]
    theirs = np.array([normalise(floater_2d(x, polygon, np.linalg.norm(polygon - x, axis=1) ** power))
                       for x in points])
    np.testing.assert_allclose(ours, theirs, atol=1e-12)


@pytest.mark.parametrize("kind,reference,tolerance", [
    ("mean_value", mean_value_3d_ju, 1e-12),  # Ju, Schaefer and Warren 2005
    ("wachspress", wachspress_3d_polar_dual, 1e-12),  # polar-dual face areas
    ("discrete_harmonic", discrete_harmonic_3d_cotangent, 1e-11),  # cotangent form (20)
])
@given(seed=SEEDS)
@EXAMPLES
def test_3d_coordinates_equal_independent_formulas(seed, kind, reference, tolerance):
    vertices, faces, points = random_case(seed, 3, 12)
    ours = gencoords.coordinates(points, vertices, faces, kind=kind)
    theirs = np.array([normalise(reference(x, vertices, faces)) for x in points])
    np.testing.assert_allclose(ours, theirs, atol=tolerance)


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10)])
@pytest.mark.parametrize("heights", ["wachspress", "voronoi", "random"])
@given(seed=SEEDS)
@EXAMPLES
def test_power_dual_closed_forms_equal_the_subset_construction(seed, dim, count, heights):
    vertices, faces, points = random_case(seed, dim, count)
    frame = point_frame(prepare_cage(vertices, faces), points)
    lengths_squared = frame.ridge_lengths_squared
    h = {"wachspress": np.ones_like(lengths_squared), "voronoi": 0.5 * lengths_squared,
         "random": np.random.default_rng(seed).uniform(0.1, 2.0, lengths_squared.shape)}[heights]
    closed = power_dual(frame, h)
    subsets = power_dual_by_subsets(np.moveaxis(frame.ridge_gram, (0, 1), (-2, -1)),
                                    np.moveaxis(h, 0, -1)) * frame.ridge_measure
    np.testing.assert_allclose(closed, subsets, rtol=1e-10, atol=1e-12 * np.abs(closed).max())


def test_3d_table_formulas_of_math_md():
    """d of the four named surfaces against docs/MATH.md's table, edge by edge."""
    vertices, faces = octahedron((1.0, 1.3, 0.8))
    x = np.array([0.1, -0.2, 0.15])
    ridges = gencoords.advanced.ridges(faces)
    e_j, e_k = vertices[ridges[:, 0]] - x, vertices[ridges[:, 1]] - x
    l_j, l_k = np.linalg.norm(e_j, axis=1), np.linalg.norm(e_k, axis=1)
    cross = np.linalg.norm(np.cross(e_j, e_k), axis=1)
    cos_a = np.einsum("ij,ij->i", e_j, e_k) / (l_j * l_k)
    angle = np.arccos(cos_a)

    def cot_at(vertex, other):  # angle at `vertex` between (other - vertex) and (x - vertex)
        u, v = other - vertex, x - vertex
        return np.einsum("ij,ij->i", u, v) / np.linalg.norm(np.cross(u, v), axis=1)

    vj, vk = vertices[ridges[:, 0]], vertices[ridges[:, 1]]
    table = {
        "mean_value": angle / 2,
        "discrete_harmonic": cross / 2,
        "wachspress": (2 - cos_a * (l_j / l_k + l_k / l_j)) / (2 * cross),
        "voronoi": (l_j ** 2 * cot_at(vk, vj) + l_k ** 2 * cot_at(vj, vk)) / 8,
    }
    for kind, expected in table.items():
        np.testing.assert_allclose(gencoords.advanced.ridge_scalars(x, vertices, faces, kind)[0], expected, rtol=1e-12)


@pytest.mark.parametrize("dim", [3, 4, 5])
def test_mean_value_equals_its_definition_by_integration(dim):
    """The N-D mean value scalar (3D: angle / 2; 4D: solid angle / 3, docs/MATH.md's
    derivation) against Monte Carlo integration of the definition."""
    vertices, facets = cross_polytope(dim, radii=np.linspace(0.7, 1.4, dim))
    x = np.linspace(0.05, 0.2, dim)
    ours = gencoords.coordinates(x, vertices, facets, kind="mean_value")[0]
    estimate = normalise(mean_value_by_integration(x, vertices, facets))
    np.testing.assert_allclose(estimate, ours, atol=3e-3)
    # The check can fail: Wachspress coordinates differ by more than its tolerance.
    assert np.abs(gencoords.coordinates(x, vertices, facets, kind="wachspress")[0] - estimate).max() > 1e-2


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10), (4, 8)])  # 5D: 40 s of hull volumes
@given(seed=SEEDS)
@settings(max_examples=3, deadline=None)
def test_wachspress_equals_polar_dual_volumes_in_any_dimension(seed, dim, count):
    """MATH.md's N-D power-dual scalars against the polar dual's facet volumes."""
    vertices, faces, points = random_case(seed, dim, count, points=3)
    ours = gencoords.coordinates(points, vertices, faces, kind="wachspress")
    theirs = np.array([normalise(wachspress_by_polar_dual_volumes(x, vertices, faces)) for x in points])
    np.testing.assert_allclose(ours, theirs, atol=1e-10)


@pytest.mark.parametrize("dim,count", [(2, 7), (3, 10), (4, 8), (5, 9)])
@given(seed=SEEDS)
@EXAMPLES
def test_discrete_harmonic_minimises_the_dirichlet_energy_in_any_dimension(seed, dim, count):
    """MATH.md's N-D scalar (volume of {x} + ridge) against the stiffness matrix of eq. (10)."""
    vertices, faces, points = random_case(seed, dim, count)
    ours = gencoords.coordinates(points, vertices, faces, kind="discrete_harmonic")
    theirs = np.array([normalise(discrete_harmonic_by_stiffness(x, vertices, faces)) for x in points])
    np.testing.assert_allclose(ours, theirs, atol=1e-10)
