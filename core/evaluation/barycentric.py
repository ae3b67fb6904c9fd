"""The public entry points: coordinates, weights, ridge scalars and locations of points,
and Green coordinates.

Each builds a :class:`gencoords.Cage` for the call (validated, prepared, and stopped again
with its worker processes); callers with several batches of points keep one instead.
"""

import numpy as np

from .cage import Cage, needs_convex
from .quad_coordinates import quad_kind_coordinates
from ..base.inputs import checked
from ..base.parameters import OUTSIDE_MODES
from ..surfaces.numerical import DEFAULT_LEVELS, geodesic_pieces, simplex_rule, surface_ridge_scalars
from ..base.topology import cage_topology
from ..surfaces.named import MEAN_VALUE, MEAN_VALUE_QUADS
from ..construction.general import construct_weights, point_frame
from ..construction.units import to_world
from ..construction.validation import DEFAULT_TOLERANCE, validate_cage

__all__ = ["coordinates", "green_coordinates", "weights", "ridge_scalars", "ridge_scalars_from_surface", "point_locations",
           "needs_convex", "OUTSIDE_MODES", "ridges", "weights_from_ridge_scalars"]
# Entries of the (k, r, nodes, N) arrays of one chunk of ridge_scalars_from_surface.
_SURFACE_CHUNK_ENTRIES = 1 << 22


@checked
def coordinates(points, vertices, faces, kind=MEAN_VALUE, outside="raise",
                tolerance=DEFAULT_TOLERANCE, progress=None, dtype=np.float64, locations=None,
                workers=None, gamma=None, resolution=None):
    """Generalized barycentric coordinates of points with respect to a cage.

    Parameters
    ----------
    points : (k, N) float
        Query points (a single (N,) point is accepted).
    vertices : (n, N) float
        Cage vertices.
    faces : (m, N) int
        Simplicial facets, outward oriented (2D: counter-clockwise polygon edges;
        3D: triangles counter-clockwise seen from outside); for ``"mean_value_quads"``
        triangles and quads as :func:`gencoords.mean_value_quad_coordinates`' polygons.
    kind : str
        ``"wachspress"``, ``"mean_value"``, ``"discrete_harmonic"``, ``"voronoi"`` or
        ``"power"`` (with ``gamma``), ``"harmonic"`` (with ``resolution``) or
        ``"mean_value_quads"`` (:data:`gencoords.MEAN_VALUE_QUADS`). Mean value
        coordinates accept any closed, consistently oriented 2D/3D cage; harmonic
        coordinates any closed 3D triangle cage (solved on a grid:
        :func:`gencoords.harmonic_field`; non-negative, local); quad mean value any closed
        3D cage of triangles and quads, each quad a bilinear patch (bitwise
        :func:`gencoords.mean_value_quad_coordinates`); the others need a convex one.
    outside : str
        What to do with points outside the cage: ``"raise"`` (OutsideCageError naming
        them), ``"extrapolate"`` (the formula, smooth for mean value; on a facet's
        hyperplane, where the other kinds' weights have a pole, its limit: the affine
        coordinates of the point in that hyperplane) or ``"project"`` (the coordinates
        of the nearest boundary point).
    tolerance : float
        Relative to the cage's bounding-box diagonal. Points this close to the boundary
        count as on it and get the exact limit: linear coordinates of the facet, edge or
        vertex they touch.
    progress : callable, optional
        ``progress(fraction)`` is called from the calling thread as work completes
        (fraction in (0, 1]), for progress bars on long computations.
    dtype : numpy dtype
        Of the result. Computation is always float64; ``np.float32`` halves the
        result's memory (a large bind) without a float64 copy of it ever existing.
    locations : (k,) int8 ndarray, optional
        Filled with each point's location, as :func:`point_locations` gives it (1 inside,
        0 on the boundary, -1 outside), at no extra cost.
    workers : int or None
        Processes to compute in: ``1`` this process only; ``None`` (default) all the
        cores this process may use when the call is long enough to repay starting them
        (about half a second of work per worker), else this process. Workers are fresh
        Python interpreters importing only this package and numpy (also inside
        Blender); results come back through shared memory and are bitwise the same
        whatever the number of workers. To compute several batches against one cage,
        keep a :class:`gencoords.Cage`: it validates once and keeps its workers.

    gamma : float, optional
        The power family's exponent (kind ``"power"`` only; default -0.5): the surface's
        face dual to v_k lies at distance ``l_k^gamma`` from x. -1 gives Wachspress, 1
        Voronoi, 0 in 2D mean value (docs/POWER.md: where they stay positive).
    resolution : int, optional
        Harmonic coordinates' grid (kind ``"harmonic"`` only; default 64): cells along
        the longest side of the cage's box, as :func:`gencoords.harmonic_field`. Their
        points are placed as the grid allows (exactly in most cells, to a fraction of a
        cell beside the cage); ``outside`` is ``"raise"`` or ``"project"``.

    Returns
    -------
    coordinates : (k, n) dtype
        Rows sum to 1 and reproduce the points: ``coordinates @ vertices == points``
        (for inside and boundary points).

    Raises
    ------
    CageError
        The cage is unusable (open, non-manifold, inverted, non-convex for the kind...).
    OutsideCageError
        ``outside="raise"`` and some points are outside.
    WorkerError
        A worker process could not start, failed or was killed (the others are stopped
        and the shared memory removed).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> b = gencoords.coordinates([[0.5, 0.5], [0.25, 0.5]], square, edges, kind="wachspress")
    >>> b.shape
    (2, 4)
    >>> print(b[0])
    [0.25 0.25 0.25 0.25]
    >>> bool(np.allclose(b @ square, [[0.5, 0.5], [0.25, 0.5]]))
    True
    >>> corners = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> h = gencoords.coordinates([[0.1, 0.2, 0.3]], corners, triangles, kind="harmonic", resolution=24)
    >>> print(h.round(6))  # in a tetrahedron: its barycentric coordinates
    [[0.4 0.1 0.2 0.3]]
    >>> from gencoords.cages.shapes import block_cage
    >>> cube, quads = block_cage(np.ones((1, 1, 1), dtype=bool))   # a unit cube, six quads
    >>> q = gencoords.coordinates([[0.5, 0.5, 0.5]], cube, quads, kind=gencoords.MEAN_VALUE_QUADS)
    >>> print(np.round(q, 6))
    [[0.125 0.125 0.125 0.125 0.125 0.125 0.125 0.125]]
    """
    if kind == MEAN_VALUE_QUADS:  # faces are polygons: no Cage of simplices
        return quad_kind_coordinates(points, vertices, faces, outside, tolerance, progress, locations, workers,
                                     gamma, resolution).astype(dtype, copy=False)
    with Cage(vertices, faces, tolerance) as cage:
        return cage.coordinates(points, kind=kind, outside=outside, progress=progress, dtype=dtype,
                                locations=locations, workers=workers, gamma=gamma, resolution=resolution)


