"""Cage validation: each check names what is wrong and where (face or vertex index)."""

import numpy as np

from ..base import tolerances
from .general import prepare_cage
from ..base.errors import CageError
from ..base.inputs import checked

__all__ = ["validate_cage", "convexity_violation", "non_convex_error", "DEFAULT_TOLERANCE"]

DEFAULT_TOLERANCE = tolerances.DEFAULT
_CHUNK_ENTRIES = 1 << 22  # bounded memory for the all-vertices x all-facets tests


def _first(mask):
    return int(np.flatnonzero(mask)[0])


def _check_arrays(vertices, faces):
    # Shapes, dtypes, finiteness and index range: gencoords.base.inputs (validate_cage is @checked).
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    dim = vertices.shape[1]
    if len(vertices) < dim + 1:
        raise CageError("too_few_vertices", f"a {dim}D cage needs at least {dim + 1} vertices, "
                                            f"got {len(vertices)}")
    ordered = np.sort(faces, axis=1)
    repeated = (ordered[:, 1:] == ordered[:, :-1]).any(axis=1)
    if repeated.any():
        raise CageError("bad_faces", f"face {_first(repeated)} uses the same vertex twice",
                        faces=[_first(repeated)])
    unused = np.setdiff1d(np.arange(len(vertices)), faces)
    if len(unused):
        raise CageError("loose_vertices", f"cage vertex {int(unused[0])} belongs to no face "
                                          f"({len(unused)} such vertices); remove loose vertices",
                        vertices=unused[:10])
    return vertices, faces.astype(np.int64)


def _check_duplicates(vertices, tolerance):
    # Points within the tolerance have projections on a unit direction within it too:
    # sorted along a generic direction, each vertex needs comparing only with the few
    # that follow it inside that window. Exact, and near linear.
    direction = np.linspace(1.0, 1.7, vertices.shape[1])
    key = vertices @ (direction / np.linalg.norm(direction))
    order = np.argsort(key, kind="stable")
    ordered, keys = vertices[order], key[order]
    reach = np.searchsorted(keys, keys + tolerance, side="right") - np.arange(len(keys))
    for shift in range(1, int(reach.max(initial=1))):
        first = np.flatnonzero(reach > shift)
        close = np.linalg.norm(ordered[first + shift] - ordered[first], axis=1) <= tolerance
        if close.any():
            i = int(first[_first(close)])
            a, b = sorted((int(order[i]), int(order[i + shift])))
            raise CageError("duplicate_vertices", f"cage vertices {a} and {b} coincide; merge them "
                                                  "(Merge by Distance)", vertices=[a, b])


def _check_volume(vertices, size, tolerance):
    # All vertices in one hyperplane (an object scaled to zero on an axis) enclose nothing;
    # said before the coincident vertices such a cage usually also has.
    centred = vertices - vertices.mean(axis=0)
    thinnest = np.linalg.svd(centred, full_matrices=False)[2][-1]  # least-variance direction
    heights = centred @ thinnest
    thickness = float(heights.max() - heights.min())
    if thickness <= tolerance * size:
        dimension = vertices.shape[1]
        shape = {2: "line", 3: "plane"}.get(dimension, "hyperplane")
        content = {2: "area", 3: "volume"}.get(dimension, "volume")
        raise CageError("flat", f"the cage is flat: all its vertices lie in one {shape} "
                                f"(thickness {thickness / size:.3g} of its size), so it encloses no "
                                f"{content}; give it extent in every direction")


def _check_manifold(cage):
    topology = cage.topology
    uses = topology.ridge_use_count
    name = "vertex" if cage.dimension == 2 else "edge" if cage.dimension == 3 else "ridge"
    faces_of = lambda ridge: np.flatnonzero((topology.facet_ridges == ridge).any(axis=1))  # noqa: E731
    if (uses > 2).any():
        ridge = _first(uses > 2)
        raise CageError("non_manifold", f"the cage is non-manifold: {name} "
                                        f"{tuple(topology.ridges[ridge].tolist())} is shared by "
                                        f"{uses[ridge]} faces", faces=faces_of(ridge),
                        vertices=topology.ridges[ridge])
    if (uses == 1).any():
        ridge = _first(uses == 1)
        raise CageError("open", f"the cage is open: {name} {tuple(topology.ridges[ridge].tolist())} "
                                f"belongs to only one face ({np.count_nonzero(uses == 1)} boundary "
                                f"{name}s); close the hole", faces=faces_of(ridge),
                        vertices=topology.ridges[ridge])
    flipped = topology.ridge_signs_sum != 0
    if flipped.any():
        ridge = _first(flipped)
        faces = faces_of(ridge)
        raise CageError("inconsistent_orientation", f"faces {faces[0]} and {faces[1]} have opposite "
                                                    f"orientations across {name} "
                                                    f"{tuple(topology.ridges[ridge].tolist())}; "
                                                    "recalculate normals", faces=faces,
                        vertices=topology.ridges[ridge])


def _check_facets(cage, tolerance):
    corners = cage.facet_corners()
    longest = np.linalg.norm(corners[:, :, None, :] - corners[:, None, :, :], axis=-1).max(axis=(1, 2))
    measure = np.linalg.norm(cage.facet_normals, axis=1)
    # (N-1)! volume against the longest edge to that power: a scale-free flatness
    degenerate = measure <= tolerance * np.maximum(longest, tolerance) ** (cage.dimension - 1)
    if degenerate.any():
        raise CageError("degenerate_facet", f"face {_first(degenerate)} has (nearly) zero area; "
                                            "dissolve or merge it", faces=[_first(degenerate)])
    volume = np.sum(cage.facet_offsets)  # N! * signed volume, origin-independent
    if volume < 0.0:
        raise CageError("inward", "the cage's faces point inward; flip its normals")


