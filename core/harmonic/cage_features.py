"""What a grid must resolve in a cage: the narrowest gap between parts that are not
neighbours on the cage (fingers, legs side by side) and the thinnest part (a tail, a
wall), measured from the cage alone, and the resolution Bind takes from them.

From each triangle's centroid a ray leaves along the outward normal (the gap: the first
triangle it meets that shares no vertex with it) and one along the inward normal (the
thickness: the first triangle it meets).

What the solve needs, measured (the hand and quadruped fixtures, 16 to 64 cells): parts
closer than about one cell pull each other (a leg bent 60 degrees moved the other by
9e-3 of the diagonal at 0.95 cells across their gap, 3e-2 at 0.47; the fingers by 4e-2
at 0.5), while from 1.03 cells on nothing leaks (below 1e-6). Thin parts need no cells
of their own: the cut cells' nodes hold them (the tail at 0.24 cells across moved the
rest by 4e-15). So :func:`automatic_resolution` refines the whole grid until the
narrowest gap is ``CELLS_ACROSS_GAP`` cells across, and reports the thinnest part only.
"""

from dataclasses import dataclass

import numpy as np

from .boundary_values import segment_crossings

__all__ = ["narrowest_gap_and_thinnest_part", "resolving_resolution", "automatic_resolution", "GridChoice",
           "CELLS_ACROSS_GAP", "AUTOMATIC_FLOOR", "AUTOMATIC_CEILING"]

# Cells across the narrowest gap an automatic grid gives (leaks begin below about 1).
CELLS_ACROSS_GAP = 1.25
# Automatic grids: the cells along the longest side that every cage gets (the default
# before the gaps were measured), and the most a gap can ask for: the solve's time grows
# faster than the cube (the hand's cage, core alone: 1.5 s at 59, 8 to 10 s at 96 and 112,
# 22 s at 128, 147 s at 160), and at 112 it is about Mesh Deform p6's Bind of the cup.
AUTOMATIC_FLOOR, AUTOMATIC_CEILING = 48, 112

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
    and what it resolves there: ``gap_cells`` (cells across the narrowest gap) and
    ``thinnest_cells`` (across the thinnest part), inf where none is narrower than the
    rays looked (``CELLS_ACROSS_GAP`` cells at the floor); ``capped`` where the gap asked
    for more than the ceiling (the memory, or a Resolution set by hand) allowed."""

    resolution: int
    gap_cells: float
    thinnest_cells: float
    capped: bool = False

    def words(self):
        """What the grid resolved, in the panel's words: str."""
        def across(cells, what):
            return f"{what} {cells:.1f} cells across" if np.isfinite(cells) else None
        parts = [across(self.gap_cells, "narrowest gap"), across(self.thinnest_cells, "thinnest part")]
        said = ", ".join(part for part in parts if part) or f"no gap or part under {CELLS_ACROSS_GAP:g} cells"
        return said + (f" (under {CELLS_ACROSS_GAP:g}: parts this close may pull each other)" if self.capped else "")


def automatic_resolution(vertices, triangles, ceiling=AUTOMATIC_CEILING, floor=AUTOMATIC_FLOOR):
    """The resolution that puts ``CELLS_ACROSS_GAP`` cells across the cage's narrowest
    gap, between ``floor`` and ``ceiling``: :class:`GridChoice`.

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
    floor = min(floor, ceiling)
    gap, thickness = narrowest_gap_and_thinnest_part(vertices, triangles,
                                                     reach=CELLS_ACROSS_GAP * longest / floor)
    wanted = int(np.ceil(CELLS_ACROSS_GAP * longest / gap)) if gap > 0.0 else ceiling + 1
    resolution = int(min(max(floor, wanted), ceiling))
    cell = longest / resolution
    return GridChoice(resolution, gap / cell, thickness / cell, capped=wanted > ceiling)
