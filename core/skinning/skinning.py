"""Skinning weights from coordinates: linear blend skinning with translating bones.

A bone per cage vertex j, resting at ``heads[j]`` and moved to the cage vertex ``C_j``,
translates the points it weighs by ``C_j - heads[j]``. Linear blend skinning (as
Blender's Armature modifier and glTF runtimes evaluate it, rows normalised by their sum)
then moves point i by

    sum_j w_ij (C_j - heads_j) / sum_j w_ij,

which is the coordinates' own ``sum_j c_ij (C_j - R_j)`` when ``w = c`` and the bones
rest on the bind-time cage ``R``. Skinning weights cannot be negative (Blender clamps
vertex-group weights to [0, 1]) and game engines keep 4 or 8 per vertex, so
:func:`deviation` measures what the weights actually written give against the exact
deformation.
"""

import numpy as np

from ..base import tolerances
from ..harmonic.reproduction import largest_entries
from ..harmonic.reproduction import reproduce_points  # noqa: F401  (part of this module's API)
from ..storage import sparse

NEGATIVE_TOLERANCE = tolerances.SKINNING_NEGATIVE  # see there


def top_k(coordinates, k):
    """The ``k`` largest coordinates of each row, renormalised to sum 1
    (``gencoords.harmonic.reproduction.largest_entries``): the sparse form skinning keeps.

    Parameters
    ----------
    coordinates : (p, n) float
        Non-negative rows (harmonic coordinates; :func:`negative_weights` counts others).
    k : int
        Kept per row, 1 <= k; ``k >= n`` keeps every column.

    Returns
    -------
    indices : (p, k') int64
        Columns kept, largest weight first (k' = min(k, n)).
    weights : (p, k') float64
        Their values divided by the kept sum: each row sums to 1 (a row whose kept
        weights are all zero gets 1/k' each; one with a negative kept weight the missing
        sum by size, as ``largest_entries`` says), so translations stay exact.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.skinning.skinning import top_k
    >>> indices, weights = top_k(np.array([[0.1, 0.6, 0.3]]), 2)
    >>> indices.tolist(), weights.round(3).tolist()
    ([[1, 2]], [[0.667, 0.333]])
    """
    if int(k) < 1:
        raise ValueError(f"k must be at least 1, got {k!r}")
    return largest_entries(coordinates, k)


def truncate(coordinates, max_influences, rest=None):
    """The ``max_influences`` largest weights of each row, renormalised (0: all kept);
    with the cage ``rest``, reweighted to place each point where the full row does
    (``storage.sparse.placed_pairs``): a rig keeps linear precision wherever the point lies
    among its kept bones (on the character, 16 influences follow a turned and scaled
    cage exactly, and deviate 8e-4 of the diagonal under the smooth motion against 7e-3
    truncated alone).

    Parameters
    ----------
    coordinates : (k, n) float
    max_influences : int
    rest : (n, 3) float, optional
        The cage the coordinates were computed in.

    Returns
    -------
    weights : (k, n) float64
        Zero outside each row's kept columns; rows sum to one.
    """
    weights = np.asarray(coordinates, dtype=np.float64)
    if not max_influences or max_influences >= weights.shape[1]:
        return weights.copy()
    if rest is None:
        indices, kept = top_k(weights, max_influences)
    else:
        indices, kept = sparse.placed_pairs(weights, max_influences, rest)
    truncated = np.zeros_like(weights)
    np.put_along_axis(truncated, indices.astype(np.int64), kept, axis=1)
    return truncated


def negative_weights(weights, tolerance=NEGATIVE_TOLERANCE):
    """How many weights are below ``-tolerance``, and the smallest weight.

    Parameters
    ----------
    weights : (k, n) float

    Returns
    -------
    count : int
    smallest : float
        The minimum of ``weights`` (0.0 when empty).
    """
    weights = np.asarray(weights)
    if weights.size == 0:
        return 0, 0.0
    return int(np.count_nonzero(weights < -tolerance)), float(weights.min())


def skin(weights, heads, moved):
    """Displacements linear blend skinning gives for bones moved from ``heads`` to ``moved``.

    Parameters
    ----------
    weights : (k, n) float
        Non-negative; each row is normalised by its sum (rows summing to 0 stay put).
    heads, moved : (n, N) float
        The bones' rest and current positions.

    Returns
    -------
    displacement : (k, N) float64
    """
    weights = np.asarray(weights, dtype=np.float64)
    total = weights.sum(axis=1, keepdims=True)
    normalised = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0.0)
    return normalised @ (np.asarray(moved, dtype=np.float64) - np.asarray(heads, dtype=np.float64))


def deviation(coordinates, rest, weights, heads, moved):
    """Largest distance between the exact and the skinned deformation, per cage diagonal.

    Parameters
    ----------
    coordinates : (k, n) float
        The exact coordinates of k points.
    rest : (n, N) float
        The cage the coordinates were computed in.
    weights : (k, n) float
        The skinning weights (as written, e.g. read back from vertex groups).
    heads : (n, N) float
        The bones' rest positions (as written), in the same frame as ``rest``.
    moved : (n, N) float
        The cage (and bones) after a motion.

    Returns
    -------
    deviation : float
        ``max_i |c_i (moved - rest) - skin(w, heads, moved)_i| / |diagonal of rest|``.
    """
    rest = np.asarray(rest, dtype=np.float64)
    if len(coordinates) == 0:
        return 0.0
    exact = np.asarray(coordinates, dtype=np.float64) @ (np.asarray(moved, dtype=np.float64) - rest)
    skinned = skin(weights, heads, moved)
    diagonal = np.linalg.norm(np.ptp(rest, axis=0))
    return float(np.linalg.norm(exact - skinned, axis=1).max() / diagonal)
