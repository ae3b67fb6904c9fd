"""Parts of a cage closer than a grid cell: what the grid does about them, and what it
reports. The narrowest gap between parts that are not neighbours on the cage (fingers,
legs side by side) and the thinnest part (a tail, a wall) are measured from the cage
alone: from each triangle's centroid a ray leaves along the outward normal (the gap: the
first triangle it meets that shares no vertex with it) and one along the inward normal
(the thickness: the first triangle it meets).

A grid coarser than a gap would join the parts on each side of it twice over: two inside
nodes whose grid edge crosses the gap would be neighbours in the Laplacian, and a point
beside the gap would be interpolated from the other part's nodes (a leg bent 60 degrees
moved the other by 9e-3 of the diagonal at 0.95 cells across their gap; two prongs
closer than a cell, 4e-2 whatever the grid). So the grid parts them itself
(docs/MATH.md, "Parts closer than a cell"): :func:`nodes_across_gaps` are not solved
but hold their own part's boundary values, and :func:`hidden_corners` leaves out of a
point's interpolation the corners whose values come from where the cage hides (the
other part). Thin parts need no cells of their own either (the cut cells' points hold
them: the quadruped's tail at 0.24 cells across moved the rest by 4e-15), so every cage
gets :func:`automatic_resolution`'s floor, and the panel reports what it measured.
"""

from dataclasses import dataclass

import numpy as np

from ..base.grid import node_positions
from .boundary_values import nearest_boundary_points, segment_crossings
from .solve import NEAREST_CROSSING

__all__ = ["narrowest_gap_and_thinnest_part", "resolving_resolution", "automatic_resolution", "GridChoice",
           "nodes_across_gaps", "hidden_corners", "hidden_from", "REPORTED_GAP_CELLS", "AUTOMATIC_FLOOR"]

# Gaps and parts narrower than this many cells are reported (the panel: what the grid met).
REPORTED_GAP_CELLS = 1.25
# Automatic grids: the cells along the longest side every cage gets (finer ones cost more
# than the cube: the hand's cage, core alone, 1.5 s at 59, 8 to 10 s at 96 and 112, 22 s at
# 128, 147 s at 160; a gap needs none, the grid parts it, and the joints crease no less).
AUTOMATIC_FLOOR = 48
# A segment's crossing this near one of its ends (of its length) is that end on the cage,
# not the cage between: a boundary point is seen from inside its own part, and a point
# within the tolerance of a face is on it.
_ON_THE_CAGE = 1e-4
_MOST_CROSSINGS = 4  # of a segment looked at (a gap between two parts: two)

_START = 1e-9  # of the cage's size: the rays start this far off their triangle
_HOPS = 4  # neighbours a gap's ray passes before it gives up


def _unit_normals(vertices, triangles):
    a, b, c = (vertices[triangles[:, corner]] for corner in range(3))
    normals = np.cross(b - a, c - a)
    return (a + b + c) / 3.0, normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)


def narrowest_gap_and_thinnest_part(vertices, triangles, reach=None):
    """The narrowest gap between non-neighbouring parts of the cage and its thinnest part
    (world units; inf where no ray finds one).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward oriented, closed.
    reach : float, optional
        How far the rays look (world units; default twice the cage's diagonal): gaps and
        parts wider than this read inf. Short rays meet few triangles' boxes: fast.

    Returns
    -------
    gap, thickness : float

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.cage_features import narrowest_gap_and_thinnest_part
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, triangles = icosphere(1)
    >>> gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles)
    >>> gap, bool(1.8 < thickness < 2.0)  # no other part; about the sphere's diameter
    (inf, True)
    """
    vertices, triangles = np.asarray(vertices, dtype=np.float64), np.asarray(triangles)
    centres, normals = _unit_normals(vertices, triangles)
    size = float(np.linalg.norm(np.ptp(vertices, axis=0)))
    reach = 2.0 * size if reach is None else float(reach)
    inward, _, _ = segment_crossings(centres - _START * size * normals, -reach * normals, vertices, triangles)
    thickness = float((inward * reach).min(initial=np.inf))
    own = np.sort(triangles, axis=1)
    starts, travelled = centres + _START * size * normals, np.zeros(len(centres))
    gap = np.inf
    pending = np.arange(len(centres))
    for _ in range(_HOPS):
        fraction, columns, _ = segment_crossings(starts[pending], reach * normals[pending], vertices, triangles)
        hit = np.isfinite(fraction)
        pending, fraction, columns = pending[hit], fraction[hit], columns[hit]
        neighbour = (columns[:, :, None] == own[pending][:, None, :]).any(axis=(1, 2))
        distance = travelled[pending] + fraction * reach
        gap = min(gap, float(distance[~neighbour].min(initial=np.inf)))
        pending, distance = pending[neighbour], distance[neighbour]
        starts[pending] = centres[pending] + (distance + _START * size)[:, None] * normals[pending]
        travelled[pending] = distance + _START * size
        if not len(pending):
            break
    return gap, thickness