@checked
def green_coordinates(points, vertices, faces, outside="raise", tolerance=DEFAULT_TOLERANCE, progress=None,
                      dtype=np.float64, locations=None, workers=None):
    """Green coordinates (Lipman, Levin and Cohen-Or 2008) of points in a closed triangle cage.

    ``points = phi @ vertices + psi @ unit_normals`` and ``phi`` rows sum to 1, for points
    inside any closed, outward-oriented triangle cage, convex or not; points on the
    boundary (within ``tolerance``) get the limit from inside. Deform with
    :func:`gencoords.green_deform`: a similarity of the cage moves the points by the same
    similarity, and stretches keep details' shape (docs/MATH.md, "Green coordinates").

    Parameters
    ----------
    points : (k, 3) float
    vertices : (n, 3) float
    faces : (m, 3) int
        Triangles counter-clockwise seen from outside.
    outside : str
        ``"raise"`` (:class:`gencoords.OutsideCageError`) or ``"project"`` (the nearest
        boundary point's coordinates). Green coordinates do not extrapolate:
        ``"extrapolate"`` is refused.
    tolerance : float
        Relative to the cage's size, as :func:`coordinates`.
    progress, dtype, locations, workers
        As :func:`coordinates` (computed in float64; bitwise the same in any number of
        worker processes).

    Returns
    -------
    phi : (k, n) dtype
        One per cage vertex.
    psi : (k, m) dtype
        One per face, in length units (it multiplies the face's unit normal).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> phi, psi = gencoords.green_coordinates([[0.1, 0.2, -0.3]], vertices, faces)
    >>> phi.shape, psi.shape
    ((1, 42), (1, 80))
    >>> normals = np.cross(*(vertices[faces[:, 1:]] - vertices[faces[:, :1]]).transpose(1, 0, 2))
    >>> normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    >>> print((phi @ vertices + psi @ normals).round(12), phi.sum().round(12))
    [[ 0.1  0.2 -0.3]] 1.0
    """
    with Cage(vertices, faces, tolerance) as cage:
        return cage.green_coordinates(points, outside=outside, progress=progress, dtype=dtype,
                                      locations=locations, workers=workers)


