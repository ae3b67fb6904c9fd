"""Harmonic coordinates of a closed triangle cage, solved once on a grid, evaluated at any
points by trilinear interpolation (docs/MATH.md, "Harmonic coordinates"); solved
by :func:`gencoords.harmonic.grid_field.harmonic_field`."""


import hashlib
import itertools

import numpy as np

from ..base.errors import OutsideCageError
from ..base.inputs import checked
from ..construction.boundary import winding_numbers
from .boundary_values import nearest_boundary_points
from .cage_features import _across_the_part, _without, hidden_corners, hidden_from
from ..base.grid import node_positions
from .inside import inside_or_on
from .interpolation import trilinear
from .reproduction import placing_largest
from .taken_points import taken_rows, taken_slice

__all__ = ["DEFAULT_RESOLUTION", "HarmonicField"]

DEFAULT_RESOLUTION = 64
# A point in a cell with a corner that does not place itself exactly keeps this many of
# its largest interpolated coordinates, reweighted to place it (docs/MATH.md): the rest
# weigh little (per-point sparse storage of 32 deviates 5e-5 of the diagonal on the
# character) and the reweighting costs in proportion to the count.
CUT_SUPPORT = 32
# Of the nearest exact node's coordinates added to a prior that cannot reach its point.
_WIDENING = 1e-2
_CUT_POINTS = 512  # points in cut cells placed at a time (each point's pairs are its own)
_MIXED_ENTRIES = 1 << 16  # (point, cage vertex) entries interpolated at a time (0.5 MB of float64)


