"""The similarity a Bind probes what it writes with, and how far the written coordinates
follow it: rotated and scaled cages are what the sums check (translations) does not see
(a thin wall's points, a coarse grid's nodes)."""

import numpy as np

__all__ = ["probe_similarity", "similarity_deviation"]


def probe_similarity(rest):
    """The similarity Bind probes what it writes with: the cage ``rest`` ((n, 3)) turned
    40 degrees about a skew axis, scaled by 1.5 and moved by its diagonal.

    Returns
    -------
    rotation : (3, 3) float64
    scale : float
    shift : (3,) float64

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.planning.similarity import probe_similarity
    >>> rotation, scale, shift = probe_similarity(np.array([[0.0, 0, 0], [3, 4, 0]]))
    >>> bool(np.allclose(rotation @ rotation.T, np.eye(3))), scale, shift.round(6).tolist()
    (True, 1.5, [3.0, -4.0, 0.0])
    """
    axis = np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    angle = np.radians(40.0)
    rotation = np.eye(3) + np.sin(angle) * cross + (1.0 - np.cos(angle)) * cross @ cross
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(rest, dtype=np.float64), axis=0)))
    return rotation, 1.5, diagonal * np.array([0.6, -0.8, 0.0])


def similarity_deviation(places, sums, points, rest):
    """How far points follow :func:`probe_similarity` of the cage, of its size after the
    move, where their coordinates as written place them at ``places`` ((k, 3):
    ``sum_j w_j R_j``) and sum to ``sums`` ((k,)): a vertex moves to ``sum_j w_j (s Q R_j
    + t) = s Q places + sums t`` and should be at ``s Q x + t``. A float.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.planning.similarity import similarity_deviation
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    >>> points = np.array([[0.5, 0.5, 0.5], [0.2, 0.3, 0.4]])
    >>> similarity_deviation(points, np.ones(2), points, cube)
    0.0
    >>> round(similarity_deviation(points + [1e-3, 0, 0], np.ones(2), points, cube), 6)  # 1e-3 of 1.73
    0.000577
    """
    rest = np.asarray(rest, dtype=np.float64)
    rotation, scale, shift = probe_similarity(rest)
    followed = scale * np.asarray(places, dtype=np.float64) @ rotation.T + np.asarray(sums)[:, None] * shift
    wanted = scale * np.asarray(points, dtype=np.float64) @ rotation.T + shift
    size = scale * float(np.linalg.norm(np.ptp(rest, axis=0)))
    return float(np.linalg.norm(followed - wanted, axis=1).max(initial=0.0) / size)
