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
vertex deviates: :func:`deviation` measures it for any motion. The same form with
``basis = I`` is the exact one.

How far the compact form is from the exact one depends on the cage and on where the
points lie: :func:`residual_deviations` measures the standard smooth motion and the worst
single-vertex drag exactly from the coordinates' residual ``W - slots @ basis.T``, and
:func:`smallest_size` finds the fewest basis vectors that keep both under a target.

Green coordinates (``[phi, psi]``, n + m per point) compress the same way over the
n + m rows of :func:`gencoords.construction.green.green_displacements`, with
:func:`green_motion_basis`; the functions below take ``faces`` for them.
"""

import numpy as np

from ..base import tolerances
from ..construction.green import green_displacements

__all__ = ["motion_basis", "green_motion_basis", "smooth_test_motion", "vertex_drag_motion", "deviation",
           "residual_deviations", "smallest_size", "DRAG_FRACTION"]

DRAG_FRACTION = 0.1  # the dragged cage vertex moves this fraction of the cage's diagonal


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


def smooth_test_motion(vertices):
    """The standard smooth cage motion compact coordinates are measured with.

    A twist of up to 60 degrees about the cage's longest axis that grows with the height
    along it, plus a sideways bend of 15 % of that height: what an artist does with a
    cage, and not affine, so the basis's smooth modes (not only its affine ones) matter.

    Parameters
    ----------
    vertices : (n, 3) float

    Returns
    -------
    moved : (n, 3) float64

    Examples
    --------
    >>> from gencoords.storage.compact import smooth_test_motion
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron((1.0, 1.0, 2.0))
    >>> smooth_test_motion(vertices).shape
    (6, 3)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    axis = int(np.argmax(high - low))
    across = [(axis + 1) % 3, (axis + 2) % 3]
    centre = 0.5 * (low + high)
    height = (vertices[:, axis] - low[axis]) / max(high[axis] - low[axis], tolerances.TINY)
    angle = np.radians(60.0) * height
    u, v = (vertices[:, across] - centre[across]).T
    moved = vertices.copy()
    moved[:, across[0]] = centre[across[0]] + np.cos(angle) * u - np.sin(angle) * v
    moved[:, across[1]] = centre[across[1]] + np.sin(angle) * u + np.cos(angle) * v
    moved[:, across[0]] += 0.15 * (high[axis] - low[axis]) * height ** 2
    return moved


def vertex_drag_motion(vertices, index=0, fraction=DRAG_FRACTION):
    """One cage vertex dragged outward by ``fraction`` of the cage's diagonal.

    Parameters
    ----------
    vertices : (n, N) float
    index : int
    fraction : float

    Returns
    -------
    moved : (n, N) float64

    Examples
    --------
    >>> from gencoords.storage.compact import vertex_drag_motion
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> moved = vertex_drag_motion(vertices, index=0, fraction=0.5)
    >>> moved[0].round(6).tolist(), bool((moved[1:] == vertices[1:]).all())
    ([2.732051, 0.0, 0.0], True)
    """
    moved = np.array(vertices, dtype=np.float64)
    direction = moved[index] - moved.mean(axis=0)
    diagonal = np.linalg.norm(np.ptp(moved, axis=0))
    length = max(np.linalg.norm(direction), tolerances.TINY)
    moved[index] += fraction * diagonal * direction / length
    return moved


def deviation(coordinates, slots, basis, rest, moved):
    """Largest distance between the exact and the compact deformation, per cage diagonal.

    Parameters
    ----------
    coordinates : (k, n) float
        Exact coordinates of k sample points.
    slots : (k, s) float
        Their compact slots, ``coordinates @ basis`` (possibly rounded to float32).
    basis : (n, s) float
    rest, moved : (n, N) float
        The cage before and after the motion.

    Returns
    -------
    deviation : float
        ``max_i |w_i D - slots_i basis^T D| / |diagonal|``, with ``D = moved - rest``.

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.storage.compact import deviation, motion_basis, vertex_drag_motion
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> w = gencoords.coordinates([[0.1, 0.2, 0.3]], vertices, faces, workers=1)
    >>> basis = motion_basis(vertices, faces, 42)  # every motion: exact
    >>> float(deviation(w, w @ basis, basis, vertices, vertex_drag_motion(vertices))) < 1e-12
    True
    """
    rest = np.asarray(rest, dtype=np.float64)
    displacement = np.asarray(moved, dtype=np.float64) - rest
    exact = np.asarray(coordinates, dtype=np.float64) @ displacement
    compact = np.asarray(slots, dtype=np.float64) @ (np.asarray(basis).T @ displacement)
    if len(exact) == 0:
        return 0.0
    diagonal = np.linalg.norm(np.ptp(rest, axis=0))
    return float(np.linalg.norm(exact - compact, axis=1).max() / diagonal)


