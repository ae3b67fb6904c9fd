"""Example cages: regular polygons, octahedra, icospheres, cross-polytopes and random
convex polytopes in any dimension (outward oriented)."""

from itertools import combinations

import numpy as np

from ..base import tolerances

__all__ = ["regular_polygon", "octahedron", "irregular_octahedron", "icosphere", "cross_polytope",
           "random_convex_polytope", "convex_hull_facets"]


def regular_polygon(sides, radius=1.0):
    """Counter-clockwise regular polygon.

    Returns
    -------
    vertices : (sides, 2) float
    edges : (sides, 2) int
    """
    angle = 2.0 * np.pi * np.arange(sides) / sides
    vertices = radius * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    edges = np.stack([np.arange(sides), (np.arange(sides) + 1) % sides], axis=1)
    return vertices, edges


def octahedron(radii=(1.0, 1.0, 1.0)):
    """Octahedron with vertices at +-radii on the axes (regular when radii are equal).

    Returns
    -------
    vertices : (6, 3) float
        Order: +x, -x, +y, -y, +z, -z.
    faces : (8, 3) int
    """
    x, y, z = radii
    vertices = np.array([[x, 0, 0], [-x, 0, 0], [0, y, 0], [0, -y, 0], [0, 0, z], [0, 0, -z]], float)
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                      [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return vertices, faces


def irregular_octahedron():
    """The irregular octahedron of the paper's figure 10, in ``octahedron``'s vertex order
    and with its faces: a convex double pyramid over a planar convex quadrilateral, its
    apexes leaning off axis, so no sphere passes through its vertices.

    Returns
    -------
    vertices : (6, 3) float
        Order: near +x, -x, +y, -y (the quadrilateral, in z = 0), then the two apexes.
    faces : (8, 3) int
    """
    vertices = np.array([[1.25, 0.15, 0.0], [-0.85, -0.1, 0.0], [-0.1, 0.95, 0.0],
                         [0.2, -0.8, 0.0], [0.3, 0.15, 1.1], [-0.25, -0.1, -0.8]])
    return vertices, octahedron()[1]


def icosphere(subdivisions=1, radius=1.0):
    """Geodesic sphere: 10 * 4^s + 2 vertices (12, 42, 162, 642, ...), all on the sphere.

    Returns
    -------
    vertices : (n, 3) float
    faces : (m, 3) int
    """
    t = (1.0 + 5.0 ** 0.5) / 2.0
    vertices = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
                         [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                         [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    faces = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
                      [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
                      [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
                      [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
    for _ in range(subdivisions):
        # One new vertex per edge, shared by both faces: key edges by sorted endpoints.
        edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        midpoints = len(vertices) + inverse.reshape(3, -1).T  # (m, 3): mid of 01, 12, 20
        vertices = np.concatenate([vertices, 0.5 * vertices[unique].sum(axis=1)])
        a, b, c = faces.T
        ab, bc, ca = midpoints.T
        faces = np.concatenate([np.stack(f, axis=1) for f in
                                ([a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca])])
    vertices = radius * vertices / np.linalg.norm(vertices, axis=1, keepdims=True)
    return vertices, faces


def cross_polytope(dim, radii=None):
    """The N-D cross-polytope (2D square, 3D octahedron, 4D 16-cell), outward oriented."""
    radii = np.ones(dim) if radii is None else np.asarray(radii, dtype=float)
    vertices = np.concatenate([np.diag(radii), -np.diag(radii)])
    return vertices, convex_hull_facets(vertices)


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
        if np.all(others < -tolerances.HULL_SIDE) or np.all(others > tolerances.HULL_SIDE):
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
        if (gaps + np.eye(count) * 2.0).min() > tolerances.DIRECTION_GAP:
            break
    axes = rng.uniform(0.5, 2.0, size=dim)
    rotation = np.linalg.qr(rng.normal(size=(dim, dim)))[0]
    vertices = (directions * axes) @ rotation.T + rng.uniform(-3, 3, size=dim)
    return vertices, convex_hull_facets(vertices)
