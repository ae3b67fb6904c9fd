"""Compact coordinates: exact for affine and smooth cage motions, k x s numbers for k points.

A point with coordinates ``w`` (a row of ``W``, shape (k, n)) moves by ``w @ D`` when the
cage's vertices move by ``D`` (n, N). Keeping all of ``W`` costs k x n numbers, and k x n
multiply-adds each time the cage moves. The compact form keeps an orthonormal basis
``basis`` (n, s) of cage motions, the affine motions first and then the cage's smoothest
vibration modes (lowest eigenvectors of its edge-graph Laplacian), and per point the
projections ``slots = W @ basis`` (k, s). Then

    W @ D  ~  slots @ (basis.T @ D)

exactly when ``D`` lies in the span of the basis: every affine motion (coordinates have
linear precision, so an affine cage motion moves every point by the same affine map),
and the broad bends and twists a coarse cage is made for. A sharp drag of one cage
vertex deviates: :func:`gencoords.storage.deviations.deviation` measures it for any motion. The same form with
``basis = I`` is the exact one.

How far the compact form is from the exact one depends on the cage and on where the
points lie: :func:`gencoords.storage.deviations.residual_deviations` measures the standard smooth motion and the worst
single-vertex drag exactly from the coordinates' residual ``W - slots @ basis.T``, and
:func:`smallest_size` finds the fewest basis vectors that keep both under a target.

Green coordinates (``[phi, psi]``, n + m per point) compress the same way over the
n + m rows of :func:`gencoords.construction.green_deform.green_displacements`, with
:func:`green_motion_basis`; the functions below take ``faces`` for them.
"""

import numpy as np

from ..base import tolerances
from . import exact
from .deviations import residual_deviations
from .deviations import smooth_test_motion  # noqa: F401  (the add-on's Bake measures with compact's motion)

__all__ = ["motion_basis", "green_motion_basis", "smallest_size"]


def _edges(faces):
    """Unique undirected edges of simplicial facets, (e, 2) int (every vertex pair)."""
    faces = np.asarray(faces, dtype=np.int64)
    first, second = np.triu_indices(faces.shape[1], k=1)
    pairs = np.sort(np.concatenate([faces[:, [i, j]] for i, j in zip(first, second)]), axis=1)
    return np.unique(pairs, axis=0)


def motion_basis(vertices, faces, size):
    """Orthonormal cage motions: the affine ones, then the smoothest others.

    Parameters
    ----------
    vertices : (n, N) float
        Cage vertices.
    faces : (m, N) int
        Cage facets (only their edges are used).
    size : int
        Number of basis vectors s, at least N + 1 (the affine motions) and at most n.

    Returns
    -------
    basis : (n, s) float64
        Orthonormal columns. The first N + 1 span the affine functions of the vertex
        positions (constant and linear); the others are eigenvectors of the cage's
        edge-graph Laplacian restricted to the complement, by increasing frequency.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.compact import motion_basis
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> basis = motion_basis(vertices, faces, 10)
    >>> basis.shape, bool(np.allclose(basis.T @ basis, np.eye(10)))
    ((42, 10), True)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    count, dim = vertices.shape
    if not dim + 1 <= size <= count:
        raise ValueError(f"size must be between {dim + 1} (the affine motions) and "
                         f"{count} (the cage's vertex count), got {size}")
    extent = max(np.ptp(vertices, axis=0).max(), tolerances.TINY)
    centred = (vertices - vertices.mean(axis=0)) / extent
    affine, _ = np.linalg.qr(np.column_stack([np.ones(count), centred]))
    edges = _edges(faces)
    laplacian = np.zeros((count, count))
    np.add.at(laplacian, (edges[:, 0], edges[:, 1]), -1.0)
    np.add.at(laplacian, (edges[:, 1], edges[:, 0]), -1.0)
    laplacian[np.diag_indices(count)] = -laplacian.sum(axis=1)
    # Restricted to the complement of the affine motions, the Laplacian's eigenvectors of
    # nonzero eigenvalue are orthogonal to them; the affine ones fall into its null space.
    complement = np.eye(count) - affine @ affine.T
    values, vectors = np.linalg.eigh(complement @ laplacian @ complement)
    outside_affine = np.linalg.norm(affine.T @ vectors, axis=0) < 0.5
    smooth = vectors[:, outside_affine][:, np.argsort(values[outside_affine])]
    return np.column_stack([affine, smooth[:, :size - dim - 1]])


def _dual_edges(faces):
    """Pairs of triangles sharing an edge, (e, 2) int."""
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]]), axis=1)
    owners = np.tile(np.arange(len(faces)), 3)
    order = np.lexsort(edges.T[::-1])
    edges, owners = edges[order], owners[order]
    same = (edges[1:] == edges[:-1]).all(axis=1)
    return np.column_stack([owners[:-1][same], owners[1:][same]])


def green_motion_basis(vertices, faces, size):
    """Orthonormal motions of Green coordinates' n + m rows (vertices, then faces).

    Block-diagonal: the vertex rows take :func:`motion_basis` (affine, then smooth), the
    face rows the same construction on the faces' unit normals over the triangles'
    adjacency (constant and linear in the normal, then smooth). A similarity moves the
    vertices affinely and turns and scales the normals linearly, so every similarity of
    the cage lies in the first 8 columns: compact Green storage follows it exactly.
    Then the two parts' smooth modes alternate in proportion to their sizes.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int
        Outward triangles.
    size : int
        Number of columns s, between 8 and n + m.

    Returns
    -------
    basis : (n + m, s) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.compact import green_motion_basis
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> basis = green_motion_basis(vertices, faces, 24)
    >>> basis.shape, bool(np.allclose(basis.T @ basis, np.eye(24)))
    ((122, 24), True)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    count, face_count = len(vertices), len(faces)
    if not 8 <= size <= count + face_count:
        raise ValueError(f"size must be between 8 (the similarities) and {count + face_count} (the "
                         f"cage's vertex and face count), got {size}")
    normals = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), tolerances.TINY)
    parts = (motion_basis(vertices, faces, count), motion_basis(normals, _dual_edges(faces), face_count))
    # Column order: both affine blocks, then whichever part has used less of itself.
    order, used = [(0, c) for c in range(4)] + [(1, c) for c in range(4)], [4, 4]
    while len(order) < size:
        part = 0 if used[0] / count <= used[1] / face_count else 1
        order.append((part, used[part]))
        used[part] += 1
    basis = np.zeros((count + face_count, size))
    for column, (part, index) in enumerate(order):
        rows = slice(0, count) if part == 0 else slice(count, None)
        basis[rows, column] = parts[part][:, index]
    return basis


