"""Convex cages around point sets: the intersection of supporting half-spaces.

A cage made for a mesh must be closed, convex and contain every vertex. Intersecting the
half-spaces ``n_i . x <= h_i + margin`` over well-spread unit directions ``n_i``, with
``h_i`` the points' largest extent along ``n_i``, gives such a polytope by construction:
convex (an intersection of half-spaces) and enclosing (every point satisfies every
inequality). Its vertices come from the polar dual: the half-space ``i`` maps to the point
``n_i / (h_i + margin - n_i . c)`` around an interior point ``c``, the dual's convex hull
facets are the polytope's vertices (where three planes meet), and half-spaces whose dual
point is inside that hull are redundant. Any convex-hull routine serves for the dual
(the Blender add-on uses bmesh's); the arithmetic is here. A cage of either shape needs
a mesh with a size: :func:`mesh_extent` refuses one without, before anything is made;
a tight one an offset it can make (:func:`check_offset`) and, to keep the mesh's parts
apart, one below the gaps between them (:func:`offset_for_gap`).
"""

import numpy as np

from ..base.errors import CageError

__all__ = ["mesh_extent", "check_offset", "offset_for_gap", "sphere_directions", "supporting_offsets",
           "dual_points", "facet_vertices"]

# A mesh's diagonal must span this many of the smallest distances its positions resolve:
# a cage's vertices (a few per side) then stay apart where they are stored.
EXTENT_STEPS = 64
# The largest offset, of the mesh's size, Tight offsets by: displaced farther, a voxel
# remesh's surface folds (its normals' noise grows with the distance) into loose pieces
# (a 12-vertex icosphere: 0.75 still wraps, 1.25 breaks apart), and so far out a convex
# cage hugs as well.
LARGEST_OFFSET = 0.5
# Keeping gaps: an offset above this share of the narrowest gap between the mesh's parts
# leaves the cage's two sheets in it too close (or joins them); it is lowered to
# GAP_SHARE of the gap, the sheets then two thirds of it apart, room for the decimation's
# chords and the push-outs (a hand, fingers 1/60 of its size apart: 1/6 separates them
# at 100 vertices, 1/4 crosses). A smaller offset stays: on Suzanne (gap 0.049) 0.01
# makes a cage at 100 vertices, 0.0082 crosses (crossings come and go with settings).
CLOSING_SHARE, GAP_SHARE = 1.0 / 3.0, 1.0 / 6.0