class HarmonicField:
    """Harmonic coordinates solved on a grid: the grid nodes' coordinates, and any
    point's interpolated trilinearly from its cell's 8 nodes' (:mod:`.interpolation`).

    Made by :func:`gencoords.harmonic_field`. The nodes kept are the corners of the
    cells that hold some of the cage's inside (every point inside or on the cage lies
    in such a cell): the nodes inside the cage, solved, and those on or outside it, which
    hold the cage's hat values at their nearest boundary point.

    Attributes
    ----------
    vertices : (n, 3) float
        The cage's vertices (world units, as given).
    faces : (m, 3) or (m, 4) int
        Its triangles, or (:func:`gencoords.harmonic_quad_field`) its triangles and
        quads, a triangle's fourth index -1.
    resolution : int
        Cells along the longest side of the cage's box.
    origin : (3,) float
        World position of grid node (0, 0, 0).
    spacing : float
        Edge length of the cubic cells (world units).
    shape : (3,) int tuple
        Grid nodes along x, y and z.
    node_indices : (g, 3) int
        Grid index of each kept node (node i sits at ``origin + spacing * node_indices[i]``).
    node_positions : (g, 3) float
        World positions of the kept nodes.
    node_coordinates : (g, n) float
        Their harmonic coordinates: non-negative, rows summing to 1. A new dense array
        each time it is read (the field keeps the solved nodes' rows dense and the
        others' few non-zero pairs: the cup's 35 MB against 90): :meth:`node_rows` reads
        some of them.
    node_inside : (g,) bool
        Whether each node was solved for: inside the cage, farther from it than 1e-2 of a
        cell (the others hold their nearest boundary point's hat values).
    node_exact : (g,) bool
        Whether each node's coordinates place it exactly (``sum_j w_j R_j`` is the node):
        the solved nodes (the solve is exact for linear functions; a reweighting after it
        removes the solver's and the nearest crossings' rounding: :mod:`.reproduction`),
        and the outside nodes the reweighting reaches. A point whose 8 interpolating
        nodes are all exact is placed exactly by their interpolation; the others are
        reweighted themselves (:meth:`cut_pairs`).
    convergence : list of float
        The solver's largest relative residual after each iteration (docs/MATH.md).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> corners = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward
    >>> field = gencoords.harmonic_field(corners, triangles, resolution=16)
    >>> nodes, weights = field.interpolation([[0.2, 0.2, 0.2]])
    >>> nodes.shape, bool(np.isclose(weights.sum(), 1.0))
    ((1, 8), True)
    >>> print(field.coordinates([[0.2, 0.2, 0.2]]).round(1))
    [[0.4 0.2 0.2 0.2]]
    """

    def __init__(self, prepared, vertices, faces, resolution, grid, parts):
        self._prepared, self._grid = prepared, grid
        self.vertices, self.faces, self.resolution = vertices, faces, int(resolution)
        self.origin = grid.origin * prepared.scale + prepared.origin
        self.spacing = grid.spacing * prepared.scale
        self.shape = grid.shape
        self._ids, self._surface, self._tolerance = parts["ids"], parts["surface"], parts["tolerance"]
        self._cell_inside = parts["cell_inside"]
        self.node_indices = parts["indices"]
        self.node_positions = node_positions(grid, self.node_indices) * prepared.scale + prepared.origin
        self._node_rows = parts["coordinates"]  # MixedRows
        self.node_inside = parts["inside"]
        self.node_exact = parts["exact"]
        self._sources = parts["sources"]  # (g, 3) frame units: where each node's values come from
        self._exact = parts["exact_within"]  # frame units
        self.convergence = parts["convergence"]
        self._last_rows = None  # (key, rows): sparse_rows' last answer, until asked again

    @property
    def node_coordinates(self):
        return self._node_rows.toarray()

    def node_rows(self, nodes, out=None):
        """Nodes' coordinates: (k, n) float64 for (k,) int ``nodes``, into ``out`` (C order) where given."""
        return self._node_rows.rows(nodes, out)

    def __repr__(self):
        return (f"HarmonicField({len(self.vertices)} cage vertices, resolution {self.resolution}, "
                f"{len(self.node_indices)} nodes, {int(self.node_inside.sum())} inside)")

    @checked
    def interpolation(self, points, outside="raise"):
        """Each point's 8 interpolating nodes (:func:`.interpolation.trilinear`) and
        their weights.

        Parameters
        ----------
        points : (k, 3) float
        outside : str
            ``"raise"`` (:class:`gencoords.OutsideCageError` for points outside the cage,
            beyond the tolerance) or ``"project"`` (those points' nearest boundary point
            is used instead).

        Returns
        -------
        nodes : (k, 8) int
            Rows of :attr:`node_coordinates` / :attr:`node_positions`.
        weights : (k, 8) float
            Non-negative, each row summing to 1: ``coordinates = sum over the 8 of
            weights * node_coordinates[nodes]``.

        Examples
        --------
        See :class:`HarmonicField`.
        """
        local = self._located(points, outside)
        return self._interpolation(local)

    def _located(self, points, outside, inside=None):
        """Points in the grid's frame, those outside projected (or refused); ``inside`` as
        :meth:`sparse_rows`'."""
        if outside == "extrapolate":
            raise ValueError("harmonic coordinates do not extrapolate outside the cage; use "
                             "outside='raise' or outside='project'")
        local = self._prepared.local(points)
        out = np.flatnonzero(~self._inside_or_on(local, inside))
        if len(out) and outside == "raise":
            raise OutsideCageError(out, len(local))
        if len(out):
            columns, barycentric, _ = nearest_boundary_points(
                local[out], self._prepared.vertices, self.faces, 2.0 * self._grid.spacing)
            local[out] = np.einsum("bc,bcN->bN", barycentric, self._prepared.vertices[columns])
        return local

    def _interpolation(self, local):
        corners, weights = trilinear(self._grid, local)
        nodes = self._ids[tuple(corners.transpose(2, 0, 1))]
        if (nodes < 0).any():  # every cell holding a point inside or on the cage is kept
            raise RuntimeError("a point inside the cage fell in a cell without nodes")
        return nodes, weights

    @checked
    def coordinates(self, points, outside="raise", dtype=np.float64):
        """Harmonic coordinates of points: (k, n) dtype, non-negative, rows summing to 1.

        Parameters
        ----------
        points : (k, 3) float
        outside : str
            As :meth:`interpolation`.
        dtype : numpy dtype
            Of the result (computed in float64).

        Examples
        --------
        See :class:`HarmonicField`.
        """
        nodes, weights, cut, columns, values = self.sparse_rows(points, outside)
        result = np.zeros((len(nodes), len(self.vertices)), dtype=dtype)
        self._mixed(nodes, weights, result, np.flatnonzero(~cut))  # no (k, n) interpolation beside: a hand's peak
        result[np.flatnonzero(cut)[:, None], columns] = values  # into the zeros: no (c, n) block beside
        return result

    @checked
    def sparse_rows(self, points, outside="raise", inside=None):
        """Points' coordinates in two parts: interpolated from their 8 nodes where
        those place themselves exactly, else their own sparse pairs (:meth:`cut_pairs`).

        Parameters
        ----------
        points : (k, 3) float
        outside : str
            As :meth:`interpolation`.
        inside : (k,) bool, optional
            Points known inside the cage, its quads split any way (Bind's refusal): those
            away from the quads are not tested again (:func:`.inside.inside_or_on`).

        Returns
        -------
        nodes, weights : (k, 8) int and float
            :meth:`interpolation`.
        cut : (k,) bool
            The points whose coordinates are their own pairs, not the interpolation.
        columns, values : (c, K) int and float
            Those c points' pairs (:meth:`cut_pairs`).
        """
        # A Bind asks up to three times for the same points (two levels' rows; Automatic's
        # sample, every few of them; then the pairs' or exact storage's coordinates, chunk
        # by chunk, where two levels would not do): located and placed once, the rows of
        # the last set asked for kept (each caller gets copies to write into), a sample of
        # every s-th of its points or a run of them taken from them.
        key = (outside, points.shape, hashlib.blake2b(np.ascontiguousarray(points).tobytes(), digest_size=16).digest())
        if self._last_rows is not None and self._last_rows[0] != key and self._last_rows[0][0] == outside:
            taken = taken_slice(self._last_rows[2], points)
            if taken is not None:
                return taken_rows(self._last_rows[1], taken)
        if self._last_rows is None or self._last_rows[0] != key:
            self._last_rows = (key, self._located_rows(points, outside, inside), np.array(points, dtype=np.float64))
        return tuple(part.copy() for part in self._last_rows[1])

    def _located_rows(self, points, outside, inside):
        local = self._located(points, outside, inside)
        nodes, weights = self._interpolation(local)
        hidden = self._hidden(local, nodes)
        cut = self.cut(nodes) | hidden.any(axis=1)
        placed = local[cut] * self._prepared.scale + self._prepared.origin
        seen = _without(weights[cut], hidden[cut])
        # A batch of points at a time: their (c, n) interpolated rows were the cup's peak.
        columns = np.empty((len(placed), min(CUT_SUPPORT, len(self.vertices))), dtype=np.int64)
        values = np.empty(columns.shape)
        for start in range(0, len(placed), _CUT_POINTS):
            batch = slice(start, start + _CUT_POINTS)
            columns[batch], values[batch] = self.cut_pairs(placed[batch], nodes[cut][batch], seen[batch])
        return nodes, weights, cut, columns, values

    def cut(self, nodes, local=None):
        """Whether one of each point's nodes ((k, 8): :meth:`interpolation`) does not place
        itself exactly (a cell at the cage), or (given the points, ``local`` (k, 3) frame
        units) is hidden from it across a gap (:meth:`_hidden`): (k,) bool."""
        cut = ~self.node_exact[nodes].all(axis=1)
        return cut if local is None else cut | self._hidden(local, nodes).any(axis=1)

    def _hidden(self, local, nodes):
        """Which of each point's corners the cage hides from it (:func:`.cage_features.hidden_corners`)."""
        hidden = np.zeros(nodes.shape, dtype=bool)
        rows, frame = np.flatnonzero(~self.node_inside[nodes].all(axis=1)), self._prepared
        hidden[rows] = hidden_corners(local[rows], self._sources[nodes[rows]], frame.vertices, self.faces,
                                      lambda at: winding_numbers(frame, at * frame.scale + frame.origin) >= 0.5)
        return hidden

    def cut_pairs(self, points, nodes, weights, count=CUT_SUPPORT):
        """The coordinates of points in cut cells (:meth:`cut`), placing them exactly:
        their ``count`` largest interpolated coordinates reweighted by maximum entropy
        (:func:`.reproduction.reproduce_points`), non-negative and local. Where those
        do not span the point (every corner of its cell holds the values of the same
        few boundary triangles), the prior is the mix along the normal instead: the
        nearest boundary point's hat values and the coordinates of a point deeper along
        the line through both, the deeper point's cell placing itself exactly.

        Parameters
        ----------
        points : (c, 3) float
            Inside or on the cage (world units).
        nodes, weights : (c, 8) int and float
            Their :meth:`interpolation`, hidden corners (:meth:`_hidden`) weighing 0 (all
            of them, a part thinner than a cell between gaps: its prior its own walls').
        count : int

        Returns
        -------
        columns : (c, K) int
            Cage vertices, K = min(count, n).
        values : (c, K) float
            Non-negative, rows summing to 1.
        """
        local = self._prepared.local(points)
        rows = self._mixed(nodes, weights)
        alone = np.flatnonzero(np.sum(weights, axis=1) == 0.0)
        rows[alone] = _across_the_part(local[alone], self._prepared.vertices, self.faces, self._grid.spacing)
        columns, values, residual = placing_largest(rows, count, self._prepared.vertices, local)
        short = np.flatnonzero(residual > self._exact)
        if len(short):
            rows = self._along_the_normal(local[short], rows[short])
            columns[short], values[short], residual[short] = placing_largest(rows, count, self._prepared.vertices, local[short])
        shorter = residual[short] > self._exact
        if shorter.any():  # near an edge or corner of the cage: the nearest exact node widens the prior
            short, rows = short[shorter], rows[shorter]
            nearest, _ = _nearest_exact_nodes(self._grid, self._ids, self.node_exact, local[short])
            seen = ~hidden_from(local[short], node_positions(self._grid, self.node_indices[nearest]),
                                self._prepared.vertices, self.faces)  # not the other part's, across a gap
            rows[seen] += _WIDENING * self.node_rows(nearest[seen])
            columns[short], values[short], residual[short] = placing_largest(rows, count, self._prepared.vertices,
                                                                             local[short])
        shortest = residual[short] > self._exact
        if shortest.any():  # a thin wall or a thin part's tip: no exact node within reach
            short = short[shortest]
            prior = _across_the_part(local[short], self._prepared.vertices, self.faces, self._grid.spacing)
            across, across_values, across_residual = placing_largest(prior, count, self._prepared.vertices,
                                                                     local[short])
            better = (across_residual < residual[short]) & (prior.sum(axis=1) > 0.5)
            columns[short[better]], values[short[better]] = across[better], across_values[better]
        return columns, values

    def _mixed(self, nodes, weights, out=None, rows=None):
        """The interpolation of the nodes' coordinates: (c, n) float64, or into ``out``'s
        ``rows``; a block of rows at a time (no (c, n) temporaries beside; each row alone),
        each corner's term taken into one buffer."""
        out = np.zeros((len(nodes), len(self.vertices))) if out is None else out
        rows = np.arange(len(nodes)) if rows is None else rows
        step = max(1, _MIXED_ENTRIES // len(self.vertices))
        term = np.empty((min(step, len(rows)), len(self.vertices)))
        for start in range(0, len(rows), step):
            block = rows[start:start + step]
            mixed, taken = np.zeros((len(block), len(self.vertices))), term[:len(block)]
            for corner in range(nodes.shape[1]):
                self.node_rows(nodes[block, corner], taken)
                taken *= weights[block, corner, None]
                mixed += taken
            out[block] = mixed
        return out

    def _along_the_normal(self, local, rows):
        """Priors that span points near the cage ((c, 3), frame units): ``(1 - t) hat(p)
        + t coordinates(q)`` with p the nearest boundary point, q = p + depth (x - p) / |x - p|
        the first of a few depths whose cell places itself exactly, t = |x - p| / depth
        (so the prior places x). ``rows`` are kept where no depth is found."""
        vertices, spacing = self._prepared.vertices, self._grid.spacing
        columns, barycentric, distance = nearest_boundary_points(local, vertices, self.faces, 2.0 * spacing)
        nearest = np.einsum("bc,bcN->bN", barycentric, vertices[columns])
        hat = np.zeros_like(rows)
        np.add.at(hat, (np.arange(len(hat))[:, None], columns), barycentric)  # a padding column adds 0
        direction = (local - nearest) / np.where(distance > 0.0, distance, 1.0)[:, None]
        on = distance <= self._exact
        rows[on] = hat[on]
        pending = np.flatnonzero(~on)
        for cells in (1.0, 1.5, 2.0, 3.0, 4.0, 6.0):
            depth = distance[pending] + cells * spacing
            deeper = nearest[pending] + depth[:, None] * direction[pending]
            inside = np.flatnonzero(self._inside_or_on(deeper))  # and its own part's (no gap crossed)
            inside = inside[~hidden_from(local[pending[inside]], deeper[inside], vertices, self.faces)]
            nodes, weights = self._interpolation(deeper[inside])
            whole = ~self.cut(nodes, deeper[inside])
            found = inside[whole]
            t = (distance[pending[found]] / depth[found])[:, None]
            rows[pending[found]] = (1.0 - t) * hat[pending[found]] + t * self._mixed(nodes[whole], weights[whole])
            pending = np.delete(pending, found)
            if not len(pending):
                break
        return rows

    def _inside_or_on(self, local, inside=None):
        """Whether each point (frame units) is inside the cage or within the tolerance of it
        (:func:`.inside.inside_or_on`; ``inside`` as :meth:`sparse_rows`')."""
        return inside_or_on(self._prepared, local, self.faces, (self._grid, self._cell_inside, self._surface),
                            self._tolerance, inside)


def _nearest_exact_nodes(grid, ids, exact, local):
    """The nearest node that places itself exactly to each point ((c, 3), frame units),
    searched in growing blocks of nodes around it, up to 7 across: (rows (c,) int,
    found (c,) bool). A point still searching at reach r found nothing nearer, so only
    the block's shell is looked at, one offset at a time (memory: a few (c,) arrays)."""
    nearest, found = np.zeros(len(local), dtype=np.int64), np.zeros(len(local), dtype=bool)
    centre = np.rint((local - grid.origin) / grid.spacing).astype(np.int64)
    top = np.array(grid.shape) - 1
    for reach in (1, 2, 3):
        pending = np.flatnonzero(~found)
        if not len(pending):
            break
        here, there = centre[pending], local[pending]
        best = np.full(len(pending), np.inf)
        steps = range(-reach, reach + 1)
        for offset in itertools.product(steps, steps, steps):  # first best in this order
            if reach > 1 and max(map(abs, offset)) < reach:  # searched at the reach before
                continue
            nodes = (here + offset).clip(0, top)
            rows = ids[nodes[:, 0], nodes[:, 1], nodes[:, 2]]
            if offset == (-reach,) * 3:  # where none is found: as a search of the whole block
                nearest[pending] = rows
            gap = np.einsum("cN,cN->c", nodes * grid.spacing + grid.origin - there,
                            nodes * grid.spacing + grid.origin - there)
            better = np.where(rows >= 0, exact[rows.clip(0)], False) & (gap < best)
            best[better] = gap[better]
            nearest[pending[better]] = rows[better]
        found[pending] = np.isfinite(best)
    return nearest, found