def convexity_violation(cage, tolerance=DEFAULT_TOLERANCE):
    """The worst vertex beyond a facet's plane, if any.

    Parameters
    ----------
    cage : PreparedCage
    tolerance : float
        Relative to the cage size; heights up to it count as coplanar (flat regions of
        triangulated quads are convex).

    Returns
    -------
    violation : (vertex, face, height) or None
        ``height`` in world units.
    """
    absolute = tolerance * cage.size
    unit_normals = cage.facet_normals / np.linalg.norm(cage.facet_normals, axis=1, keepdims=True)
    unit_offsets = cage.facet_offsets / np.linalg.norm(cage.facet_normals, axis=1)
    step = max(1, _CHUNK_ENTRIES // max(len(unit_offsets), 1))
    for start in range(0, len(cage.vertices), step):
        # Signed height of every vertex above every facet's plane (outward positive).
        height = cage.vertices[start:start + step] @ unit_normals.T - unit_offsets[None, :]
        if (height > absolute).any():
            vertex, face = np.unravel_index(np.argmax(height), height.shape)
            return int(start + vertex), int(face), float(height[vertex, face]) * cage.scale
    return None


@checked
def concave_facets(vertices, faces, tolerance=DEFAULT_TOLERANCE):
    """Triangles that meet a neighbour at an edge bent inward: where a closed, outward
    3D cage dents in (what an artist flattens or fills to make it convex).

    An edge is bent inward when the far corner of one of its triangles lies above the
    other triangle's plane by more than ``tolerance`` of the cage's size.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int
        Outward triangles of a closed manifold cage.
    tolerance : float

    Returns
    -------
    facets : (j,) int
        Sorted indices into ``faces``; empty for a convex cage.

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron()
    >>> gencoords.advanced.concave_facets(vertices, faces).tolist()
    []
    >>> dented = vertices.copy(); dented[0] *= -0.5  # a corner pushed through the middle
    >>> len(gencoords.advanced.concave_facets(dented, faces)) > 0
    True
    """
    if vertices.shape[1] != 3:
        raise ValueError(f"concave_facets takes a 3D cage, got {vertices.shape[1]}D vertices")
    vertices, faces = np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)
    size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    corners = vertices[faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), tolerances.TINY)
    # Half-edge (a, b) of facet i, the corner opposite it; its twin (b, a) is in facet j.
    starts, ends, opposite = faces.ravel(), np.roll(faces, -1, axis=1).ravel(), np.roll(faces, 1, axis=1).ravel()
    owner = np.repeat(np.arange(len(faces)), 3)
    count = len(vertices)
    keys = starts * count + ends
    order = np.argsort(keys)
    found = np.clip(np.searchsorted(keys[order], ends * count + starts), 0, len(keys) - 1)
    twin = order[found]
    paired = keys[twin] == ends * count + starts
    i, j = owner[paired], owner[twin[paired]]
    far = vertices[opposite[twin[paired]]]
    height = np.einsum("kd,kd->k", far - vertices[starts[paired]], normals[i])
    bent = height > tolerance * size
    return np.unique(np.concatenate([i[bent], j[bent]]))


def non_convex_error(violation):
    """The :class:`CageError` for a :func:`convexity_violation` (vertex, face, height)."""
    vertex, face, height = violation
    return CageError("non_convex", f"the cage is not convex: vertex {vertex} lies {height:.3g} "
                                   f"outside the plane of face {face}", faces=[face], vertices=[vertex])


def _check_convex(cage, tolerance):
    violation = convexity_violation(cage, tolerance)
    if violation is not None:
        raise non_convex_error(violation)


@checked
def validate_cage(vertices, faces, convex=True, tolerance=DEFAULT_TOLERANCE):
    """Check that a cage can be used, raising :class:`CageError` naming the problem.

    Parameters
    ----------
    vertices : (n, N) float
    faces : (m, N) int
        Simplicial facets, outward oriented (2D: counter-clockwise polygon edges; 3D:
        triangles counter-clockwise seen from outside).
    convex : bool
        Also require convexity (every kind but mean value).
    tolerance : float
        Relative to the cage's bounding-box diagonal, in (0, 1e-3] (``gencoords.base.tolerances``):
        coincident vertices, flat facets and convexity are judged to this precision.

    Returns
    -------
    cage : PreparedCage
        The prepared cage, for reuse.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    >>> edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])  # counter-clockwise
    >>> cage = gencoords.advanced.validate_cage(square, edges)
    >>> gencoords.advanced.validate_cage(square, edges[:, ::-1])
    Traceback (most recent call last):
    ...
    gencoords.base.errors.CageError: ...
    """
    vertices, faces = _check_arrays(vertices, faces)
    cage = prepare_cage(vertices, faces)
    absolute = tolerance * cage.size
    _check_volume(cage.vertices, cage.size, tolerance)
    _check_duplicates(cage.vertices, absolute)
    _check_manifold(cage)
    _check_facets(cage, tolerance)
    if convex:
        _check_convex(cage, tolerance)
    return cage
