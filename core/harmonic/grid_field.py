"""Solving harmonic coordinates on a grid: :func:`harmonic_field` (the grid fitted to the
cage, its nodes sorted into solved, boundary and outside ones, the Shortley-Weller
system solved, nodes beside the cage reweighted to place themselves) and
:func:`harmonic_coordinates` (a field's lookup, in one call). The result:
:class:`~gencoords.harmonic.field.HarmonicField`.
"""

import itertools

import numpy as np

from ..base.arrays import in_row_blocks
from ..base.errors import CageError
from ..base.grid import fit_grid, inside_nodes, node_positions, surface_cells
from ..base.inputs import checked
from ..base.mixed_rows import MixedRows
from ..construction.quad_cage import fan_split, validate_polygons
from ..construction.validation import DEFAULT_TOLERANCE, validate_cage
from . import field
from .cage_features import hidden_from, nodes_across_gaps
from .boundary_values import between_split_and_patch, nearest_boundary_points
from .field import CUT_SUPPORT, DEFAULT_RESOLUTION, HarmonicField, _WIDENING, _nearest_exact_nodes
from .interpolation import CORNERS
from .reproduction import batch_rows, placing_largest, reproduce_points
from .solve import NEAREST_CROSSING, SOLVER_TOLERANCE, boundary_rhs, solved_rows

__all__ = ["harmonic_field", "harmonic_quad_field", "harmonic_coordinates"]

# Newton steps for widened Dirichlet nodes: those that can be reached are within a dozen;
# the others (beyond a convex part of the cage) would spend the full count for nothing.
_WIDENED_ITERATIONS = 12
_EXACT = 1e-12  # of the cage's size: a node's reweighted coordinates place it exactly
_HULL_ROUNDING = 1e-6  # of a cell: a node beyond the hull by less is still tried
_BETWEEN_NODES = 1 << 16  # grid nodes tested between a quad's split and its patch at a time
_PRIOR_ENTRIES = 1 << 18  # (node, cage vertex) entries of the Dirichlet nodes' priors at a time


def _cell_corners_any(cells):
    """Nodes that are a corner of at least one marked cell: (x+1, y+1, z+1) bool."""
    nodes = np.zeros(tuple(size + 1 for size in cells.shape), dtype=bool)
    for a, b, c in CORNERS:
        nodes[a:a + cells.shape[0], b:b + cells.shape[1], c:c + cells.shape[2]] |= cells
    return nodes


def _cells_with_a_corner(nodes):
    """Cells with at least one marked corner: (x-1, y-1, z-1) bool."""
    x, y, z = (size - 1 for size in nodes.shape)
    cells = np.zeros((x, y, z), dtype=bool)
    for a, b, c in CORNERS:
        cells |= nodes[a:a + x, b:b + y, c:c + z]
    return cells


def _grid_nodes(grid, corners, tolerance, vertices, polygons=None):
    """The kept nodes and what is known of them before the solve: dict of arrays. With
    ``polygons`` (``corners`` their :func:`fan_split`'s) a node between a quad's two
    triangles and its patch is inside or outside as the patch has it."""
    inside = inside_nodes(grid, corners)
    if polygons is not None:
        if (polygons[:, -1] >= 0).any():  # a block of nodes at a time: every node's position was 2 x 24 bytes
            between, = in_row_blocks(lambda nodes: (between_split_and_patch(
                node_positions(grid, np.column_stack(np.unravel_index(nodes, grid.shape))), vertices, polygons),),
                _BETWEEN_NODES, np.arange(inside.size))
            inside ^= between.reshape(grid.shape)
        corners = vertices[np.where(polygons >= 0, polygons, polygons[:, :1])]  # a quad's box, not its halves'
    surface = surface_cells(grid, corners, tolerance)
    kept = _cell_corners_any(surface | _cells_with_a_corner(inside))
    ids = np.full(grid.shape, -1, dtype=np.int64)
    indices = np.argwhere(kept)
    ids[kept] = np.arange(len(indices))
    near_surface = _cell_corners_any(surface)[kept]
    return dict(ids=ids, surface=surface, indices=indices, inside=inside[kept], near_surface=near_surface,
                tolerance=tolerance, cell_inside=inside[:-1, :-1, :-1])


