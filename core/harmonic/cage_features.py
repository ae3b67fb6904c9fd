"""What a grid must resolve in a cage: the narrowest gap between parts that are not
neighbours on the cage (fingers, legs side by side) and the thinnest part (a tail, a
wall), measured from the cage alone (issue 35, item 1).

From each triangle's centroid a ray leaves along the outward normal (the gap: the first
triangle it meets that shares no vertex with it) and one along the inward normal (the
thickness: the first triangle it meets). A grid separates two parts when at least one
node lies between them, and holds a part when a node lies inside it: cells of about half
the smaller of the two do both.
"""

import numpy as np

from .boundary_values import segment_crossings

__all__ = ["narrowest_gap_and_thinnest_part", "resolving_resolution"]

_START = 1e-9  # of the cage's size: the rays start this far off their triangle
_HOPS = 4  # neighbours a gap's ray passes before it gives up


def _unit_normals(vertices, triangles):
    a, b, c = (vertices[triangles[:, corner]] for corner in range(3))
    normals = np.cross(b - a, c - a)
    return (a + b + c) / 3.0, normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)


def narrowest_gap_and_thinnest_part(vertices, triangles):
    """The narrowest gap between non-neighbouring parts of the cage and its thinnest part
    (world units; inf where no ray finds one).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward oriented, closed.

    Returns
    -------
    gap, thickness : float

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.cage_features import narrowest_gap_and_thinnest_part
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, triangles = icosphere(1)
    >>> gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles)
    >>> gap, bool(1.8 < thickness < 2.0)  # no other part; about the sphere's diameter
    (inf, True)
    """
    vertices, triangles = np.asarray(vertices, dtype=np.float64), np.asarray(triangles)
    centres, normals = _unit_normals(vertices, triangles)
    size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    reach = 2.0 * size
    inward, _, _ = segment_crossings(centres - _START * size * normals, -reach * normals, vertices, triangles)
    thickness = float((inward * reach).min(initial=np.inf))
    own = np.sort(triangles, axis=1)
    starts, travelled = centres + _START * size * normals, np.zeros(len(centres))
    gap = np.inf
    pending = np.arange(len(centres))
    for _ in range(_HOPS):
        fraction, columns, _ = segment_crossings(starts[pending], reach * normals[pending], vertices, triangles)
        hit = np.isfinite(fraction)
        pending, fraction, columns = pending[hit], fraction[hit], columns[hit]
        neighbour = (columns[:, :, None] == own[pending][:, None, :]).any(axis=(1, 2))
        distance = travelled[pending] + fraction * reach
        gap = min(gap, float(distance[~neighbour].min(initial=np.inf)))
        pending, distance = pending[neighbour], distance[neighbour]
        starts[pending] = centres[pending] + (distance + _START * size)[:, None] * normals[pending]
        travelled[pending] = distance + _START * size
        if not len(pending):
            break
    return gap, thickness


def resolving_resolution(vertices, triangles, cells_across=2.0):
    """Cells along the cage's longest side that put ``cells_across`` cells across its
    narrowest gap and its thinnest part (:func:`narrowest_gap_and_thinnest_part`): int.

    Examples
    --------
    >>> from gencoords.harmonic.cage_features import resolving_resolution
    >>> from gencoords.cages.shapes import icosphere
    >>> resolving_resolution(*icosphere(1))  # a ball: 2 cells across its diameter
    3
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles)
    smallest = min(gap, thickness)
    longest = float(np.ptp(vertices, axis=0).max())
    return int(np.ceil(cells_across * longest / smallest)) if np.isfinite(smallest) else 2
