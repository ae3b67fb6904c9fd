"""Splitting a polygon cage's quads into triangles without creating dents."""

import numpy as np

from .inputs import checked

__all__ = ["triangulate_quads"]


@checked
def triangulate_quads(vertices, quads):
    """Split each quad along the diagonal that keeps the surface convex there.

    A non-planar quad has one diagonal along which its two triangles fold outward and
    one along which they fold inward; an artist dragging a corner of a convex quad cage
    expects the former (the inward fold would make a convex cage non-convex). Planar
    quads may use either; the first diagonal is kept.

    Parameters
    ----------
    vertices : (n, 3) float
    quads : (q, 4) int
        Corners counter-clockwise seen from outside.

    Returns
    -------
    triangles : (2q, 3) int
        Quad j gives triangles 2j and 2j + 1, outward oriented.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    >>> gencoords.cages.triangulate_quads(corners, np.array([[0, 1, 2, 3]])).shape
    (2, 3)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    quads = np.asarray(quads, dtype=np.int64).reshape(-1, 4)
    a, b, c, d = (vertices[quads[:, i]] for i in range(4))
    # Split (a, b, c) + (a, c, d) folds inward when d lies above the plane of (a, b, c).
    folds_inward = np.einsum("qN,qN->q", d - a, np.cross(b - a, c - a)) > 0.0
    first = np.where(folds_inward[:, None], quads[:, [0, 1, 3]], quads[:, [0, 1, 2]])
    second = np.where(folds_inward[:, None], quads[:, [1, 2, 3]], quads[:, [0, 2, 3]])
    return np.stack([first, second], axis=1).reshape(-1, 3)