def resolving_resolution(vertices, triangles, cells_across=2.0):
    """Cells along the cage's longest side that put ``cells_across`` cells across its
    narrowest gap and its thinnest part (:func:`narrowest_gap_and_thinnest_part`): int.

    Examples
    --------
    >>> from gencoords.harmonic.cage_features import resolving_resolution
    >>> from gencoords.cages.shapes import icosphere
    >>> resolving_resolution(*icosphere(1))  # a ball: 2 cells across its diameter
    3
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles)
    smallest = min(gap, thickness)
    longest = float(np.ptp(vertices, axis=0).max())
    return int(np.ceil(cells_across * longest / smallest)) if np.isfinite(smallest) else 2


@dataclass(frozen=True)
class GridChoice:
    """The grid an automatic Bind takes: ``resolution`` (cells along the longest side),
    and what it meets there: ``gap_cells`` (cells across the narrowest gap) and
    ``thinnest_cells`` (across the thinnest part), inf where none is narrower than
    ``REPORTED_GAP_CELLS`` cells; ``capped`` where the memory free allowed fewer cells than
    the floor."""

    resolution: int
    gap_cells: float
    thinnest_cells: float
    capped: bool = False

    def words(self):
        """What the grid met, in the panel's words: str."""
        def across(cells, what):
            return f"{what} {cells:.1f} cells across" if np.isfinite(cells) else None
        parts = [across(self.gap_cells, "narrowest gap"), across(self.thinnest_cells, "thinnest part")]
        said = ", ".join(part for part in parts if part) or f"no gap or part under {REPORTED_GAP_CELLS:g} cells"
        return said + (f" (fewer cells than {AUTOMATIC_FLOOR}: the memory free)" if self.capped else "")


