"""A uniform grid of cubic cells fitted to a cage's box (harmonic coordinates are solved on it; point location looks points up in it).

``resolution`` cells span the box's longest side; the other sides get as many cells of
the same size as they need (a thin limb is as finely sampled as a long one), plus one
cell of margin on every side, so the outermost nodes are outside the cage. Nodes are
classified inside or outside exactly, by counting the cage's signed crossings of a ray
from each node along +z (one ray per grid column: the cost is columns x facets, not
nodes x facets).
"""

from dataclasses import dataclass

import numpy as np

__all__ = ["Grid", "fit_grid", "inside_nodes", "column_pairs", "surface_cells", "node_positions"]

# The rays leave the nodes' exact x and y by this fraction of a cell, in directions no
# cage edge of a box-modelled cage shares, so a ray never grazes an edge or a vertex.
_RAY_OFFSET = (2.0 ** -20 * np.sqrt(2.0), 2.0 ** -20 * np.sqrt(3.0) / 2.0)
_BATCH_PAIRS = 1 << 15  # (facet, column) pairs tested at a time: about 100 bytes each in temporaries
_SLAB_ROUNDING = 1e-6  # of a cell: a facet's slab grown by this against rounding


@dataclass(frozen=True)
class Grid:
    """A uniform grid of cubic cells.

    Attributes
    ----------
    origin : (3,) float
        Position of node (0, 0, 0).
    spacing : float
        Edge length of a cell.
    shape : (3,) int tuple
        Nodes along x, y and z (cells + 1).
    """

    origin: np.ndarray
    spacing: float
    shape: tuple

    @property
    def cells(self):
        """Cells along x, y and z: (3,) int tuple."""
        return tuple(size - 1 for size in self.shape)


