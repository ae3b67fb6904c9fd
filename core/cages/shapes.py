"""Example cages: regular polygons, octahedra, icospheres and cross-polytopes in any
dimension, and box-modelled cages made of unit cubes (outward oriented)."""

from itertools import combinations

import numpy as np

__all__ = ["regular_polygon", "octahedron", "irregular_octahedron", "icosphere", "cross_polytope",
           "block_cage", "t_pose_blocks"]


def regular_polygon(sides, radius=1.0):
    """Counter-clockwise regular polygon.

    Returns
    -------
    vertices : (sides, 2) float
    edges : (sides, 2) int

    Examples
    --------
    >>> from gencoords.cages.shapes import regular_polygon
    >>> vertices, edges = regular_polygon(4)
    >>> vertices.round(6).tolist(), edges.tolist()
    ([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [-0.0, -1.0]], [[0, 1], [1, 2], [2, 3], [3, 0]])
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

    Examples
    --------
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron((1.0, 2.0, 3.0))
    >>> vertices[::2].tolist(), faces.shape
    ([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]], (8, 3))
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

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.cages.shapes import irregular_octahedron
    >>> vertices, faces = irregular_octahedron()
    >>> gencoords.coordinates([[0.1, 0.0, 0.1]], vertices, faces, workers=1).shape
    (1, 6)
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

    Examples
    --------
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(2, radius=0.5)
    >>> vertices.shape, faces.shape
    ((162, 3), (320, 3))
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
    """The N-D cross-polytope (2D square, 3D octahedron, 4D 16-cell), outward oriented.

    Parameters
    ----------
    dim : int
    radii : (dim,) float, optional
        The vertices are at +-radii on the axes (all 1 by default).

    Returns
    -------
    vertices : (2 dim, dim) float
        Order: +radii on each axis, then -radii on each axis.
    facets : (2^dim, dim) int
        One vertex per axis, + or -.

    Examples
    --------
    >>> from gencoords.cages.shapes import cross_polytope
    >>> vertices, facets = cross_polytope(4)  # the 16-cell
    >>> vertices.shape, facets.shape
    ((8, 4), (16, 4))
    """
    radii = np.ones(dim) if radii is None else np.asarray(radii, dtype=float)
    vertices = np.concatenate([np.diag(radii), -np.diag(radii)])
    if dim == 2:  # counter-clockwise from -x
        return vertices, np.array([[2, 3], [3, 0], [0, 1], [1, 2]])
    inside = vertices.mean(axis=0)
    facets = []
    for facet in combinations(range(2 * dim), dim):
        if len({vertex % dim for vertex in facet}) < dim:
            continue  # a vertex and its opposite: not on one facet
        facet = list(facet)
        # det[v_0 - x, v_1 - x, ...] > 0 for x inside: orient against the centre.
        if np.linalg.det(vertices[facet] - inside) < 0:
            facet[0], facet[1] = facet[1], facet[0]
        facets.append(facet)
    return vertices, np.array(facets)


def block_cage(occupied, size=1.0):
    """The surface of a union of cubes, as a quad cage (a box-modelled, non-convex cage).

    Parameters
    ----------
    occupied : (X, Y, Z) bool
        Which unit cubes of a grid are filled; cubes that touch only along an edge or at
        a corner would make the surface non-manifold (not checked).
    size : float
        Edge length of a cube.

    Returns
    -------
    vertices : (n, 3) float
        The lattice points on the surface, cube (i, j, k) spanning ``size * [i, i+1]`` x ...
    quads : (q, 4) int
        One per exposed cube side, counter-clockwise seen from outside.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import block_cage
    >>> vertices, quads = block_cage(np.ones((2, 1, 1), dtype=bool))  # two cubes in a row
    >>> vertices.shape, quads.shape
    ((12, 3), (10, 4))
    """
    occupied = np.asarray(occupied, dtype=bool)
    padded = np.pad(occupied, 1)
    cubes = np.argwhere(occupied)
    corners = []
    for axis in range(3):
        u, w = np.eye(3, dtype=np.int64)[[(axis + 1) % 3, (axis + 2) % 3]]
        ring = np.array([0 * u, u, u + w, w])  # counter-clockwise about +axis
        for sign in (1, -1):
            step = np.eye(3, dtype=np.int64)[axis] * sign
            exposed = cubes[~padded[tuple((cubes + 1 + step).T)]]
            offset = np.eye(3, dtype=np.int64)[axis] * (sign > 0)
            order = ring if sign > 0 else ring[::-1]
            corners.append(exposed[:, None, :] + offset + order[None])
    corners = np.concatenate(corners)
    points, quads = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    return points * float(size), quads.reshape(-1, 4)


def t_pose_blocks():
    """Occupancy of a T-posed figure of cubes for :func:`block_cage`: legs, a torso, arms
    along x and a head, 2 cubes deep (13, 2, 10) bool; its cage has 234 vertices.

    Examples
    --------
    >>> from gencoords.cages.shapes import block_cage, t_pose_blocks
    >>> vertices, quads = block_cage(t_pose_blocks())
    >>> len(vertices)
    234
    """
    occupied = np.zeros((13, 2, 10), dtype=bool)
    occupied[3:5, :, 0:4] = occupied[8:10, :, 0:4] = True  # legs
    occupied[3:10, :, 4:8] = True  # torso
    occupied[0:13, :, 6:8] = True  # arms
    occupied[5:8, :, 8:10] = True  # head
    return occupied