def automatic_resolution(vertices, triangles, ceiling=AUTOMATIC_FLOOR, floor=AUTOMATIC_FLOOR):
    """The automatic grid, ``floor`` cells along the longest side (fewer where ``ceiling``,
    the memory's limit, is lower), and the gaps and parts narrower than
    ``REPORTED_GAP_CELLS`` cells it meets: :class:`GridChoice`. Parts closer than a cell
    are parted by the grid itself (:func:`nodes_across_gaps`, :func:`hidden_corners`).

    Parameters
    ----------
    vertices : (n, 3) float
    triangles : (m, 3) int
        Outward oriented, closed.
    ceiling : int
        The most cells it may take (the memory's limit, where lower than the default).

    Examples
    --------
    >>> from gencoords.harmonic.cage_features import automatic_resolution
    >>> from gencoords.cages.shapes import icosphere
    >>> automatic_resolution(*icosphere(1))  # one ball: the floor, nothing narrow
    GridChoice(resolution=48, gap_cells=inf, thinnest_cells=inf, capped=False)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    longest = float(np.ptp(vertices, axis=0).max())
    resolution = int(min(floor, ceiling))
    cell = longest / resolution
    gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles, reach=REPORTED_GAP_CELLS * cell)
    return GridChoice(resolution, gap / cell, thickness / cell, capped=ceiling < floor)


def hidden_from(starts, ends, vertices, faces, end_share=_ON_THE_CAGE, inside=None):
    """Whether the cage lies between each start and end: (s,) bool.

    Without ``inside``: whether the segment meets the cage short of its end (a crossing
    within ``end_share`` of the segment from the end, an end on the cage, does not
    count; nor one within ``_ON_THE_CAGE`` of a start on the cage). With ``inside``
    ((m, 3) -> (m,) bool, inside or on the cage): whether a stretch of the segment
    between its crossings lies outside the cage, so that ends on the cage, and a segment
    along a face through a crease, are judged by where the segment runs.

    Parameters
    ----------
    starts, ends : (s, 3) float
    vertices : (n, 3) float
    faces : (m, w) int
        Triangles, or polygons (a triangle's fourth -1; a quad its bilinear patch).
    end_share : float
    inside : callable, optional

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.cage_features import hidden_from
    >>> from gencoords.cages.shapes import icosphere
    >>> vertices, triangles = icosphere(2)
    >>> hidden_from(np.zeros((2, 3)), np.array([[0.5, 0, 0], [3.0, 0, 0]]), vertices, triangles).tolist()
    [False, True]
    """
    starts, ends = np.asarray(starts, dtype=np.float64), np.asarray(ends, dtype=np.float64)
    steps = ends - starts
    forward, _, _ = segment_crossings(starts, steps, vertices, faces)
    if inside is None:
        return (forward > _ON_THE_CAGE) & (forward < 1.0 - end_share)
    # Each segment's crossings in turn (a few at most), then the middle of each stretch
    # between them: outside the cage, the segment leaves it there.
    hidden = np.zeros(len(starts), dtype=bool)
    met = np.flatnonzero(forward < 1.0 - end_share)
    last, crossing = np.zeros(len(met)), forward[met]
    for _ in range(_MOST_CROSSINGS):
        if not len(met):
            break
        middle = 0.5 * (last + np.minimum(crossing, 1.0))
        long = np.minimum(crossing, 1.0) - last > 2.0 * _ON_THE_CAGE
        out = long & ~inside(starts[met] + middle[:, None] * steps[met])
        hidden[met[out]] = True
        going = ~out & (crossing < 1.0 - end_share)
        met, last = met[going], crossing[going] + _ON_THE_CAGE
        found, _, _ = segment_crossings(starts[met] + last[:, None] * steps[met], (1.0 - last)[:, None] * steps[met],
                                        vertices, faces)
        crossing = last + found * (1.0 - last)
    return hidden


def nodes_across_gaps(grid, indices, ids, inside, solved, near_surface, vertices, faces):
    """Solved grid nodes whose edge to another inside node crosses the cage (two parts
    closer than a cell, or one folded back): (p,) int, sorted. Left solved, the Laplacian
    would join the parts through that edge (or the other node's values would: a node on
    a thin part's far side).

    Parameters
    ----------
    grid : gencoords.base.grid.Grid
    indices : (g, 3) int
        The kept nodes' grid indices.
    ids : (x, y, z) int
        Each grid node's row among them (-1: not kept).
    inside, solved, near_surface : (g,) bool
        The nodes inside the cage, those solved for, and the corners of cells the surface
        may cross (the only ones whose edges can cross it).
    vertices : (n, 3) float
        The cage in the grid's frame.
    faces : (m, w) int
    """
    candidates = np.flatnonzero(inside & near_surface)
    found = [np.zeros(0, dtype=np.int64)]
    for step in np.eye(3, dtype=np.int64):
        there = indices[candidates] + step
        within = (there < np.array(grid.shape)).all(axis=1)
        here, other = candidates[within], ids[tuple(there[within].T)]
        pair = other >= 0
        here, other = here[pair], other[pair]
        pair = inside[other] & near_surface[other] & (solved[here] | solved[other])
        here, other = here[pair], other[pair]
        # From the solved end: the other may lie on the cage (within NEAREST_CROSSING of a
        # cell), where its own face's crossing is no gap.
        start, end = np.where(solved[here], here, other), np.where(solved[here], other, here)
        crossed = hidden_from(node_positions(grid, indices[start]), node_positions(grid, indices[end]), vertices,
                              faces, end_share=NEAREST_CROSSING)
        found += [here[crossed], other[crossed]]
    found = np.unique(np.concatenate(found))
    return found[solved[found]]


def hidden_corners(points, corner_sources, vertices, faces, inside=None):
    """Which corners of each point's cell hold values from where the cage hides from the
    point (the other part, across a gap): (k, c) bool. Each corner's values come from a
    place: a solved node's own, another node's nearest boundary point (seen from inside
    its own part); the corner is hidden where the cage lies between that place and the
    point. (Only where the point's own part is thinner than a cell or closer than a cell
    to another can this happen; the caller asks in the cells at the cage.)

    Parameters
    ----------
    points : (k, 3) float
    corner_sources : (k, c, 3) float
        Where each corner's values come from.
    vertices : (n, 3) float
    faces : (m, w) int
    inside : callable, optional
        As :func:`hidden_from`'s (a point on the cage).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.cage_features import hidden_corners
    >>> from gencoords.cages.shapes import octahedron
    >>> vertices, faces = octahedron()
    >>> sources = np.array([[[0.5, 0.5, 0.0], [0.0, 0.0, 0.2], [2.0, 0.0, 0.0]]])  # on the cage, inside, beyond
    >>> hidden_corners(np.zeros((1, 3)), sources, vertices, faces).tolist()
    [[False, False, True]]
    """
    points, corner_sources = np.asarray(points, dtype=np.float64), np.asarray(corner_sources, dtype=np.float64)
    count = corner_sources.shape[1]
    hidden = hidden_from(np.repeat(points, count, axis=0), corner_sources.reshape(-1, 3), vertices, faces,
                         inside=inside)
    return hidden.reshape(len(points), count)


def _without(weights, hidden):
    """Interpolation weights ((c, 8)) without the ``hidden`` corners, renormalised: rows
    with none hidden as they were; rows with every corner hidden, zeros."""
    weights = np.array(weights, dtype=np.float64)
    rows = np.flatnonzero(hidden.any(axis=1))
    kept = np.where(hidden[rows], 0.0, weights[rows])
    total = kept.sum(axis=1)
    weights[rows] = kept / np.where(total > 0.0, total, 1.0)[:, None]
    return weights


def _across_the_part(local, vertices, faces, spacing):
    """Priors that place points near the cage ((c, 3), frame units) exactly: the mix of
    the hat values at the nearest boundary point p and at the first crossing q of the ray
    from p through the point, ``(|q - x| hat(p) + |x - p| hat(q)) / |q - p|``, non-negative
    and held by the part's own walls (a thin wall, a thin part's tip: their cells hold no
    node placing itself). Returns (c, n) float (rows where no crossing is found: 0)."""
    columns, barycentric, distance = nearest_boundary_points(local, vertices, faces, 2.0 * spacing)
    nearest = np.einsum("bc,bcN->bN", barycentric, vertices[columns])
    direction = (local - nearest) / np.where(distance > 0.0, distance, 1.0)[:, None]
    reach = 2.0 * float(np.linalg.norm(np.ptp(vertices, axis=0)))
    fraction, far_columns, far_barycentric = segment_crossings(local, reach * direction, vertices, faces)
    found = np.isfinite(fraction) & (distance > 0.0)
    t = np.where(found, distance / np.where(found, distance + fraction * reach, 1.0), 0.0)[:, None]
    rows = np.zeros((len(local), len(vertices)))
    np.add.at(rows, (np.arange(len(local))[:, None], columns), np.where(found[:, None], (1.0 - t) * barycentric, 0.0))
    np.add.at(rows, (np.arange(len(local))[:, None], far_columns), np.where(found[:, None], t * far_barycentric, 0.0))
    return rows