def _boundary_nodes(grid, parts, vertices, faces):
    """The Dirichlet nodes and their values: the kept nodes outside the cage and those
    inside nearer to it than ``solve.NEAREST_CROSSING`` of a cell (on it, to rounding:
    a crossing there is ambiguous and its row's weight 1 / theta unbounded) hold their
    nearest boundary point's hat values. The other inside nodes are solved for; the
    solve meets the cage where the grid's edges cross it (``solve.boundary_rhs``).

    Returns
    -------
    measured : (b,) int
        The nodes measured: those outside and those at cells the surface may cross.
    columns, values : (b, w) int, (b, w) float
        Their nearest boundary point's hat values (w: the faces' width; an inside node
        farther than ``NEAREST_CROSSING``, solved: zeros, never read).
    solved : (g,) bool
    """
    measured = np.flatnonzero(~parts["inside"] | parts["near_surface"])
    positions = node_positions(grid, parts["indices"][measured])
    inside, near = parts["inside"][measured], NEAREST_CROSSING * grid.spacing
    columns = np.zeros((len(measured), faces.shape[1]), dtype=np.int64)
    values, distance = np.zeros(columns.shape), np.empty(len(measured))
    columns[~inside], values[~inside], distance[~inside] = nearest_boundary_points(
        positions[~inside], vertices, faces, 1.75 * grid.spacing)
    # An inside node is a Dirichlet node only nearer than ``near``: looked for no farther
    # (the others are solved; their hat values are never read).
    columns[inside], values[inside], distance[inside] = nearest_boundary_points(
        positions[inside], vertices, faces, near, widen=False)
    solved = parts["inside"].copy()
    solved[measured[distance < near]] = False
    # Parts closer than a cell: a node whose edge crosses the gap holds its nearest
    # boundary point's values, which lie on its own part (the cage is between it and
    # every other part), instead of being the other part's neighbour in the Laplacian.
    across = nodes_across_gaps(grid, parts["indices"], parts["ids"], parts["inside"], solved, parts["near_surface"],
                               vertices, faces)
    at = np.searchsorted(measured, across)
    columns[at], values[at], _ = nearest_boundary_points(positions[at], vertices, faces, 1.75 * grid.spacing)
    solved[across] = False
    return measured, columns, values, solved


