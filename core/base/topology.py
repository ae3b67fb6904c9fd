"""Combinatorics of a simplicial cage: ridges, their facets and orientations.

A ridge is an (N-2)-face: a vertex in 2D, an edge in 3D. Each ridge is stored with its
vertex indices sorted ascending (the canonical order); ``ridge_signs`` records how the
canonical order relates to the facet's own orientation, which is what turns one ridge
vector per (point, ridge) into the cofactor vectors ``m_i`` of every facet using it.
"""

from dataclasses import dataclass

import numpy as np


__all__ = ["CageTopology", "cage_topology", "gather_table"]


def _permutation_parity(order):
    """Sign (+1 or -1) of the permutations that sort each row.

    Parameters
    ----------
    order : (m, p) int
        Rows of distinct values.

    Returns
    -------
    sign : (m,) int
    """
    ranks = np.argsort(np.argsort(order, axis=1), axis=1)
    # Count inversions; p is at most the dimension, so the double loop is tiny.
    inversions = np.zeros(len(order), dtype=np.int64)
    width = order.shape[1]
    for a in range(width):
        for b in range(a + 1, width):
            inversions += ranks[:, a] > ranks[:, b]
    return 1 - 2 * (inversions % 2)


def _ridge_incidences(faces):
    """The ridge opposite each facet slot, with its orientation sign.

    Parameters
    ----------
    faces : (m, N) int

    Returns
    -------
    sorted_ridges : (m, N, N-1) int
        Vertices of the ridge opposite slot i of each facet, ascending.
    signs : (m, N) int
        ``(-1)^i`` times the parity of sorting the ridge from facet order: the cofactor
        ``m_i`` of the facet equals ``signs[t, i]`` times the generalized cross product
        of the ridge's vectors in ascending order.
    """
    faces = np.asarray(faces)
    count, dim = faces.shape
    opposite = np.stack([np.delete(faces, i, axis=1) for i in range(dim)], axis=1)
    flat = opposite.reshape(count * dim, dim - 1)
    parity = _permutation_parity(flat).reshape(count, dim)
    slot_sign = np.where(np.arange(dim) % 2 == 0, 1, -1)
    return np.sort(opposite, axis=2), parity * slot_sign[None, :]


@dataclass(frozen=True)
class CageTopology:
    """Everything about a cage that does not depend on vertex positions or query points.

    Attributes
    ----------
    faces : (m, N) int
    ridges : (r, N-1) int
        Sorted ridge vertices (see :func:`ridges`).
    facet_ridges : (m, N) int
        Index of the ridge opposite each facet slot.
    facet_ridge_signs : (m, N) float
        Orientation signs: cofactor ``m_i`` of facet t = sign * ridge cross product.
    ridge_use_count : (r,) int
        How many facets use each ridge (2 on a closed manifold).
    ridge_signs_sum : (r,) int
        Sum of the signs of each ridge's uses (0 when consistently oriented).
    vertex_slots : (n, v) int
        For each vertex, the flat indices ``i * m + t`` of the facet slots it fills
        (slot i of facet t), padded with ``m * N`` (a slot that reads as zero).
    """

    faces: np.ndarray
    ridges: np.ndarray
    facet_ridges: np.ndarray
    facet_ridge_signs: np.ndarray
    ridge_use_count: np.ndarray
    ridge_signs_sum: np.ndarray
    vertex_slots: np.ndarray

    @property
    def dimension(self):
        return self.faces.shape[1]

    def ridge_facets(self):
        """The two facets of each ridge and the vertex opposite it in each.

        Only meaningful on a closed, consistently oriented cage (each ridge used twice,
        once with sign +1 and once with -1).

        Returns
        -------
        facets : (r, 2) int
            Facet whose slot sign is +1, then the one whose sign is -1.
        opposite : (r, 2) int
            The vertex of each of those facets that is not on the ridge.
        """
        count, dim = self.faces.shape
        flat_ridge = self.facet_ridges.reshape(-1)
        flat_sign = self.facet_ridge_signs.reshape(-1)
        facet_of_slot = np.repeat(np.arange(count), dim)
        vertex_of_slot = self.faces.reshape(-1)
        facets = np.empty((len(self.ridges), 2), dtype=np.int64)
        opposite = np.empty_like(facets)
        for column, sign in enumerate((1.0, -1.0)):
            chosen = flat_sign == sign
            facets[flat_ridge[chosen], column] = facet_of_slot[chosen]
            opposite[flat_ridge[chosen], column] = vertex_of_slot[chosen]
        return facets, opposite


def gather_table(owners, count):
    """For each owner, the indices of the items it owns: summing per-item values into
    per-owner totals becomes a few row gathers instead of a scatter loop.

    Parameters
    ----------
    owners : (L,) int
        Owner (in ``range(count)``) of each item.
    count : int

    Returns
    -------
    table : (count, w) int
        Row o lists the items of owner o, padded with ``L`` (an index past the items,
        which callers point at a row of zeros); w is the largest number of items owned.
    """
    order = np.argsort(owners, kind="stable")
    owned = np.bincount(owners, minlength=count)
    starts = np.concatenate([[0], np.cumsum(owned)[:-1]])
    rank = np.arange(len(order)) - starts[owners[order]]
    table = np.full((count, max(int(owned.max(initial=0)), 1)), len(owners), dtype=np.int64)
    table[owners[order], rank] = order
    return table


def cage_topology(faces, vertex_count):
    """Build the :class:`CageTopology` of a cage.

    Parameters
    ----------
    faces : (m, N) int
    vertex_count : int
        n, the number of cage vertices (vertices used by no facet are allowed here and
        rejected by validation).

    Returns
    -------
    CageTopology
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    count, dim = faces.shape
    sorted_ridges, signs = _ridge_incidences(faces)
    unique, inverse = np.unique(sorted_ridges.reshape(-1, dim - 1), axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    use_count = np.bincount(inverse, minlength=len(unique))
    signs_sum = np.bincount(inverse, weights=signs.reshape(-1), minlength=len(unique)).astype(np.int64)

    # Slot-major (flat index i * m + t) like the per-slot arrays of the construction.
    vertex_slots = gather_table(faces.T.reshape(-1), vertex_count)

    return CageTopology(
        faces=faces,
        ridges=unique,
        facet_ridges=inverse.reshape(count, dim),
        facet_ridge_signs=signs.astype(np.float64),
        ridge_use_count=use_count,
        ridge_signs_sum=signs_sum,
        vertex_slots=vertex_slots,
    )
