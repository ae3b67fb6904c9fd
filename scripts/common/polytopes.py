"""Random convex polytopes in any dimension and points inside them: the fixtures of the
core's tests and benchmarks (tests/core/polytopes.py, scripts/benchmarks/bench_core.py).

Not part of the core: a user's cage comes from their mesh, and the core's example cages
(``gencoords.cages.shapes``) are regular ones.
"""

from itertools import combinations

import numpy as np

__all__ = ["convex_hull_facets", "random_convex_polytope", "random_interior_points"]

# A hull facet's plane has every other point farther than this on one side; random
# directions of a polytope are at least this far apart.
HULL_SIDE = 1e-12
DIRECTION_GAP = 1e-3


def convex_hull_facets(points):
    """Facets of the convex hull of points in general convex position (every point a vertex).

    Brute force over all N-subsets: fine for the dozen points a test uses.

    Parameters
    ----------
    points : (n, N) float

    Returns
    -------
    facets : (m, N) int
        Outward oriented (det[v_1 - v_0, ...] ordering, as the core expects).
    """
    count, dim = points.shape
    if dim == 2:
        centre = points.mean(axis=0)
        order = np.argsort(np.arctan2(*(points - centre).T[::-1]))
        return np.stack([order, np.roll(order, -1)], axis=1)
    facets = []
    for subset in combinations(range(count), dim):
        base = points[subset[0]]
        edges = points[list(subset[1:])] - base
        # Normal: the null vector of the edges (last right-singular vector).
        normal = np.linalg.svd(edges)[2][-1]
        side = (points - base) @ normal
        others = np.delete(side, subset)
        if np.all(others < -HULL_SIDE) or np.all(others > HULL_SIDE):
            facet = list(subset)
            # det[v_0 - x, v_1 - x, ...] > 0 for x inside: orient against the centroid.
            inside = points.mean(axis=0)
            if np.linalg.det(points[facet] - inside) < 0:
                facet[0], facet[1] = facet[1], facet[0]
            facets.append(facet)
    return np.array(facets)


def random_convex_polytope(rng, dim, count):
    """A random convex simplicial polytope: points on a random ellipsoid.

    Parameters
    ----------
    rng : numpy Generator
    dim : int
    count : int
        Number of vertices (> dim).

    Returns
    -------
    vertices : (count, dim) float
    facets : (m, dim) int
    """
    while True:  # redraw the rare near-coincident vertices (an ill-conditioned cage whose
        # rounding the precision tests would blame on the formulas)
        directions = rng.normal(size=(count, dim))
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        gaps = np.linalg.norm(directions[:, None] - directions[None], axis=-1)
        if (gaps + np.eye(count) * 2.0).min() > DIRECTION_GAP:
            break
    axes = rng.uniform(0.5, 2.0, size=dim)
    rotation = np.linalg.qr(rng.normal(size=(dim, dim)))[0]
    vertices = (directions * axes) @ rotation.T + rng.uniform(-3, 3, size=dim)
    return vertices, convex_hull_facets(vertices)


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
