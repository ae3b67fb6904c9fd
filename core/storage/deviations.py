"""How far a stored form of coordinates is from the exact one, of the cage's diagonal:
under the standard smooth motion (:func:`smooth_test_motion`) and under the worst
single cage vertex dragged (:func:`vertex_drag_motion`), measured exactly from the
residual ``W - stored(W)`` (:func:`residual_deviations`; :func:`deviation` for any
motion). Compact and sparse storage, and Automatic's choice between them, measure with
these; Green coordinates (``[phi, psi]``) take ``faces``.
"""

import numpy as np

from ..base import tolerances
from ..construction.green_deform import green_displacements

__all__ = ["smooth_test_motion", "vertex_drag_motion", "deviation", "residual_deviations", "DRAG_FRACTION"]

DRAG_FRACTION = 0.1  # the dragged cage vertex moves this fraction of the cage's diagonal


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
    >>> from gencoords.storage.deviations import smooth_test_motion
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
    >>> from gencoords.storage.deviations import vertex_drag_motion
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
    >>> from gencoords.storage.compact import motion_basis
    >>> from gencoords.storage.deviations import deviation, vertex_drag_motion
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
    >>> from gencoords.storage.compact import motion_basis
    >>> from gencoords.storage.deviations import residual_deviations
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