def _beyond_the_hull(positions, vertices, triangles, margin):
    """Whether each position ((p, 3)) lies farther than ``margin`` beyond the convex hull
    of ``vertices`` along one of the triangles' normals: (p,) bool. No non-negative
    weights of the vertices place such a position to within ``margin`` (the hull's
    support along a normal bounds every point they place), so it need not be tried."""
    normals = np.cross(vertices[triangles[:, 1]] - vertices[triangles[:, 0]],
                       vertices[triangles[:, 2]] - vertices[triangles[:, 0]])
    lengths = np.linalg.norm(normals, axis=1)
    normals = normals[lengths > 0.0] / lengths[lengths > 0.0, None]
    support = (vertices @ normals.T).max(axis=0, initial=-np.inf)
    beyond = np.zeros(len(positions), dtype=bool)
    step = max(1, _PRIOR_ENTRIES // max(1, len(normals)))
    for start in range(0, len(positions), step):
        beyond[start:start + step] = (positions[start:start + step] @ normals.T > support + margin).any(axis=1)
    return beyond


def _nearest_seen(grid, ids, exact, positions, targets, sources, vertices, faces):
    """For each node of ``targets``, the nearest exact node within 3 cells that sees the
    node's boundary point (``sources`` (t, 3): no gap between them): (rows (t,) int,
    found (t,) bool)."""
    offsets = np.array(list(itertools.product(range(-3, 4), repeat=3)))
    offsets = offsets[np.argsort((offsets ** 2).sum(axis=1), kind="stable")]
    centre = np.rint((positions[targets] - grid.origin) / grid.spacing).astype(np.int64)
    rows, found = np.zeros(len(targets), dtype=np.int64), np.zeros(len(targets), dtype=bool)
    for offset in offsets:  # nearest offsets first: the first seen exact node is kept
        pending = np.flatnonzero(~found)
        if not len(pending):
            break
        nodes = (centre[pending] + offset).clip(0, np.array(grid.shape) - 1)
        there = ids[tuple(nodes.T)]
        usable = np.flatnonzero(there >= 0)
        usable = usable[exact[there[usable]]]
        seen = ~hidden_from(positions[there[usable]], sources[pending[usable]], vertices, faces)
        rows[pending[usable[seen]]], found[pending[usable[seen]]] = there[usable[seen]], True
    return rows, found


def _placing_exactly(coordinates, solved, positions, vertices, triangles, grid, ids, within, sources, faces):
    """The nodes' coordinates (:class:`~gencoords.base.mixed_rows.MixedRows`, (g, n): the
    solved ones dense) reweighted in place to place their ``positions`` ((g, 3)) exactly
    (:mod:`.reproduction`), and which now do: (g,) bool.

    The grid places a node only to within a fraction of a cell (the Dirichlet nodes hold
    their nearest boundary point's values). A solved node lies inside the cage, in the
    convex hull of the cage vertices its coordinates weigh (all of them), so the
    reweighting reaches it. A Dirichlet node's hat values weigh one triangle: widened by
    the nearest solved node's coordinates (their CUT_SUPPORT largest: local), they reach
    it where it is inside the cage or in a hollow of it; elsewhere (beyond a convex part
    of the cage no non-negative weights reach) it keeps its hat values: one beyond the
    cage's convex hull is not tried (the cup's outer wall: half its Dirichlet nodes)."""
    exact = solved.copy()
    # Reweighted in place, a few batches at a time: a copy of every solved row and its
    # result beside the field were the cup's peak (2 x 36 MB).
    inside = np.flatnonzero(solved)
    step = max(1, _PRIOR_ENTRIES // len(vertices) // batch_rows(len(vertices))) * batch_rows(len(vertices))
    dense = coordinates.dense
    for start in range(0, len(inside), step):
        rows = inside[start:start + step]
        held = coordinates.row_of[rows]
        dense[held], residual = reproduce_points(None, dense[held], vertices, positions[rows])
        exact[rows] = residual <= within
    others = np.flatnonzero(~solved)
    # Beyond the hull by more than ``within`` and rounding: never reached, whatever the prior.
    others = others[~_beyond_the_hull(positions[others], vertices, triangles, within + _HULL_ROUNDING * grid.spacing)]
    nearest, found = _nearest_exact_nodes(grid, ids, exact, positions[others])
    others, nearest = others[found], nearest[found]
    # A widening node across a gap would bring the other part: the nearest one seen instead.
    hidden = np.flatnonzero(hidden_from(positions[nearest], sources[others], vertices, faces))
    nearest[hidden], found = _nearest_seen(grid, ids, exact, positions, others[hidden], sources[others[hidden]],
                                           vertices, faces)
    kept = np.ones(len(others), dtype=bool)
    kept[hidden[~found]] = False
    others, nearest = others[kept], nearest[kept]
    # A batch of dense priors at a time (the cup: 25,000 nodes x 322 vertices were 64 MB,
    # twice); a prior reads solved nodes and its own, which no other batch writes.
    step = max(1, _PRIOR_ENTRIES // len(vertices))
    for start in range(0, len(others), step):
        batch, widening = others[start:start + step], nearest[start:start + step]
        prior = coordinates.rows(widening)
        prior *= _WIDENING
        prior += coordinates.rows(batch)
        columns, values, residual = placing_largest(prior, CUT_SUPPORT, vertices, positions[batch], _WIDENED_ITERATIONS)
        del prior
        reached = residual <= within
        coordinates.set_pairs(batch[reached], columns[reached], values[reached])
        exact[batch[reached]] = True
    return exact


@checked
def harmonic_field(vertices, faces, resolution=DEFAULT_RESOLUTION, tolerance=DEFAULT_TOLERANCE, progress=None,
                   workers=None, solver_tolerance=SOLVER_TOLERANCE):
    """Solve harmonic coordinates on a grid fitted to a closed 3D triangle cage.

    A 7-point Laplacian on cubic cells, ``resolution`` of them along the longest side of
    the cage's box, meeting the cage where the grid's edges cross it (Shortley-Weller):
    the nodes inside the cage are the unknowns, the crossings hold the cage's
    piecewise-linear hat values. Every coordinate is non-negative and each row sums to 1
    (the discrete maximum principle), and the coordinates place every point exactly
    (linear precision); docs/MATH.md gives the figures measured.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (m, 3) int
        Triangles, counter-clockwise seen from outside (quads:
        :func:`gencoords.cages.triangulate_quads`). Any closed cage, convex or not.
    resolution : int
        Cells along the longest side of the cage's box (2 to 1024, None: 64; the cost grows as
        its cube). Like Mesh Deform's Precision, but the cells are cubes, so a thin limb
        gets as many cells across as its thickness allows.
    tolerance : float
        Relative to the cage's box diagonal: points this close to the cage count as on it.
    progress : callable, optional
        ``progress(fraction)`` as the solve advances; an exception it raises (a cancel)
        stops the computation (and the workers) and propagates.
    workers : int or None
        Processes for the iterative solver (the cage vertices' columns are independent):
        ``1`` this process; ``None`` as many as the cores allow when the solve is long
        enough to repay starting them (about a second of work each), falling back to this
        process with a :class:`gencoords.WorkerWarning` where they cannot start (an
        explicit count raises :class:`gencoords.WorkerError`). The result is the same
        whatever the number. The direct solver, chosen where it is cheaper (a body with
        limbs), runs in this process and starts none.
    solver_tolerance : float
        Relative residual each cage vertex's column is solved to (the Bind takes 1e-6:
        its weights are float32 and those below 1e-5 are dropped).

    Returns
    -------
    field : HarmonicField
        The grid nodes' coordinates, and any point's by trilinear interpolation.

    Raises
    ------
    CageError
        The cage is not a closed, outward-oriented 3D triangle cage.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> vertices, triangles = gencoords.cages.shapes.icosphere(1)
    >>> field = gencoords.harmonic_field(vertices, triangles, resolution=12)
    >>> field.node_coordinates.shape[1], bool(field.node_coordinates.min() >= 0.0)
    (42, True)
    """
    prepared = validate_cage(vertices, faces, convex=False, tolerance=tolerance)
    if prepared.dimension != 3:
        raise CageError("bad_faces", f"harmonic coordinates need a 3D triangle cage, got a "
                                     f"{prepared.dimension}D one")
    return _solved_field(prepared, vertices, faces, None, resolution, progress, workers, solver_tolerance, tolerance)


@checked
def harmonic_quad_field(vertices, polygons, resolution=DEFAULT_RESOLUTION, tolerance=DEFAULT_TOLERANCE,
                        progress=None, workers=None, solver_tolerance=SOLVER_TOLERANCE):
    """:func:`harmonic_field` of a cage of quads and triangles, each quad its bilinear
    patch: on it the boundary values are its bilinear hats, so the field does not depend
    on how a quad would be split, nor on which corner it lists first (docs/MATH.md,
    "Harmonic coordinates on quads").

    Parameters
    ----------
    vertices : (n, 3) float
    polygons : (m, 4) int, or a list of 3- and 4-index lists
        Triangles and quads, counter-clockwise seen from outside; a triangle's fourth -1.
    resolution, tolerance, progress, workers, solver_tolerance
        As :func:`harmonic_field`.

    Returns
    -------
    field : HarmonicField
        Its ``faces`` the (m, 4) polygons.

    Raises
    ------
    CageError
        Not closed, manifold and outward, or a quad folded over itself (named).

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> vertices, quads = gencoords.cages.shapes.block_cage(np.ones((1, 1, 1), dtype=bool))
    >>> field = gencoords.harmonic_quad_field(vertices, quads, resolution=8)
    >>> print(field.coordinates([[0.5, 0.5, 0.5]]).round(3))  # the cube's centre
    [[0.125 0.125 0.125 0.125 0.125 0.125 0.125 0.125]]
    """
    validate_polygons(vertices, polygons, tolerance)
    triangles = fan_split(polygons)[0]
    prepared = validate_cage(vertices, triangles, convex=False, tolerance=tolerance)
    return _solved_field(prepared, vertices, triangles, polygons, resolution, progress, workers, solver_tolerance,
                         tolerance)


def _solved_field(prepared, vertices, triangles, polygons, resolution, progress, workers, solver_tolerance,
                  tolerance):
    """The field of a validated cage: its ``triangles`` (the inside nodes, the workers'
    cage) and the faces boundary values are taken on, ``polygons`` where given."""
    resolution = field.DEFAULT_RESOLUTION if resolution is None else resolution
    faces = triangles if polygons is None else polygons
    grid = fit_grid(prepared.vertices, resolution)
    local = prepared.vertices
    parts = _grid_nodes(grid, local[triangles], tolerance * prepared.size, local, polygons)
    measured, columns, values, solved = _boundary_nodes(grid, parts, local, faces)
    hat_ids = np.full(grid.shape, -1, dtype=np.int64)
    hat_ids[tuple(parts["indices"][measured].T)] = np.arange(len(measured))
    unknowns = np.zeros(grid.shape, dtype=bool)
    unknowns[tuple(parts["indices"][solved].T)] = True
    rhs = boundary_rhs(unknowns, grid, local, faces, hat_ids, columns, values)
    rows, order, parts["convergence"] = solved_rows(unknowns, rhs, (prepared.vertices, triangles), solver_tolerance,
                                                    progress=progress, workers=workers)
    # The solved nodes' rows dense, as the solver leaves them (argwhere order, the nodes'
    # too, then its own); the others sparse: their hat values, or their placing pairs.
    coordinates = MixedRows(rows, np.flatnonzero(solved)[order], len(parts["indices"]),
                            max(faces.shape[1], min(CUT_SUPPORT, len(vertices))))
    fixed = np.flatnonzero(~solved[measured])  # every node not solved (a padding column holds 0)
    coordinates.set_pairs(measured[fixed], columns[fixed], values[fixed])
    parts["coordinates"], parts["inside"] = coordinates, solved
    # Where each node's values come from: its own place, or (not solved) its nearest
    # boundary point (what :func:`.cage_features.hidden_corners` looks for behind the cage).
    positions = node_positions(grid, parts["indices"])
    parts["sources"] = positions.copy()
    parts["sources"][measured[fixed]] = np.einsum("bw,bwN->bN", values[fixed], local[columns[fixed]])
    parts["exact_within"] = _EXACT * np.linalg.norm(np.ptp(local, axis=0))
    parts["exact"] = _placing_exactly(coordinates, solved, positions, local, triangles, grid, parts["ids"],
                                      parts["exact_within"], parts["sources"], faces)
    return HarmonicField(prepared, np.array(vertices), np.array(faces), resolution, grid, parts)


@checked
def harmonic_coordinates(points, vertices, faces, resolution=DEFAULT_RESOLUTION, outside="raise",
                         tolerance=DEFAULT_TOLERANCE, progress=None, dtype=np.float64, workers=None):
    """Harmonic coordinates of points in a closed 3D triangle cage (see :func:`harmonic_field`).

    Parameters
    ----------
    points : (k, 3) float
    vertices : (n, 3) float
    faces : (m, 3) int
        Outward-oriented triangles; any closed cage, convex or not.
    resolution, tolerance, progress, workers
        As :func:`harmonic_field`.
    outside : str
        ``"raise"`` or ``"project"`` (:meth:`HarmonicField.interpolation`).
    dtype : numpy dtype
        Of the result.

    Returns
    -------
    coordinates : (k, n) dtype
        Non-negative, rows summing to 1.

    Examples
    --------
    >>> import numpy as np, gencoords
    >>> corners = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    >>> triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    >>> b = gencoords.harmonic_coordinates([[0.1, 0.2, 0.3]], corners, triangles, resolution=24)
    >>> print(b.round(6), bool(b.min() >= 0.0))  # in a tetrahedron: its barycentric coordinates
    [[0.4 0.1 0.2 0.3]] True
    """
    field = harmonic_field(vertices, faces, resolution, tolerance, progress, workers)
    return field.coordinates(points, outside, dtype)