@checked
def weights(points, vertices, faces, kind=MEAN_VALUE, tolerance=DEFAULT_TOLERANCE, workers=None,
            gamma=None, resolution=None):
    """Homogeneous weights of a named kind: ``sum_i w_i (v_i - x) = 0``.

    Parameters (``workers`` included) and cage requirements as :func:`coordinates`.
    Inside the cage these are the unnormalised weights of the construction (coordinates
    are ``w / w.sum()``); at boundary points, where the formula has a pole, the limit coordinates (themselves
    homogeneous weights) are returned; outside points get the formula's value, or on a
    facet's hyperplane (a pole, for a convex-only kind) the limit coordinates there.
    Harmonic coordinates (``kind="harmonic"``, ``resolution`` as :func:`coordinates`) have
    no formula: their weights are their coordinates, inside and on the cage only; those
    of ``kind="mean_value_quads"`` their coordinates, extrapolated outside.

    Returns
    -------
    weights : (k, n) float

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> w = gencoords.weights([[0.5, 0.5]], square, edges)
    >>> w.shape
    (1, 4)
    >>> bool(np.allclose(w @ (square - [0.5, 0.5]), 0.0))  # sum_i w_i (v_i - x) = 0
    True
    """
    if kind == MEAN_VALUE_QUADS:
        return quad_kind_coordinates(points, vertices, faces, "extrapolate", tolerance, None, None, workers,
                                     gamma, resolution)
    with Cage(vertices, faces, tolerance) as cage:
        return cage.weights(points, kind=kind, workers=workers, gamma=gamma, resolution=resolution)


@checked
def ridge_scalars(points, vertices, faces, kind, gamma=None):
    """Ridge scalars d of a named generating surface.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
    kind : str
        One of :data:`gencoords.advanced.KINDS`.
    gamma : float, optional
        For kind ``"power"`` (see :func:`coordinates`).

    Returns
    -------
    d : (k, r) float
        Columns follow :func:`gencoords.advanced.ridges` (2D: vertices, 3D: edges). A ridge through a
        point has no scalar there: NaN (or inf) in that entry; :func:`coordinates` takes
        the boundary limits instead.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> d = gencoords.advanced.ridge_scalars([[0.5, 0.5]], square, edges, "mean_value")
    >>> d.shape  # (k, r): one scalar per point and ridge
    (1, 4)
    """
    return Cage(vertices, faces).ridge_scalars(points, kind, gamma=gamma)