def fit_grid(vertices, resolution):
    """The grid with ``resolution`` cubic cells along the longest side of the box of
    ``vertices`` (n, 3), and one cell of margin all round: :class:`Grid`."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    spacing = float((high - low).max()) / resolution
    cells = np.ceil((high - low) / spacing - 1e-9).astype(np.int64) + 2
    origin = 0.5 * (low + high) - 0.5 * spacing * cells
    return Grid(origin, spacing, tuple(int(count) + 1 for count in cells))


def node_positions(grid, indices):
    """Positions of nodes given by their (g, 3) integer grid indices: (g, 3) float."""
    return grid.origin + grid.spacing * np.asarray(indices, dtype=np.float64)


def _column_boxes(grid, corners):
    """Each facet's projection in cells (m, 3, 2) and the grid columns its box spans:
    lowest (m, 2) int and counts (m, 2) int."""
    offset = np.array(_RAY_OFFSET) * grid.spacing
    xy = (corners[:, :, :2] - grid.origin[:2] - offset) / grid.spacing  # in cells
    low = np.ceil(xy.min(axis=1)).astype(np.int64).clip(0, np.array(grid.shape[:2]) - 1)
    high = np.floor(xy.max(axis=1)).astype(np.int64).clip(0, np.array(grid.shape[:2]) - 1)
    return xy, low, np.maximum(high - low + 1, 0)


def column_pairs(grid, corners):
    """How many (facet, grid column) pairs :func:`inside_nodes` tests: int (a facet's
    share is the area of its box seen from above, in columns)."""
    _, _, counts = _column_boxes(grid, corners)
    return int((counts[:, 0] * counts[:, 1]).sum())


def _column_crossings(grid, corners):
    """Where each grid column's ray meets the facets: (column x, column y, height, sign).

    ``corners`` (m, 3, 3): the facets' corner positions. The sign is that of the facet's
    normal's z component (+1 where the ray leaves the cage going up).
    """
    xy, low, counts = _column_boxes(grid, corners)
    sizes = counts[:, 0] * counts[:, 1]
    facet = np.repeat(np.arange(len(corners)), sizes)
    within = np.arange(len(facet)) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    column = low[facet] + np.stack([within // counts[facet, 1], within % counts[facet, 1]], axis=1)
    # 2D edge functions of the column's ray in the facet's projection.
    a, b, c = (xy[facet, corner] - column for corner in range(3))
    cross = lambda u, v: u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]  # noqa: E731
    edge = np.stack([cross(b, c), cross(c, a), cross(a, b)], axis=1)
    area = edge.sum(axis=1)
    hit = (area != 0.0) & ((edge > 0.0).all(axis=1) | (edge < 0.0).all(axis=1))
    facet, column, edge, area = facet[hit], column[hit], edge[hit], area[hit]
    height = np.einsum("kc,kc->k", edge / area[:, None], corners[facet, :, 2])
    return column[:, 0], column[:, 1], height, np.sign(area)


def inside_nodes(grid, corners):
    """Which nodes are inside the cage (winding number 1): (x, y, z) bool array.

    Parameters
    ----------
    grid : Grid
    corners : (m, 3, 3) float
        The cage's triangles' corners, outward oriented.
    """
    # Counts of signed crossings (at most one a facet): 16 bits, summed in place (float64
    # and a summed copy were 37 MB at once for the 131^3 nodes of a Bind's inside lookup).
    winding = np.zeros(grid.shape, dtype=np.int16 if len(corners) < 1 << 15 else np.int32)  # no overflow
    _, _, counts = _column_boxes(grid, corners)
    ends = np.cumsum(counts[:, 0] * counts[:, 1])  # pairs up to each facet
    start = 0
    while start < len(corners):  # facets a batch at a time: about _BATCH_PAIRS pairs
        done = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, done + _BATCH_PAIRS, side="right")))
        x, y, height, sign = _column_crossings(grid, corners[start:stop])
        # A crossing above node z counts for it: add the sign at the last node below it
        # (then sum from the top down).
        level = np.floor((height - grid.origin[2]) / grid.spacing).astype(np.int64)
        keep = level >= 0
        np.add.at(winding, (x[keep], y[keep], np.minimum(level[keep], grid.shape[2] - 1)),
                  sign[keep].astype(winding.dtype))
        start = stop
    from_the_top = winding[:, :, ::-1]
    np.cumsum(from_the_top, axis=2, out=from_the_top)
    return winding > 0


def surface_cells(grid, corners, reach):
    """Cells that the cage's surface may cross: (x, y, z) bool array over cells.
    Conservative: every cell within ``reach`` of a facet is in.

    A facet marks the cells of its box, grown by ``reach``, that also meet its slab (the
    band between its corners' extreme heights along its normal, grown by ``reach``):
    a facet slanted across its box (a revolved cup's wall) marks the cells along it, not
    the whole box. The slab holds the facet whatever its normal (a quad's bilinear patch
    too: it lies in its corners' convex hull), so a rounded normal costs only tightness.

    Parameters
    ----------
    grid : Grid
    corners : (m, c, 3) float
        Each facet's corners (a triangle's 3, a quad's 4).
    reach : float
        In the grid's units.
    """
    cells = np.zeros(grid.cells, dtype=bool)
    last = np.array(grid.cells) - 1
    low = np.floor((corners.min(axis=1) - reach - grid.origin) / grid.spacing).astype(np.int64).clip(0, last)
    high = np.floor((corners.max(axis=1) + reach - grid.origin) / grid.spacing).astype(np.int64).clip(0, last)
    normals = np.cross(corners[:, 2] - corners[:, 0], corners[:, -1] - corners[:, 1])  # a triangle's: its last is its first
    lengths = np.linalg.norm(normals, axis=1)
    normals = normals / np.where(lengths > 0.0, lengths, 1.0)[:, None]
    heights = np.einsum("mcN,mN->mc", corners - grid.origin, normals)
    # A cell's centre within half its extent along the normal, reach and rounding of the slab.
    margin = 0.5 * grid.spacing * np.abs(normals).sum(axis=1) + reach + _SLAB_ROUNDING * grid.spacing
    bottom, top = heights.min(axis=1) - margin, heights.max(axis=1) + margin
    for facet, ((i0, j0, k0), (i1, j1, k1)) in enumerate(zip(low.tolist(), high.tolist())):
        x, y, z = ((np.arange(start, stop + 1) + 0.5) * grid.spacing
                   for start, stop in ((i0, i1), (j0, j1), (k0, k1)))
        normal = normals[facet]
        height = (normal[0] * x)[:, None, None] + (normal[1] * y)[None, :, None] + (normal[2] * z)[None, None, :]
        cells[i0:i1 + 1, j0:j1 + 1, k0:k1 + 1] |= (height >= bottom[facet]) & (height <= top[facet])
    return cells
