"""Measures of a closed triangle surface that Make Cage Tight checks its cages with:
normals at the vertices, vertices where two sheets touch, pieces that enclose nothing, and
the triangles a cage of triangles and quads is bound with, and the narrowest gap between
the parts of a mesh (from rays cast outward: the caster, Blender's BVH tree in the add-on,
is the caller's).
"""

import numpy as np

from ..base.triangulation import triangulate_quads

__all__ = ["vertex_normals", "pinched_vertices", "degenerate_pieces", "cage_triangles", "ray_samples", "narrowest_gap"]


def vertex_normals(vertices, triangles):
    """Area-weighted unit normals at the vertices of an outward triangle mesh.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int

    Returns
    -------
    normals : (n, 3) float64
        Zero at vertices of no triangle.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.surface import vertex_normals
    >>> vertices, faces = octahedron()
    >>> bool(np.allclose(vertex_normals(vertices, faces), vertices))  # unit, along each vertex
    True
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64)
    corners = vertices[triangles]
    face = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros_like(vertices)
    for corner in range(3):
        np.add.at(normals, triangles[:, corner], face)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


def pinched_vertices(triangles):
    """Vertices where a closed, edge-manifold triangle mesh touches itself: their faces
    form more than one fan (two sheets meeting at a point).

    Around each vertex, a face's corner leads across its outgoing edge to the face on the
    other side; the corners of a vertex whose faces form one fan make a single cycle.

    Parameters
    ----------
    triangles : (m, 3) int
        Every edge shared by two consistently oriented triangles.

    Returns
    -------
    vertices : (p,) int64
        Sorted; empty for a manifold mesh.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.surface import pinched_vertices
    >>> faces = octahedron()[1]
    >>> pinched_vertices(faces).tolist(), pinched_vertices(np.concatenate([faces, faces + 5])).tolist()
    ([], [5])
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    corner_vertex = triangles.ravel()
    following = np.roll(triangles, -1, axis=1).ravel()  # the corner's outgoing edge ends here
    # The twin of edge (v, w) is (w, v): in its face, the corner at v follows the one at w.
    key = {(int(w), int(v)): c for c, (v, w) in enumerate(zip(corner_vertex, following))}
    successor = np.array([key[(int(v), int(w))] for v, w in zip(corner_vertex, following)])
    twin_face, twin_position = np.divmod(successor, 3)
    step = 3 * twin_face + (twin_position + 1) % 3  # the twin face's corner at v
    seen = np.zeros(len(step), dtype=bool)
    fans = np.zeros(int(corner_vertex.max(initial=-1)) + 1, dtype=np.int64)
    for start in range(len(step)):
        if not seen[start]:
            fans[corner_vertex[start]] += 1
            corner = start
            while not seen[corner]:
                seen[corner] = True
                corner = step[corner]
    return np.flatnonzero(fans > 1).astype(np.int64)


def degenerate_pieces(triangles):
    """Whether a simplified surface has pieces that enclose nothing: a triangle twice (a
    closed piece collapsed to two back-to-back faces) or a vertex in fewer than 3
    triangles. A collapse decimation keeps every separate piece, down to 3 vertices.

    Parameters
    ----------
    triangles : (m, 3) int

    Returns
    -------
    bool

    Examples
    --------
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.surface import degenerate_pieces
    >>> degenerate_pieces(octahedron()[1]), degenerate_pieces([[0, 1, 2], [0, 2, 1]])
    (False, True)
    """
    faces = np.sort(np.asarray(triangles, dtype=np.int64).reshape(-1, 3), axis=1)
    uses = np.bincount(faces.ravel())
    return len(np.unique(faces, axis=0)) < len(faces) or bool(((uses > 0) & (uses < 3)).any())


def cage_triangles(vertices, triangles, quads=None):
    """The triangles a cage of triangles and quads is bound with: its triangles, then
    each quad split as :func:`gencoords.cages.triangulate_quads` splits it (the diagonal
    depends on the positions, so it is found again whenever they move).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
    quads : (q, 4) int or None

    Returns
    -------
    triangles : (m + 2q, 3) int64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.surface import cage_triangles
    >>> square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> cage_triangles(square, np.zeros((0, 3), int), [[0, 1, 2, 3]]).tolist()
    [[0, 1, 2], [0, 2, 3]]
    """
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    if quads is None or not len(quads):
        return triangles
    return np.concatenate([triangles, triangulate_quads(vertices, quads)])


# A ray's hit counts as the gap to another part where the surface hit faces back along it
# within this cosine (about 25 degrees): parallel parts (fingers) count; a crease where
# two overlapping parts meet at an angle does not.
FACING = 0.9
# Of each triangle, the points rays start from (barycentric): its centroid and a point
# towards each corner, so a coarse mesh's long faces are sampled near their ends too.
_SAMPLES = np.array([[2.0, 2.0, 2.0], [4.0, 1.0, 1.0], [1.0, 4.0, 1.0], [1.0, 1.0, 4.0]]) / 6.0


def ray_samples(vertices, triangles, count=20_000):
    """Where rays that measure the gaps between a surface's parts start, and their
    directions: points on the triangles (their centroid and a point towards each
    corner) and the triangles' outward unit normals, at most ``count`` (evenly spread
    over the triangles).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward.
    count : int

    Returns
    -------
    origins : (r, 3) float64
    directions : (r, 3) float64
        Unit; triangles of no area give none.

    Examples
    --------
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.surface import ray_samples
    >>> origins, directions = ray_samples(*octahedron())
    >>> origins.shape, directions.shape  # 8 faces, 4 points each
    ((32, 3), (32, 3))
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    corners = vertices[triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1)
    keep = np.flatnonzero(length > 0.0)
    if len(keep) * len(_SAMPLES) > count:  # evenly spread over the triangles
        keep = keep[np.unique(np.linspace(0, len(keep) - 1, max(1, count // len(_SAMPLES))).astype(np.int64))]
    origins = np.einsum("sc,tci->tsi", _SAMPLES, corners[keep]).reshape(-1, 3)
    directions = np.repeat(normals[keep] / length[keep, None], len(_SAMPLES), axis=0)
    return origins, directions


def narrowest_gap(distances, cosines):
    """The narrowest gap between a surface's parts, from rays cast outward from it
    (:func:`ray_samples`): the shortest distance to a hit whose surface faces back along
    the ray (the cosine between its normal and the ray below ``-FACING``).

    Parameters
    ----------
    distances : (r,) float
        Along each ray to its first hit; ``inf`` (or NaN) for none.
    cosines : (r,) float
        Between the hit surface's outward normal and the ray's direction.

    Returns
    -------
    gap : float
        ``inf`` where no part faces another.

    Examples
    --------
    >>> from gencoords.cages.surface import narrowest_gap
    >>> narrowest_gap([0.5, 0.1, 0.3, float("inf")], [-1.0, -0.5, -0.95, 0.0])  # 0.1: a crease
    0.3
    """
    distances = np.asarray(distances, dtype=np.float64)
    facing = np.isfinite(distances) & (np.asarray(cosines, dtype=np.float64) < -FACING)
    return float(distances[facing].min()) if facing.any() else float("inf")