def smallest_size(coordinates, basis, rest, target, sizes, faces=None):
    """The fewest leading basis vectors that keep both standard deviations under ``target``.

    Parameters
    ----------
    coordinates : (k, n) float
        Exact coordinates of sample points.
    basis : (n, m) float
        Orthonormal columns in order of use (:func:`motion_basis` with size m).
    rest : (n, 3) float
        The cage at rest.
    target : float
        Largest deviation allowed, of the cage's diagonal.
    sizes : increasing sequence of int
        Candidate sizes, each at most m.
    faces : (f, 3) int, optional
        Green coordinates (``coordinates`` then ``[phi, psi]``): as ``deviations.residual_deviations``.

    Returns
    -------
    size : int or None
        The first of ``sizes`` whose smooth and worst drag deviations (on the sample, in
        float64) are both below ``target``; None if none is.
    smooth, drag : float
        Those deviations at ``size`` (at the last size when None).

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.storage.compact import motion_basis, smallest_size
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> w = gencoords.coordinates([[0.1, 0.2, 0.3], [0.0, -0.4, 0.1]], vertices, faces, workers=1)
    >>> basis = motion_basis(vertices, faces, 42)
    >>> size, smooth, drag = smallest_size(w, basis, vertices, 1e-3, [4, 10, 20, 42])
    >>> size in (4, 10, 20, 42), smooth < 1e-3 and drag < 1e-3
    (True, True)
    """
    coordinates = np.asarray(coordinates, dtype=np.float64)
    basis = np.asarray(basis, dtype=np.float64)
    projections = coordinates @ basis  # (k, m)
    residual, used = coordinates.copy(), 0
    smooth, drag = np.inf, np.inf
    for size in sizes:
        # Truncating to more columns removes their part from the residual: the whole
        # sweep costs one k x m x n product, whatever the number of candidates.
        residual -= projections[:, used:size] @ basis[:, used:size].T
        used = size
        smooth, drag_per_vertex = residual_deviations(residual, rest, faces=faces)
        drag = float(drag_per_vertex.max(initial=0.0))
        if smooth < target and drag < target:
            return size, smooth, drag
    return None, smooth, drag


def encode(choice, coordinates, rest=None):
    """Compact slots of ``coordinates`` ((j, rows) float64): their projections on
    ``choice.basis`` ((rows, s) float64), (j, s) float32, and no indices (None)."""
    return (coordinates @ choice.basis).astype(np.float32), None


def reproduce(choice, slots, indices=None, rows=None):
    """The coordinates the deformer reproduces from compact ``slots`` ((j, s) float32 as
    written) and the float32 basis it stores: (j, rows) float64."""
    return slots @ choice.basis.astype(np.float32).astype(np.float64).T


def plan_bytes(plan):
    """Bytes of a compact plan's attributes: its slots, and the basis in as many again."""
    return 2 * exact.attribute_bytes(len(plan.slots), plan.slot_count)