def mesh_extent(points, resolution=0.0):
    """The bounding-box diagonal of the points a cage is to enclose, refusing points with
    none to speak of: all at one point, or within ``EXTENT_STEPS`` times ``resolution``
    of one another (the cage's vertices could not be told apart where they are stored).
    Points on a line or in a plane have an extent: a cage around them is a prism or slab.

    Parameters
    ----------
    points : (k, 3) float
    resolution : float
        Absolute: the smallest distance the cage's stored positions resolve there (a
        float32 step at the mesh's coordinates); 0 refuses only coinciding points.

    Returns
    -------
    diagonal : float

    Raises
    ------
    CageError
        ``problem`` "no_extent"; the message says how far apart the points are.

    Examples
    --------
    >>> from gencoords.cages.enclosing import mesh_extent
    >>> mesh_extent([[0.0, 0.0, 0.0], [3.0, 4.0, 0.0]])  # on a line: a prism encloses them
    5.0
    >>> try:
    ...     mesh_extent([[1e6, 0.0, 0.0]] * 4 + [[1e6, 0.01, 0.0]], resolution=0.0625)
    ... except ValueError as error:
    ...     print(error)
    every vertex of the mesh lies within 0.01 of one another, too close to tell apart where they are (positions there are stored 0.0625 apart): a cage needs a mesh with a size
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    diagonal = float(np.linalg.norm(np.ptp(points, axis=0))) if len(points) else 0.0
    if diagonal > EXTENT_STEPS * resolution and diagonal > 0.0 and np.isfinite(diagonal):
        return diagonal
    if diagonal == 0.0:
        where = "sits at one point"
    else:
        where = (f"lies within {diagonal:.3g} of one another, too close to tell apart where they "
                 f"are (positions there are stored {resolution:.3g} apart)")
    raise CageError("no_extent", f"every vertex of the mesh {where}: a cage needs a mesh with a size")


def check_offset(offset):
    """Refuse an offset Tight cannot make a cage at, before anything is made.

    Parameters
    ----------
    offset : float
        The gap between the mesh and the cage, a share of the mesh's bounding-box
        diagonal.

    Raises
    ------
    CageError
        ``problem`` "offset": above ``LARGEST_OFFSET``; the message says what helps.

    Examples
    --------
    >>> from gencoords.cages.enclosing import check_offset
    >>> check_offset(0.01)
    >>> try:
    ...     check_offset(1.25)
    ... except ValueError as error:
    ...     print(error)
    an Offset of 1.25 of the mesh's size is more than Tight offsets by (0.5): displaced that far, the voxel remesh's surface folds into loose pieces. Lower Offset to 0.5 or less, or use Convex with Margin 1.25 (that far out a convex cage hugs as well)
    """
    if not offset <= LARGEST_OFFSET:
        raise CageError("offset", f"an Offset of {offset:.3g} of the mesh's size is more than Tight "
                                  f"offsets by ({LARGEST_OFFSET:g}): displaced that far, the voxel "
                                  "remesh's surface folds into loose pieces. Lower Offset to "
                                  f"{LARGEST_OFFSET:g} or less, or use Convex with Margin {offset:.3g} "
                                  "(that far out a convex cage hugs as well)")


def offset_for_gap(offset, gap):
    """The offset a tight cage keeps the mesh's parts apart with: ``offset``, or where it
    is above ``CLOSING_SHARE`` of the narrowest gap between them, ``GAP_SHARE`` of it.

    Parameters
    ----------
    offset : float
        The offset asked for, a share of the mesh's size.
    gap : float
        The narrowest gap between the mesh's parts, a share of its size
        (:func:`gencoords.cages.surface.narrowest_gap`; ``inf`` for none).

    Returns
    -------
    offset : float

    Examples
    --------
    >>> from gencoords.cages.enclosing import offset_for_gap
    >>> round(offset_for_gap(0.01, 1.0 / 60.0), 5), offset_for_gap(0.01, 0.049), offset_for_gap(0.01, float("inf"))
    (0.00278, 0.01, 0.01)
    """
    return float(offset if offset <= CLOSING_SHARE * gap else GAP_SHARE * gap)


def sphere_directions(count):
    """Nearly uniform unit directions on the sphere (a Fibonacci lattice).

    Parameters
    ----------
    count : int
        At least 4.

    Returns
    -------
    directions : (count, 3) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.enclosing import sphere_directions
    >>> directions = sphere_directions(100)
    >>> directions.shape, bool(np.allclose(np.linalg.norm(directions, axis=1), 1.0))
    ((100, 3), True)
    """
    if count < 4:
        raise ValueError(f"at least 4 directions enclose a volume, got {count}")
    index = np.arange(count) + 0.5
    height = 1.0 - 2.0 * index / count
    radius = np.sqrt(1.0 - height ** 2)
    angle = np.pi * (1.0 + 5.0 ** 0.5) * index
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle), height])


def supporting_offsets(points, directions, margin=0.0, chunk=1 << 16):
    """Largest extent of the points along each direction, plus ``margin``.

    Parameters
    ----------
    points : (k, N) float
    directions : (d, N) float
        Unit directions.
    margin : float
        Added to every offset (absolute, in the points' units).
    chunk : int
        Points per block (bounded memory for millions of points).

    Returns
    -------
    offsets : (d,) float64
        ``max_p directions @ p + margin``: the half-space ``n . x <= offset`` holds them all.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.enclosing import supporting_offsets
    >>> points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    >>> supporting_offsets(points, np.eye(3), margin=0.5).tolist()
    [1.5, 2.5, 3.5]
    """
    points = np.asarray(points, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    offsets = np.full(len(directions), -np.inf)
    for start in range(0, len(points), chunk):
        np.maximum(offsets, (points[start:start + chunk] @ directions.T).max(axis=0), out=offsets)
    return offsets + margin


def dual_points(directions, offsets, centre):
    """Polar dual of the half-spaces ``directions . x <= offsets`` about ``centre``.

    Parameters
    ----------
    directions : (d, N) float
    offsets : (d,) float
    centre : (N,) float
        A point strictly inside every half-space.

    Returns
    -------
    points : (d, N) float64
        ``n_i / (offset_i - n_i . centre)``. Their convex hull's facets are the polytope's
        vertices (:func:`facet_vertices`).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.enclosing import dual_points
    >>> directions = np.concatenate([np.eye(3), -np.eye(3)])  # the cube |x| <= 2
    >>> dual_points(directions, np.full(6, 2.0), np.zeros(3))[:2].tolist()
    [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0]]
    """
    directions = np.asarray(directions, dtype=np.float64)
    distance = np.asarray(offsets, dtype=np.float64) - directions @ np.asarray(centre, dtype=np.float64)
    if not (distance > 0).all():
        raise ValueError("the centre must lie strictly inside every half-space")
    return directions / distance[:, None]


def facet_vertices(directions, offsets, dual_facets):
    """The polytope's vertex for each facet of the dual hull: where its planes meet.

    Parameters
    ----------
    directions : (d, N) float
    offsets : (d,) float
    dual_facets : (f, N) int
        Facets of the convex hull of :func:`dual_points`, by half-space index.

    Returns
    -------
    vertices : (f, N) float64
        Solutions of ``directions[facet] @ x = offsets[facet]`` (coinciding for facets of
        one dual face: merge them by distance).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.cages.enclosing import facet_vertices
    >>> directions = np.concatenate([np.eye(3), -np.eye(3)])  # the cube |x| <= 2
    >>> facet_vertices(directions, np.full(6, 2.0), [[0, 1, 2], [3, 4, 5]]).tolist()
    [[2.0, 2.0, 2.0], [-2.0, -2.0, -2.0]]
    """
    directions = np.asarray(directions, dtype=np.float64)
    facets = np.asarray(dual_facets, dtype=np.int64)
    # Right-hand sides as (f, N, 1): numpy 2 reads a stack of vectors (f, N) as one matrix.
    rhs = np.asarray(offsets, dtype=np.float64)[facets][..., None]
    return np.linalg.solve(directions[facets], rhs)[..., 0]
