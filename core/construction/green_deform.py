"""Deforming with Green coordinates: each face's normal scaled by its stretch factor
(:func:`stretch_factors`), the deformed points (:func:`green_deform`) and the cage motions
Green coordinates see (:func:`green_displacements`: n vertex moves and m normal changes,
what compact storage's basis spans for them). The coordinates: :mod:`.green`.
"""

import numpy as np

from ..base.errors import CageError
from ..base.inputs import checked
from .validation import DEFAULT_TOLERANCE, validate_cage

__all__ = ["stretch_factors", "green_deform", "green_displacements"]


def _green_cage(vertices, faces, tolerance):
    if vertices.shape[1] != 3:
        raise CageError("bad_faces", f"Green coordinates need a 3D triangle cage, got {vertices.shape[1]}D "
                                     "vertices")
    return validate_cage(vertices, faces, convex=False, tolerance=tolerance)



@checked
def stretch_factors(vertices, cage_positions, faces):
    """Each face's stretch factor s_j from its rest shape to its deformed shape.

    ``s = ||(u', v')|| / (sqrt(8) area)`` with ``||(u', v')||^2 = |u'|^2 |v|^2
    - 2 (u'.v')(u.v) + |v'|^2 |u|^2`` (u, v the rest edge vectors from the face's first
    vertex, u', v' the deformed ones): 1 at rest, c under a similarity of ratio c.

    Parameters
    ----------
    vertices : (n, 3) float
        Rest cage (the one the coordinates were computed in).
    cage_positions : (n, 3) float
        Deformed cage.
    faces : (m, 3) int

    Returns
    -------
    stretch : (m,) float

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.advanced import stretch_factors
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> bool(np.allclose(stretch_factors(vertices, 2.5 * vertices + 1.0, faces), 2.5))
    True
    """
    return _stretch(vertices, cage_positions, faces)



def _stretch(rest, deformed, faces):
    u, v = rest[faces[:, 1]] - rest[faces[:, 0]], rest[faces[:, 2]] - rest[faces[:, 0]]
    du, dv = deformed[faces[:, 1]] - deformed[faces[:, 0]], deformed[faces[:, 2]] - deformed[faces[:, 0]]
    dot = lambda a, b: np.einsum("mc,mc->m", a, b)  # noqa: E731
    squared = dot(du, du) * dot(v, v) - 2.0 * dot(du, dv) * dot(u, v) + dot(dv, dv) * dot(u, u)
    area = 0.5 * np.linalg.norm(np.cross(u, v), axis=1)
    return np.sqrt(np.maximum(squared, 0.0)) / (np.sqrt(8.0) * area)



def _unit_normals(positions, faces):
    """Unit normals of the faces, (m, 3); a face of zero area has none: 0."""
    doubled = np.cross(positions[faces[:, 1]] - positions[faces[:, 0]], positions[faces[:, 2]] - positions[faces[:, 0]])
    length = np.linalg.norm(doubled, axis=1, keepdims=True)
    return np.divide(doubled, length, out=np.zeros_like(doubled), where=length > 0.0)



def _scaled_normals(rest, deformed, faces):
    """``s n'`` of every face, (m, 3)."""
    return _stretch(rest, deformed, faces)[:, None] * _unit_normals(deformed, faces)



def green_displacements(vertices, cage_positions, faces):
    """The cage motion as Green coordinates see it: ``[v' - v; s n' - n]``, (n + m, 3).

    A point with Green coordinates ``(phi, psi)`` moves by ``[phi, psi] @`` this (the
    deformer's form, ``P + sum_i phi_i (C_i - R_i) + sum_j psi_j (s_j n'_j - n_j)``):
    0 at rest, and linear in the motion for similarities.

    Parameters
    ----------
    vertices : (n, 3) float
        Rest cage.
    cage_positions : (n, 3) float
        Deformed cage.
    faces : (m, 3) int

    Returns
    -------
    displacements : (n + m, 3) float64

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.construction.green_deform import green_displacements
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> point = np.array([[0.1, 0.2, -0.3]])
    >>> phi, psi = gencoords.green_coordinates(point, vertices, faces)
    >>> moved = vertices * [1.6, 1.0, 1.0]
    >>> offset = np.hstack([phi, psi]) @ green_displacements(vertices, moved, faces)
    >>> bool(np.allclose(point + offset, gencoords.green_deform(phi, psi, vertices, moved, faces)))
    True
    """
    rest = np.asarray(vertices, dtype=np.float64)
    moved = np.asarray(cage_positions, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    return np.vstack([moved - rest, _scaled_normals(rest, moved, faces) - _unit_normals(rest, faces)])



@checked
def green_deform(phi, psi, vertices, cage_positions, faces):
    """Deformed points from Green coordinates: ``phi @ v' + psi @ (s n')``.

    Parameters
    ----------
    phi : (k, n) float
    psi : (k, m) float
        From :func:`green_coordinates` in the rest cage.
    vertices : (n, 3) float
        Rest cage.
    cage_positions : (n, 3) float
        Deformed cage.
    faces : (m, 3) int

    Returns
    -------
    positions : (k, 3) float64
        A deformed face of zero area has no normal and contributes no normal term.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, faces = icosphere(1)
    >>> points = np.array([[0.1, 0.2, -0.3], [0.0, -0.4, 0.2]])
    >>> phi, psi = gencoords.green_coordinates(points, vertices, faces)
    >>> turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 degrees about z
    >>> moved = gencoords.green_deform(phi, psi, vertices, 2.0 * vertices @ turn.T, faces)
    >>> bool(np.allclose(moved, 2.0 * points @ turn.T))  # a similarity, followed exactly
    True
    """
    rest, deformed = vertices, cage_positions
    _green_cage(rest, faces, DEFAULT_TOLERANCE)
    return phi.astype(np.float64) @ deformed + psi.astype(np.float64) @ _scaled_normals(rest, deformed, faces)
