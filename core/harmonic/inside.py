"""Whether points are inside a harmonic field's cage or on it, its quads their bilinear
patches (:func:`.boundary_values.between_split_and_patch`), looked up on the field's grid;
the points a test on the quads' triangles found inside taken as they are away from the
quads (:func:`in_quad_boxes`)."""

import numpy as np

from ..construction.boundary import inside_by_grid
from .boundary_values import boxed_pairs, between_split_and_patch, nearest_boundary_points

__all__ = ["inside_or_on", "in_quad_boxes"]


def inside_or_on(prepared, local, faces, lookup, tolerance, inside=None):
    """Whether each point is inside the cage or within ``tolerance`` of it: (k,) bool.

    Parameters
    ----------
    prepared : PreparedCage
        The cage's triangles (a quad's two: ``quad_cage.fan_split``'s) in their frame.
    local : (k, 3) float
        Points in that frame.
    faces : (m, 3) or (m, 4) int
        Triangles, or polygons (a triangle's fourth -1): a quad is its patch.
    lookup : (grid, cell_inside, surface)
        As ``construction.boundary.inside_lookup``'s, the cells inside as the patches
        have them, the surface's cells those of the quads' boxes.
    tolerance : float
        In the frame.
    inside : (k,) bool, optional
        Points known to be inside the cage, its quads split into triangles any way
        (winding number at least 1/2: Bind's refusal, ``boundary.outside_points``): those
        outside every quad's box grown by ``tolerance`` (:func:`in_quad_boxes`) are
        inside here too and are not tested again. The result is the same as without it.
    """
    result = np.ones(len(local), dtype=bool)
    tested = (np.arange(len(local)) if inside is None
              else np.flatnonzero(~inside | in_quad_boxes(local, prepared.vertices, faces, tolerance)))
    local = local[tested]
    found, crossed = inside_by_grid(prepared, local, *lookup)
    if faces.shape[1] == 4:  # counted on the quads' triangles: the patches decide between
        found[crossed] ^= between_split_and_patch(local[crossed], prepared.vertices, faces)
    near = crossed[~found[crossed]]
    if len(near):
        _, _, distance = nearest_boundary_points(local[near], prepared.vertices, faces, tolerance)
        found[near] = distance <= tolerance
    result[tested] = found
    return result


def in_quad_boxes(positions, vertices, polygons, reach):
    """Whether each position lies in a quad's box grown by ``reach``: (b,) bool (faces of
    3 columns: none).

    Outside every one, a position is farther than ``reach`` from each quad's patch and
    from both splits of it into two triangles (all three lie in its corners' hull), so
    the closed surfaces a cage makes with its quads taken either way wind around it
    alike, and :func:`between_split_and_patch` (which looks only in the boxes) flips it
    for none: it is inside the patches' cage if it is inside the triangles' (to
    rounding, which reaches only points nearer to the cage than the tolerance, and
    :func:`inside_or_on` takes those as on it)."""
    quads = polygons[polygons[:, 3] >= 0] if polygons.shape[1] == 4 else polygons[:0]
    found = np.zeros(len(positions), dtype=bool)
    if len(quads):
        found[boxed_pairs(positions, vertices[quads], reach)[0]] = True
    return found
