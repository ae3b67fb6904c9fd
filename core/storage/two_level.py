"""Sparse storage in two levels (harmonic coordinates: interpolations of grid-node
values): the grid nodes that interpolate the points carry their own (cage vertex,
weight) pairs, and each point keeps its corner nodes (8:
``gencoords.harmonic.interpolation``) with their weights. The truncation then happens at
the nodes only, and a node can keep many pairs cheaply: the N nodes are few beside the k
points. Their pairs are stored stacked (:func:`gencoords.storage.sparse.stacked_columns`)
in columns as long as the points, so they take about N x K' numbers each, not k x K'.
:func:`two_level_layout` encodes, :func:`gencoords.storage.sparse.layout_coordinates`
decodes, :func:`plan_bytes` counts.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..harmonic.interpolation import CORNER_COUNT
from ..base.arrays import in_row_blocks
from .pair_deviations import deviations, interpolated
from .sparse import fewest_pairs, fewest_slots_bound, placed_pairs, playback_seconds as gather_seconds

__all__ = ["used_nodes", "playback_seconds", "automatic_node_slot_counts", "filled_node_slot_counts", "two_level_layout", "fewest_node_slots", "TwoLevelLayout", "NODE_SLOT_COUNTS"]

# Candidate K' of grid nodes (two levels): few nodes beside the points, so many pairs are
# cheap (bench_sparse_routes.py: 48 pairs on 1,286 nodes play back in 0.8x Mesh Deform's time).
NODE_SLOT_COUNTS = (8, 16, 24, 32, 48, 64, 96, 128)
# Beyond those, Automatic tries more K', up to every cage vertex, while the nodes' pairs
# fill at most this many stored columns (each a gather over the mesh's vertex count, as one
# of the 4 corners is): the node stage then costs at most twice the vertex stage. Harmonic
# coordinates deep inside a convex cage are not local (a million points in a 642-vertex
# icosphere: 128 pairs deviate 2e-2), and there the nodes are few beside the points.
MORE_NODE_SLOT_COUNTS, NODE_COLUMN_BUDGET = (192, 256, 384, 512), 8
SAMPLE_POINTS = 2000  # points the fewest K' is chosen on (then measured on all)
SAMPLE_MARGIN = 0.8  # of the target, for the points the sample skipped
_PLACED_ENTRIES = 1 << 18  # (node, cage vertex) entries paired at a time (2 MB of float64 rows)
_GATHERED_ENTRIES = 1 << 16  # (node, slot) pairs placed at a time (their vertices: 1.5 MB)


def used_nodes(corners):
    """The grid nodes that interpolate the points, and the corners renumbered into them.

    Parameters
    ----------
    corners : (k, c) int
        Each point's corner nodes (rows of a grid's nodes).

    Returns
    -------
    used : (N,) int
        Sorted node rows.
    local : (k, c) int32
        ``corners`` as rows of ``used``.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.two_level import used_nodes
    >>> used, local = used_nodes(np.array([[7, 3, 7, 9, 3, 3, 9, 7]]))
    >>> used.tolist(), local.tolist()
    ([3, 7, 9], [[1, 0, 1, 2, 0, 0, 2, 1]])
    """
    used, local = np.unique(np.asarray(corners), return_inverse=True)
    return used, local.reshape(np.shape(corners)).astype(np.int32)


def automatic_node_slot_counts(point_count, node_count, column_count, per_vector=3):
    """Automatic's candidate K' for N grid nodes beside k points: NODE_SLOT_COUNTS, then
    MORE_NODE_SLOT_COUNTS and every column (n) as far as NODE_COLUMN_BUDGET stored columns,
    filled (:func:`filled_node_slot_counts`).

    Examples
    --------
    >>> from gencoords.storage.two_level import automatic_node_slot_counts
    >>> automatic_node_slot_counts(1_000_000, 7960, 642)  # 375 slots a column: all 642 in 2
    (375, 642)
    >>> automatic_node_slot_counts(43236, 5524, 196)  # all 196 would take 10 columns
    (21, 42, 63, 84, 105, 147)
    """
    per_column = _slots_per_column(point_count, node_count, per_vector)
    more = [count for count in MORE_NODE_SLOT_COUNTS + (column_count,)
            if -(-min(count, column_count) // per_column) <= NODE_COLUMN_BUDGET]
    return filled_node_slot_counts(NODE_SLOT_COUNTS + tuple(more), point_count, node_count, column_count, per_vector)


def _slots_per_column(point_count, node_count, per_vector):
    """Node slots one stored column holds (:func:`stacked_columns`): ``per_vector`` times
    the nodes' copies that fit its ``point_count`` rows."""
    return per_vector * max(1, point_count // max(1, node_count))


def filled_node_slot_counts(counts, point_count, node_count, column_count, per_vector=3):
    """Candidate K' rounded up to fill whole stacked columns (:func:`stacked_columns` of
    ``per_vector`` slots to a stored vector): the deformer's cost grows with the columns,
    not the slots, so a column's spare slots are free accuracy.

    Parameters
    ----------
    counts : increasing sequence of int
        Candidate K'.
    point_count, node_count : int
        The column length (the mesh's vertex count) and N.
    column_count : int
        The cage's vertex count n (no node keeps more pairs).

    Returns
    -------
    tuple of int
        Increasing, distinct, each a whole number of columns or n.

    Examples
    --------
    >>> from gencoords.storage.two_level import filled_node_slot_counts
    >>> filled_node_slot_counts((8, 16, 24, 48), 1000, 140, 200)  # 7 vectors, 21 slots a column
    (21, 42, 63)
    """
    per_column = _slots_per_column(point_count, node_count, per_vector)
    return tuple(sorted({min(-(-count // per_column) * per_column, column_count) for count in counts}))


@dataclass(frozen=True, eq=False)
class TwoLevelLayout:
    """Sparse bind data in two levels (:func:`two_level_layout`), as written: float32
    weights, int32 indices.

    Attributes
    ----------
    corners : (k, c) int32
        Each point's corner nodes (c = 8: ``gencoords.harmonic.interpolation``), as
        rows of the N nodes kept.
    corner_weights : (k, c) float32
        Their interpolation weights.
    node_indices : (N, K') int32
        Each node's cage vertices, largest weight first.
    node_weights : (N, K') float32
        Their weights, summing to 1 per node.
    deviation_smooth, deviation_drag : float
        Of the cage's diagonal, measured on every point against the points' exact
        (interpolated) coordinates.
    deviation_drag_vertex : int
    reason : str or None
        Why K' is what it is, where the target was missed.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.two_level import TwoLevelLayout
    >>> one_node = TwoLevelLayout(np.zeros((1, 4), np.int32), np.full((1, 4), 0.25, np.float32),
    ...                           np.zeros((1, 4), np.int32), np.full((1, 4), 0.25, np.float32),
    ...                           0.0, 0.0, 0)
    >>> one_node.node_count, one_node.node_slot_count
    (1, 4)
    """

    corners: np.ndarray
    corner_weights: np.ndarray
    node_indices: np.ndarray
    node_weights: np.ndarray
    deviation_smooth: float
    deviation_drag: float
    deviation_drag_vertex: int
    reason: Optional[str] = None

    @property
    def node_count(self):
        return len(self.node_indices)

    @property
    def node_slot_count(self):
        return self.node_indices.shape[1]

    def placed_points(self, rest):
        """Where the stored weights place each point with the cage ``rest`` ((n, 3)): the
        nodes' places, interpolated; (k, 3) float64. The nodes a block at a time: the
        quadruped's (N, K', 3) gathered vertices were 35 MB, its Bind's peak."""
        node_places, = in_row_blocks(lambda weights, indices: (np.einsum("nk,nkc->nc", weights.astype(np.float64),
                                                                         rest[indices]),),
                                     max(1, _GATHERED_ENTRIES // self.node_slot_count), self.node_weights,
                                     self.node_indices)
        return interpolated(node_places, self.corners, self.corner_weights)


def two_level_layout(node_coordinates, corners, corner_weights, rest, target, counts=NODE_SLOT_COUNTS):
    """The two-level sparse layout of points interpolated from nodes: the nodes with the
    fewest pairs each (of ``counts``: :func:`placed_pairs`) whose deviations stay under
    ``target`` (chosen on a sample of the points, measured on all).

    Parameters
    ----------
    node_coordinates : (N, n) float
        The nodes' coordinates (rows summing to 1): the grid nodes that interpolate the
        points (:func:`used_nodes`), and any point's own row where it is not
        interpolated (its corners all that row, its first corner weight 1).
    corners : (k, c) int
        Each point's corner nodes (rows of ``node_coordinates``).
    corner_weights : (k, c) float
        Their interpolation weights.
    rest : (n, 3) float
        The cage at rest.
    target : float
        Of the cage's diagonal.
    counts : increasing sequence of int
        Candidate K'; the last is used when none meets the target.

    Returns
    -------
    TwoLevelLayout

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.two_level import two_level_layout
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> nodes = np.random.default_rng(0).dirichlet(np.ones(6), 16)
    >>> corners = np.arange(8).reshape(2, 4)
    >>> layout = two_level_layout(nodes[:8], corners, np.full((2, 4), 0.25), vertices, 1e-3, counts=(2, 6))
    >>> layout.node_count, layout.node_slot_count, layout.deviation_drag < 1e-6
    (8, 6, True)
    """
    nodes, corners, corner_weights, sampled, interpolation = _sample(node_coordinates, corners, corner_weights)
    count, _, _, sample_indices, sample_weights = fewest_pairs(nodes[sampled], rest, target * SAMPLE_MARGIN, counts,
                                                               interpolation=interpolation)
    reason = None
    if count is None:
        count = counts[-1]
    # Each node's pairs are its row's alone: the sample's are kept, the others placed.
    others = np.ones(len(nodes), dtype=bool)
    others[sampled] = False
    indices = np.empty((len(nodes), sample_indices.shape[1]), dtype=sample_indices.dtype)
    weights = np.empty(indices.shape, dtype=np.float32)
    indices[sampled], weights[sampled] = sample_indices, sample_weights
    others = np.flatnonzero(others)
    # A block of nodes at a time (each row's pairs are its own): their rows and the (N, K')
    # ranks and weights of all at once were a quadruped's Bind peak.
    step = max(1, _PLACED_ENTRIES // max(1, nodes.shape[1]))
    for start in range(0, len(others), step):
        rows = others[start:start + step]
        indices[rows], weights[rows] = placed_pairs(nodes[rows], count, rest, span=True)
    smooth, drag, vertex = deviations(nodes, indices, weights, rest, (corners, corner_weights))
    if max(smooth, drag) >= target:
        reason = (f"{count} pairs per grid node deviate {max(smooth, drag):.1e} of the cage's "
                  f"diagonal (more than {target:.0e})")
    return TwoLevelLayout(corners, corner_weights, indices, weights, smooth, drag, vertex, reason)



def _sample(node_coordinates, corners, corner_weights):
    """The arrays as :func:`two_level_layout` takes them (float64, int32, float32), the
    sample's nodes (N' rows) and the sample as their interpolation (only the sample's
    nodes are paired while K' is chosen)."""
    nodes = np.asarray(node_coordinates, dtype=np.float64)
    corners = np.asarray(corners, dtype=np.int32)
    corner_weights = np.asarray(corner_weights, dtype=np.float32)
    sample = slice(None, None, max(1, len(corners) // SAMPLE_POINTS))
    sampled, sample_corners = used_nodes(corners[sample])
    return nodes, corners, corner_weights, sampled, (sample_corners, corner_weights[sample])


def fewest_node_slots(node_coordinates, corners, corner_weights, rest, target, counts=NODE_SLOT_COUNTS):
    """A lower bound on the K' :func:`two_level_layout` chooses with these arguments, at
    a part of its cost (``sparse.fewest_slots_bound``): where per-vertex pairs play back
    faster than two levels with it, the layout need not be made to be compared.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.storage.two_level import fewest_node_slots, two_level_layout
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, _ = octahedron()
    >>> rng = np.random.default_rng(0)
    >>> nodes, corners, weights = rng.dirichlet(np.ones(6), 300), rng.integers(0, 300, (600, 4)), np.full((600, 4), 0.25)
    >>> bound = fewest_node_slots(nodes, corners, weights, vertices, 1e-3, counts=(2, 4, 6))
    >>> bound <= two_level_layout(nodes, corners, weights, vertices, 1e-3, counts=(2, 4, 6)).node_slot_count
    True
    """
    nodes, _, _, sampled, interpolation = _sample(node_coordinates, corners, corner_weights)
    return fewest_slots_bound(nodes[sampled], rest, target * SAMPLE_MARGIN, counts, interpolation)


def playback_seconds(point_count, node_count, node_slot_count, corner_count=CORNER_COUNT, per_vector=3):
    """The deformer's estimated time per evaluation (``sparse.playback_seconds``) for k
    points over N nodes of K' pairs: the stored columns' weighted gathers, three a column
    in each of the rows holding pairs; each node's sum of its rows; each point's corners.

    Examples
    --------
    >>> from gencoords.storage.two_level import playback_seconds
    >>> round(playback_seconds(4320, 3506, 18) * 1e3, 2)  # the cape: 6 columns of 3 slots
    1.86
    """
    per_column = _slots_per_column(point_count, node_count, per_vector)
    columns = -(-node_slot_count // per_column)
    blocks = min(per_column // per_vector, -(-node_slot_count // per_vector))  # rows a node sums
    holding = min(point_count, node_count * blocks)
    gathers = per_vector * columns * holding + blocks * node_count + corner_count * point_count
    return gather_seconds(gathers, columns + blocks + corner_count)


def plan_bytes(plan):
    """Bytes of a two-level plan's attributes: each point's corner nodes and weights (an
    int32 and a float32 each), and the nodes' pairs three to a vector in stacked columns
    as long as the points (:func:`gencoords.storage.sparse.stacked_columns`)."""
    count = len(plan.slots)
    triples, per_column = -(-plan.node_slot_count // 3), count // plan.node_count
    return count * plan.slot_count * 8 + 2 * -(-triples // per_column) * count * 12