@checked
def ridge_scalars_from_surface(points, vertices, faces, radius, levels=DEFAULT_LEVELS):
    """Ridge scalars d of any generating surface star-shaped around the points.

    Each ridge's d is the (N-1)-volume enclosed by x and the ridge projected onto the
    surface, integrated numerically over the ridge's spherical simplex (docs/MATH.md);
    :func:`weights_from_ridge_scalars` turns it into weights.

    Parameters
    ----------
    points : (k, N) float
        Inside the cage (a ridge through a point gives NaN in its entry, as for
        :func:`ridge_scalars`).
    vertices : (n, N) float
    faces : (m, N) int
    radius : callable
        ``radius(points, directions)`` with points (k, N) and unit directions (k, s, N)
        returns the (k, s) distances from each point to its surface along each
        direction (the unit sphere: ``lambda x, u: np.ones(u.shape[:2])``).
    levels : int
        The accuracy parameter: each ridge's spherical simplex is subdivided ``levels``
        times into 2^(N-2) pieces (9 evaluations of ``radius`` per piece in 4D, 27 in 5D). With
        the default (5), the unit sphere gives mean value to about 1e-9 relative in 3D
        and 4e-7 in 4D; each level divides the error by roughly 30 to 60.

    Returns
    -------
    d : (k, r) float
        Columns follow :func:`gencoords.advanced.ridges`.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> unit_sphere = lambda points, directions: np.ones(directions.shape[:2])
    >>> d = gencoords.advanced.ridge_scalars_from_surface([[0.5, 0.5]], square, edges, unit_sphere)
    >>> exact = gencoords.advanced.ridge_scalars([[0.5, 0.5]], square, edges, "mean_value")
    >>> bool(np.allclose(d, exact, rtol=1e-6))  # the unit sphere generates mean value coordinates
    True
    """
    cage = Cage(vertices, faces)
    corners = cage.vertices[cage.topology_ridges]
    size = corners.shape[1]
    evaluations = len(geodesic_pieces(size, levels)) * len(simplex_rule(size, 3)[1]) * size
    step = max(1, _SURFACE_CHUNK_ENTRIES // (corners.shape[0] * evaluations * corners.shape[2]))
    d = np.empty((len(points), corners.shape[0]))
    for start in range(0, len(points), step):
        d[start:start + step] = surface_ridge_scalars(corners, points[start:start + step], radius, levels)
    return d


@checked
def point_locations(points, vertices, faces, tolerance=DEFAULT_TOLERANCE, workers=None):
    """Where each point is: 1 inside, 0 on the boundary (within tolerance), -1 outside.

    Parameters
    ----------
    points : (k, N) float
    vertices : (n, N) float
    faces : (m, N) int
        A closed, consistently oriented cage (convex or, in 2D and 3D, not).
    tolerance : float
        Relative to the cage's bounding-box diagonal.

    Returns
    -------
    locations : (k,) int8

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> where = gencoords.point_locations([[0.5, 0.5], [1.0, 0.5], [2.0, 0.5]], square, edges)
    >>> [int(code) for code in where] == [gencoords.INSIDE, gencoords.BOUNDARY, gencoords.OUTSIDE]
    True
    """
    with Cage(vertices, faces, tolerance) as cage:
        return cage.point_locations(points, workers=workers)


@checked
def ridges(faces):
    """Ridges of a simplicial cage, in the order ridge-scalar columns use.

    Parameters
    ----------
    faces : (m, N) int
        Facets (2D: polygon edges, 3D: triangles).

    Returns
    -------
    ridges : (r, N-1) int
        Sorted vertex indices of each ridge (2D: one vertex, 3D: an edge), rows in
        lexicographic order.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> print(gencoords.advanced.ridges(edges).ravel())  # 2D: a ridge is a vertex
    [0 1 2 3]
    """
    faces = np.asarray(faces, dtype=np.int64)
    return cage_topology(faces, int(faces.max(initial=-1)) + 1).ridges


@checked
def weights_from_ridge_scalars(points, vertices, faces, d):
    """The general construction for arbitrary ridge scalars (any generating surface).

    Parameters
    ----------
    points : (k, N) float
        Query points strictly inside the convex cage (elsewhere the formula is evaluated
        as is: poles on facet hyperplanes give inf or NaN).
    vertices : (n, N) float
    faces : (m, N) int
        Closed, outward-oriented simplicial facets of a convex cage.
    d : (k, r) float
        One scalar per (point, ridge), ridges ordered as :func:`gencoords.advanced.ridges`.

    Returns
    -------
    weights : (k, n) float
        Homogeneous weights: ``sum_i w_i (v_i - x) = 0`` for every point.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> d = gencoords.advanced.ridge_scalars([[0.5, 0.5]], square, edges, "wachspress")
    >>> w = gencoords.advanced.weights_from_ridge_scalars([[0.5, 0.5]], square, edges, d)
    >>> print(w / w.sum(axis=1, keepdims=True))
    [[0.25 0.25 0.25 0.25]]
    """
    cage = validate_cage(vertices, faces)
    # Frame weights have length degree -1 for the same d (u = r . m / det E).
    return to_world(construct_weights(cage, point_frame(cage, points), d.T).T, cage.scale, -1, "weights")
