"""Test polytopes: the core's example cages, random convex polytopes and points in them
(scripts.common.polytopes, shared with the benchmarks), and non-convex cages."""

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st

from gencoords.cages.shapes import cross_polytope, icosphere, octahedron, regular_polygon
from scripts.common.polytopes import convex_hull_facets, random_convex_polytope, random_interior_points

SEEDS = st.integers(0, 2**32 - 1)
# (dimension, vertex count) of the random polytopes: polygons, polyhedra, 4-polytopes
SHAPES = [(2, 7), (3, 10), (4, 8)]
EXAMPLES = settings(max_examples=15, deadline=None)


def polytope_and_points(seed, dim, count, points=20):
    """A random convex polytope and points inside: (rng, (n, N) vertices, (m, N) facets, (points, N))."""
    rng = np.random.default_rng(seed)
    vertices, faces = random_convex_polytope(rng, dim, count)
    return rng, vertices, faces, random_interior_points(rng, vertices, points)


def homogeneity_residual(weights, points, vertices):
    """max |sum_i w_i (v_i - x)|, relative to the weights' and the cage's sizes:
    (k, n) weights, (k, N) points, (n, N) vertices -> float."""
    spokes = vertices[None, :, :] - points[:, None, :]
    size = np.ptp(vertices, axis=0).max()
    return np.abs(np.einsum("kn,knN->kN", weights, spokes)).max() / (np.abs(weights).max() * size)


def dented_icosphere():
    """A closed, consistently oriented, non-convex cage: an icosphere with one vertex pushed in."""
    vertices, faces = icosphere(1)
    vertices = vertices.copy()
    vertices[0] *= 0.45
    return vertices, faces


def l_shape():
    """A non-convex 2D polygon (counter-clockwise)."""
    vertices = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    return vertices, np.stack([np.arange(6), (np.arange(6) + 1) % 6], axis=1)


__all__ = ["EXAMPLES", "SEEDS", "SHAPES", "homogeneity_residual", "polytope_and_points", "convex_hull_facets", "random_convex_polytope", "random_interior_points",
           "cross_polytope", "dented_icosphere", "l_shape", "icosphere", "octahedron",
           "regular_polygon"]
