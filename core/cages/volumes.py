"""Volumes of triangle meshes: the signed volume of a closed mesh, and the volume of the
union of overlapping closed shells (a body modelled as intersecting parts).

A mesh made of shells that pass through one another (a character's capsules) counts the
overlaps twice in its signed volume; the region it occupies is where its winding number
is positive. Along a vertical line the winding number changes by +-1 at each crossing
of the surface (the sign of the face normal's z), so the union's length on that line is
exact; :func:`union_volume` sums those lengths over a grid of lines (columns), the
volume to the columns' spacing.
"""

import numpy as np

__all__ = ["signed_volume", "union_volume", "volume_ratio"]


def signed_volume(vertices, triangles):
    """Volume enclosed by a closed, outward-oriented triangle mesh (divergence theorem).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int

    Returns
    -------
    volume : float
        Negative for an inward mesh; overlapping shells count twice.

    Examples
    --------
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.volumes import signed_volume
    >>> round(signed_volume(*octahedron()), 12)  # |x| + |y| + |z| <= 1
    1.333333333333
    """
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(triangles, dtype=np.int64)]
    centre = corners.reshape(-1, 3).mean(axis=0)  # origin-independent, fewer cancellations
    a, b, c = (corners[:, i] - centre for i in range(3))
    return float(np.einsum("mi,mi->m", a, np.cross(b, c)).sum() / 6.0)


def _column_hits(corners, cell, origin, shape):
    """Each (triangle, column) pair where a column's vertical line passes inside the
    triangle's projection: (triangle, column index, z of the crossing, +-1 winding step)."""
    low = np.ceil((corners[:, :, :2].min(axis=1) - origin) / cell - 0.5).astype(np.int64)
    high = np.floor((corners[:, :, :2].max(axis=1) - origin) / cell - 0.5).astype(np.int64)
    low, high = np.maximum(low, 0), np.minimum(high, np.array(shape) - 1)
    span = np.maximum(high - low + 1, 0)
    counts = span[:, 0] * span[:, 1]
    triangle = np.repeat(np.arange(len(corners)), counts)
    within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    ix = low[triangle, 0] + within % np.maximum(span[triangle, 0], 1)
    iy = low[triangle, 1] + within // np.maximum(span[triangle, 0], 1)
    xy = origin + (np.column_stack([ix, iy]) + 0.5) * cell
    a, b, c = (corners[triangle, i] for i in range(3))
    area = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    weights = []
    for p, q in ((b, c), (c, a), (a, b)):
        weights.append((q[:, 0] - p[:, 0]) * (xy[:, 1] - p[:, 1])
                       - (q[:, 1] - p[:, 1]) * (xy[:, 0] - p[:, 0]))
    weights = np.stack(weights, axis=1)
    # Half-open at edges (>= 0 on one side, > 0 on the other) would need exact arithmetic;
    # the columns sit at cell centres shifted off the grid of typical modelled edges.
    hit = ((weights >= 0).all(axis=1) | (weights <= 0).all(axis=1)) & (area != 0)
    weights, area = weights[hit], area[hit]
    z = (weights[:, 0] * a[hit, 2] + weights[:, 1] * b[hit, 2] + weights[:, 2] * c[hit, 2]) / area
    # Going up, a face whose normal points down (negative projected area) is an entry.
    return ix[hit] + shape[0] * iy[hit], z, -np.sign(area).astype(np.int64)


def union_volume(vertices, triangles, columns=256):
    """Volume of the region where a closed mesh's winding number is positive: the union
    of its shells, overlaps counted once.

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward oriented closed shells, which may overlap one another.
    columns : int
        Columns (vertical lines) across the larger horizontal extent; square cells.

    Returns
    -------
    volume : float
        Exact along each column; the error is that of sampling the horizontal extent at
        the columns' spacing (about the surface's area times half a spacing, at worst).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.volumes import union_volume
    >>> vertices, faces = octahedron()
    >>> both = np.concatenate([vertices, vertices + [0.0, 0.0, 1.0]])  # overlapping by 1/6
    >>> round(union_volume(both, np.concatenate([faces, faces + 6]), columns=400), 2)
    2.5
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    corners = vertices[np.asarray(triangles, dtype=np.int64)]
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    cell = float((high - low)[:2].max()) / columns
    if cell == 0.0:
        return 0.0
    # A shift by an irrational share of a cell keeps columns off modelled grid edges.
    origin = low[:2] - cell * (0.5 - 0.5 / np.sqrt(2.0))
    shape = (int(np.ceil((high[0] - origin[0]) / cell)) + 1, int(np.ceil((high[1] - origin[1]) / cell)) + 1)
    column, z, step = _column_hits(corners, cell, origin, shape)
    order = np.lexsort((z, column))
    column, z, step = column[order], z[order], step[order]
    winding = np.cumsum(step)  # the winding number just above each crossing ...
    starts = np.r_[0, np.flatnonzero(np.diff(column)) + 1]
    # ... counted from zero below each column's lowest crossing.
    winding -= np.repeat(winding[starts] - step[starts], np.diff(np.r_[starts, len(column)]))
    following = np.r_[z[1:], z[-1:]]
    same_column = np.r_[column[1:] == column[:-1], False]
    length = np.where(same_column & (winding > 0), following - z, 0.0)
    return float(length.sum() * cell * cell)


def volume_ratio(cage_vertices, cage_triangles, mesh_vertices, mesh_triangles, columns=256):
    """The cage's volume over the mesh's (the union of its shells, see
    :func:`union_volume`).

    Parameters
    ----------
    cage_vertices : (n, 3) float
    cage_triangles : (m, 3) int
    mesh_vertices : (k, 3) float
    mesh_triangles : (t, 3) int
    columns : int
        The union volume's columns across the mesh.

    Returns
    -------
    ratio : float
        ``inf`` for a mesh that encloses no volume (open or flat).

    Examples
    --------
    >>> from gencoords.cages.shapes import octahedron
    >>> from gencoords.cages.volumes import volume_ratio
    >>> vertices, faces = octahedron()
    >>> round(volume_ratio(2.0 * vertices, faces, vertices, faces, columns=400), 2)
    8.0
    """
    mesh = union_volume(mesh_vertices, mesh_triangles, columns)
    cage = signed_volume(cage_vertices, cage_triangles)
    return cage / mesh if mesh > 0.0 else float("inf")