def residual_deviations(residual, rest, fraction=DRAG_FRACTION, faces=None):
    """Deviations of a reproduction of coordinates, for the standard motions, per diagonal.

    Parameters
    ----------
    residual : (k, n) float, or (k, n + m) for Green coordinates
        Exact coordinates minus their reproduction (``W - slots @ basis.T``, with the
        slots and basis as stored).
    rest : (n, N) float
        The cage at rest (N = 3 for the smooth motion).
    fraction : float
        How far the dragged vertex moves, of the cage's diagonal.
    faces : (m, 3) int, optional
        Given for Green coordinates: the motions are then their ``green_displacements``.

    Returns
    -------
    smooth : float
        ``max_i |residual_i D| / diagonal`` for ``D`` the :func:`smooth_test_motion`.
    drag : (n,) float
        Per cage vertex j, the deviation when j alone is dragged by ``fraction`` of the
        diagonal: ``fraction * max_i |residual_ij|`` in any direction (exact and cheap,
        so the worst vertex is found without moving each one); for Green coordinates,
        dragged outward as :func:`vertex_drag_motion`, with the faces around j (exact
        for the worst vertex; the others may hold an upper bound below it).

    Examples
    --------
    >>> import gencoords
    >>> from gencoords.storage.compact import motion_basis, residual_deviations
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> w = gencoords.coordinates([[0.1, 0.2, 0.3]], vertices, faces, workers=1)
    >>> basis = motion_basis(vertices, faces, 10)
    >>> smooth, drag = residual_deviations(w - (w @ basis) @ basis.T, vertices)
    >>> drag.shape, smooth < 0.1
    ((42,), True)
    """
    rest = np.asarray(rest, dtype=np.float64)
    residual = np.asarray(residual, dtype=np.float64)
    if len(residual) == 0:
        return 0.0, np.zeros(len(rest))
    diagonal = np.linalg.norm(np.ptp(rest, axis=0))
    moved = smooth_test_motion(rest)
    motion = moved - rest if faces is None else green_displacements(rest, moved, faces)
    smooth = np.linalg.norm(residual @ motion, axis=1).max() / diagonal
    if faces is not None:
        return float(smooth), _green_drag_deviations(residual, rest, np.asarray(faces), fraction) / diagonal
    largest = np.maximum(residual.max(axis=0), -residual.min(axis=0))  # no |residual| copy
    return float(smooth), fraction * largest


def _green_drag_deviations(residual, rest, faces, fraction):
    """Per cage vertex j, ``max_i |residual_i D_j|`` (D_j: the Green displacements of j
    dragged alone, its row and the rows of the faces around it), or, for a vertex that
    cannot be the worst, an upper bound of it no larger than the worst: (n,) float.

    The bound ``max_i |r_ij| |D_jj| + sum_f max_i |r_if| |D_fj|`` costs one pass over the
    residual; exact values are computed only for the vertices whose bound could exceed
    the worst exact value found (a few, where Bind's drag is dominated by one corner),
    so the largest entry and where it is are exact."""
    count = len(rest)
    # Each vertex's step in vertex_drag_motion: outward from the centroid.
    outward = rest - rest.mean(axis=0)
    length = np.maximum(np.linalg.norm(outward, axis=1, keepdims=True), tolerances.TINY)
    steps = fraction * np.linalg.norm(np.ptp(rest, axis=0)) * outward / length  # (n, 3)
    # Face f with its corner c dragged, for every (f, c): those faces' displacements.
    corners = rest[faces]  # (m, 3, 3)
    face_rows = np.empty((len(faces), 3, 3))
    for corner in range(3):
        moved = corners.copy()
        moved[:, corner] += steps[faces[:, corner]]
        local = np.arange(3 * len(faces)).reshape(-1, 3)
        face_rows[:, corner] = green_displacements(corners.reshape(-1, 3), moved.reshape(-1, 3), local)[-len(faces):]
    owner, pair_face, pair_rows = faces.ravel(), np.repeat(np.arange(len(faces)), 3), face_rows.reshape(-1, 3)
    largest = np.maximum(residual.max(axis=0), -residual.min(axis=0))  # (n + m,)
    drag = largest[:count] * np.linalg.norm(steps, axis=1) + np.bincount(
        owner, weights=largest[count + pair_face] * np.linalg.norm(pair_rows, axis=1), minlength=count)
    worst = 0.0
    for j in np.argsort(-drag):  # by decreasing bound, until no bound can beat the worst
        if drag[j] <= worst:
            break
        fan = np.flatnonzero(owner == j)
        total = residual[:, j, None] * steps[j] + residual[:, count + pair_face[fan]] @ pair_rows[fan]
        drag[j] = np.linalg.norm(total, axis=1).max()
        worst = max(worst, drag[j])
    return drag


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
        Green coordinates (``coordinates`` then ``[phi, psi]``): as :func:`residual_deviations`.

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
