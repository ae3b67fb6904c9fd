"""Test polytopes: the core's example cages, points in them, and non-convex cages."""

import numpy as np

from gencoords.tools.shapes import (convex_hull_facets, cross_polytope, icosphere, octahedron, random_convex_polytope,
                         regular_polygon)


def random_interior_points(rng, vertices, count, shrink=0.95):
    """Random points strictly inside the convex hull of the vertices.

    Dirichlet combinations of the vertices, pulled towards the centroid.

    Returns
    -------
    points : (count, N) float
    """
    mix = rng.dirichlet(np.full(len(vertices), 0.7), size=count)
    centre = vertices.mean(axis=0)
    pull = rng.uniform(0.0, shrink, size=(count, 1))
    return centre + pull * (mix @ vertices - centre)


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


__all__ = ["convex_hull_facets", "random_convex_polytope", "random_interior_points",
           "cross_polytope", "dented_icosphere", "l_shape", "icosphere", "octahedron",
           "regular_polygon"]
