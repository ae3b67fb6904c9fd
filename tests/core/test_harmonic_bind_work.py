"""Issue 35, item 3: a Harmonic Bind's work follows the cells at the cage, not its box,
and each shortcut leaves the coordinates as they were.

- Surface cells: a facet marks the cells of its box that meet its slab, not the whole box
  (the revolved cup's slanted walls marked most of the box): every cell the surface meets
  is still marked, and the field keeps the same nodes' coordinates as with whole boxes.
- Nearest boundary points: the (node, facet) pairs cut out along one axis, and those
  farther than the reach from the facet's slab left out, find what a search of every
  facet finds; asked within a reach only (an inside node is a Dirichlet node only that
  near), the same for the positions within it.
- Dirichlet nodes beyond the cage's convex hull (no non-negative weights reach them) are
  not tried: they keep what trying them gave.
- The Bind locates and places its points once (two levels' rows, Automatic's sample of
  them, then exact storage's coordinates where two levels save nothing: the cup).
"""

import numpy as np
import pytest

from gencoords.base import grid as grid_module
from gencoords.base.grid import fit_grid, surface_cells
from gencoords.base.tolerances import FLOAT32
from gencoords.harmonic import field as field_module
from gencoords.harmonic import grid_field
from gencoords.harmonic import harmonic_quad_field
from gencoords.harmonic.boundary_values import _closest, _padded, nearest_boundary_points
from gencoords.harmonic.interpolation import CORNER_COUNT
from gencoords.planning import bind_plan
from gencoords.planning.bind_plan import plan_bind
from gencoords.planning.request import BindRequest
from tests.fixtures import artist_cages


def _box_cells(grid, corners, reach):
    """The former surface cells: every cell of each facet's box grown by ``reach``."""
    cells = np.zeros(grid.cells, dtype=bool)
    last = np.array(grid.cells) - 1
    low = np.floor((corners.min(axis=1) - reach - grid.origin) / grid.spacing).astype(np.int64).clip(0, last)
    high = np.floor((corners.max(axis=1) + reach - grid.origin) / grid.spacing).astype(np.int64).clip(0, last)
    for (i0, j0, k0), (i1, j1, k1) in zip(low.tolist(), high.tolist()):
        cells[i0:i1 + 1, j0:j1 + 1, k0:k1 + 1] = True
    return cells


def _polygons(scene):
    faces = scene.cage_faces
    return faces if faces.shape[1] == 4 else np.column_stack([faces, np.full(len(faces), -1)])


@pytest.fixture(scope="module")
def cup():
    return artist_cages.cup(0.3)


def test_a_slanted_facet_marks_the_cells_along_it_every_cell_it_meets_and_few_of_its_box():
    rng = np.random.default_rng(3)
    corners = np.array([[[0.0, 0.0, 0.0], [1.0, 0.9, 0.1], [0.2, 1.0, 0.95]],  # slanted across its box
                        [[0.1, 0.1, 0.5], [0.9, 0.1, 0.5], [0.5, 0.9, 0.5]]])  # flat: one layer
    grid = fit_grid(corners.reshape(-1, 3), 24)
    reach = 0.1 * grid.spacing
    marked = surface_cells(grid, corners, reach)
    # Points on the facets and within the reach of them: their cells are all marked.
    weights = rng.dirichlet(np.ones(3), 20000)
    on = np.einsum("pc,mcN->mpN", weights, corners).reshape(-1, 3)
    on += rng.uniform(-reach, reach, on.shape) / np.sqrt(3.0)
    cells = np.floor((on - grid.origin) / grid.spacing).astype(np.int64).clip(0, np.array(grid.cells) - 1)
    assert marked[tuple(cells.T)].all()
    # The slanted facet's box is most of the grid; the cells along it a thin sheet of it.
    boxes = _box_cells(grid, corners, reach)
    assert marked.sum() < 0.3 * boxes.sum()
    assert not (marked & ~boxes).any()


def test_the_field_keeps_the_same_coordinates_for_the_nodes_of_cells_at_the_cage(cup, monkeypatch):
    polygons = _polygons(cup)
    field = harmonic_quad_field(cup.cage_vertices, polygons, resolution=20, tolerance=FLOAT32)
    with monkeypatch.context() as patch:
        patch.setattr(grid_module, "surface_cells", _box_cells)
        patch.setattr("gencoords.harmonic.grid_field.surface_cells", _box_cells)
        boxed = harmonic_quad_field(cup.cage_vertices, polygons, resolution=20, tolerance=FLOAT32)
    # Fewer nodes kept (outside the cup's slanted walls), each one of the boxed field's...
    assert len(field.node_indices) < 0.9 * len(boxed.node_indices)
    rows = boxed._ids[tuple(field.node_indices.T)]
    assert (rows >= 0).all()
    # ... with the same coordinates, the same solved and exact nodes, the same solve.
    np.testing.assert_array_equal(field.node_inside, boxed.node_inside[rows])
    np.testing.assert_array_equal(field.node_exact, boxed.node_exact[rows])
    np.testing.assert_allclose(field.node_coordinates, boxed.node_coordinates[rows], rtol=0.0, atol=1e-12)
    assert field.node_inside.sum() == boxed.node_inside.sum()
    # The mesh's coordinates, looked up in either.
    points = cup.mesh_vertices[::3]
    np.testing.assert_allclose(field.coordinates(points), boxed.coordinates(points), rtol=0.0, atol=1e-12)


def test_dirichlet_nodes_beyond_the_hull_left_untried_keep_what_trying_them_gives(cup, monkeypatch):
    polygons = _polygons(cup)
    skipped = []
    beyond = grid_field._beyond_the_hull

    def counted(*args):
        skipped.append(beyond(*args))
        return skipped[-1]

    monkeypatch.setattr(grid_field, "_beyond_the_hull", counted)
    field = harmonic_quad_field(cup.cage_vertices, polygons, resolution=20, tolerance=FLOAT32)
    assert skipped[0].mean() > 0.3  # the cup's outer wall: most of its Dirichlet nodes
    monkeypatch.setattr(grid_field, "_beyond_the_hull", lambda positions, *_: np.zeros(len(positions), dtype=bool))
    tried = harmonic_quad_field(cup.cage_vertices, polygons, resolution=20, tolerance=FLOAT32)
    np.testing.assert_array_equal(field.node_exact, tried.node_exact)
    np.testing.assert_array_equal(field.node_coordinates, tried.node_coordinates)


@pytest.mark.parametrize("name", ["cup", "hand"])  # triangles only; quads, each its patch
def test_nearest_boundary_points_are_those_a_search_of_every_face_finds(name):
    rng = np.random.default_rng(5)
    scene = artist_cages.fixture(name, 0.1)
    vertices, faces = scene.cage_vertices, _polygons(scene)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    positions = rng.uniform(low - 0.05, high + 0.05, (600, 3))
    reach = 0.02 * float(np.linalg.norm(high - low))
    columns, values, distance = nearest_boundary_points(positions, vertices, faces, reach)
    corners = vertices[_padded(faces)]
    quad = faces[:, -1] >= 0
    every = _closest(np.repeat(positions, len(faces), axis=0), np.tile(corners, (len(positions), 1, 1)),
                     np.tile(quad, len(positions)))[1].reshape(len(positions), len(faces))
    np.testing.assert_allclose(distance, every.min(axis=1), rtol=0.0, atol=1e-12)
    placed = np.einsum("pc,pcN->pN", values, vertices[columns])  # the hat values place the nearest point
    np.testing.assert_allclose(np.linalg.norm(placed - positions, axis=1), distance, rtol=0.0, atol=1e-9)
    # Asked only within a reach (the inside nodes that may be Dirichlet nodes): the same
    # nearest points for the positions within it, none for the others.
    within = np.quantile(distance, 0.3)
    near_columns, near_values, near_distance = nearest_boundary_points(positions, vertices, faces, within, widen=False)
    found = distance <= within
    assert 0 < found.sum() < len(found)
    np.testing.assert_array_equal(near_distance[found], distance[found])
    np.testing.assert_array_equal(near_values[found], values[found])
    np.testing.assert_array_equal(near_columns[found], columns[found])
    assert np.isinf(near_distance[~found]).all() and not near_values[~found].any()


def test_the_cups_bind_locates_and_places_its_points_once_and_writes_what_the_field_gives(monkeypatch):
    scene = artist_cages.cup(0.2)  # fewer vertices than the grid nodes their cells use: no two levels
    calls, fields = [], []
    located, solved = field_module.HarmonicField._located, bind_plan.harmonic_quad_field

    def counted(self, points, outside, inside=None):
        calls.append(len(points))
        return located(self, points, outside, inside)

    def kept(*args, **kwargs):
        fields.append(solved(*args, **kwargs))
        return fields[-1]

    monkeypatch.setattr(field_module.HarmonicField, "_located", counted)
    monkeypatch.setattr(bind_plan, "harmonic_quad_field", kept)
    request = BindRequest("harmonic", tolerance=FLOAT32, polygons=_polygons(scene), workers=1)
    steps = plan_bind(scene.mesh_vertices, scene.cage_vertices, scene.cage_triangles, request)
    try:
        while True:
            next(steps)
    except StopIteration as done:
        plan = done.value
    # After two levels' rows the per-vertex pairs' path asks again (Automatic's playback
    # choice: the cup's thin walls put nearly every vertex in a cut cell).
    assert plan.storage == "SPARSE" and plan.node_indices is None
    assert calls == [len(scene.mesh_vertices)]  # Automatic's sample taken from every point's rows
    field, = fields
    field._last_rows = None  # forgotten: located and placed afresh
    dense = np.zeros((len(scene.mesh_vertices), len(scene.cage_vertices)))
    np.put_along_axis(dense, plan.indices, plan.slots.astype(np.float64), axis=1)
    exact = field.coordinates(scene.mesh_vertices)
    assert calls.count(len(scene.mesh_vertices)) == 2
    # The pairs are the field's largest, reweighted: their drag deviation bounds the gap.
    assert np.abs(dense - exact).sum(axis=1).max() < 0.05


def test_the_rows_given_twice_are_copies(cup):
    field = harmonic_quad_field(cup.cage_vertices, _polygons(cup), resolution=12, tolerance=FLOAT32)
    points = cup.mesh_vertices[::8]
    first = field.sparse_rows(points)
    first[1][:] = -1.0  # a caller writing into what it was given (two levels' rows do)
    second = field.sparse_rows(points)
    assert (second[1] >= 0.0).all() and np.allclose(second[1].sum(axis=1), 1.0)
    third = field.sparse_rows(points)  # kept: the same, and again a copy
    for part, again in zip(second, third):
        np.testing.assert_array_equal(part, again)
        assert not np.shares_memory(part, again)
    other = field.sparse_rows(points[::2])  # a sample of them: taken from their rows, which stay
    np.testing.assert_array_equal(other[0], second[0][::2])
    assert field._last_rows[0][1] == points.shape
    field.sparse_rows(points[1::2][::-1])  # neither a run nor a sample of them
    assert field._last_rows[0][1] == points[1::2].shape  # only the last set's rows are kept


@pytest.mark.parametrize("taken", [slice(None, None, 1), slice(None, None, 4), slice(None, None, 7),
                                   slice(None, None, 10_000), slice(1, None, 4), slice(100, 400), slice(-57, None)],
                         ids=["all", "every-4th", "every-7th", "the-first", "every-4th-from-1", "a-run", "the-last-run"])
def test_a_sample_or_a_run_of_the_points_takes_their_rows_from_every_points(cup, taken):
    """Automatic's sample (every few points) and the written chunks (runs of them) are
    served from the rows of every point, kept: each row is its own, so they are those
    located and placed afresh, bit for bit."""
    field = harmonic_quad_field(cup.cage_vertices, _polygons(cup), resolution=12, tolerance=FLOAT32)
    points = cup.mesh_vertices[::3]
    every = field.sparse_rows(points)
    located = []
    field._located = lambda *args: located.append(1) or field_module.HarmonicField._located(field, *args)
    rows = field.sparse_rows(points[taken])  # from every point's rows, which stay kept
    assert not located and field._last_rows[0][1] == points.shape
    field._last_rows, kept = None, field._last_rows
    alone = field.sparse_rows(points[taken])  # located and placed afresh
    assert located
    for part, again in zip(rows, alone):
        np.testing.assert_array_equal(part, again)
    assert not any(np.shares_memory(part, whole) for part, whole in zip(rows, every))
    field._last_rows = kept
    assert field.sparse_rows(points[taken][::-1])[0].shape == (len(points[taken]), CORNER_COUNT)  # located



def test_the_cups_field_and_its_points_coordinates_take_little_beside_what_they_keep(cup):
    """The field keeps its solved nodes' rows dense, as the solver leaves them, and the
    other nodes' few pairs (a dense row for every node was 90 MB on the cup at the Bind's
    grid, its solve's peak 1.3 times that); it reweights its solved nodes a few batches at
    a time, in place; the points' coordinates are written into their result (the cut
    points' rows were a second block as large)."""
    import tracemalloc

    tracemalloc.start()
    try:
        field = harmonic_quad_field(cup.cage_vertices, _polygons(cup), resolution=48, tolerance=FLOAT32, workers=1)
        _, peak = tracemalloc.get_traced_memory()
        field.sparse_rows(cup.mesh_vertices)  # located once, as the Bind does first
        tracemalloc.reset_peak()
        before, _ = tracemalloc.get_traced_memory()
        coordinates = field.coordinates(cup.mesh_vertices)
        _, points_peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    rows, every_row = field._node_rows, field.node_indices.shape[0] * len(field.vertices) * 8
    solved = np.count_nonzero(field.node_inside)
    assert rows.dense.shape == (solved, len(field.vertices)) and rows.nbytes < 0.45 * every_row
    assert peak < 0.8 * every_row  # the whole solve: less than the nodes' dense rows alone
    assert field.cut(field.interpolation(cup.mesh_vertices)[0]).mean() > 0.5  # most are cut: their rows count
    assert points_peak - before < 1.6 * coordinates.nbytes


def test_node_rows_read_the_nodes_coordinates_the_field_keeps(cup):
    """Whole rows, dense or sparse, in any order, bit for bit the dense copy's rows; a
    sparse row holds at most CUT_SUPPORT pairs; and every row, read back, is non-negative,
    sums to 1 and places its node where the field says it does."""
    field = harmonic_quad_field(cup.cage_vertices, _polygons(cup), resolution=16, tolerance=FLOAT32)
    every = field.node_coordinates
    ids = np.random.default_rng(3).permutation(len(every))[:500]
    assert every[ids].tobytes() == field.node_rows(ids).tobytes()
    assert np.count_nonzero(every[~field.node_inside], axis=1).max() <= field_module.CUT_SUPPORT
    assert every.min() >= 0.0 and np.abs(every.sum(axis=1) - 1.0).max() < 1e-12
    placed = np.linalg.norm(every[field.node_exact] @ field.vertices - field.node_positions[field.node_exact], axis=1)
    assert placed.max() < 1e-9 * np.linalg.norm(np.ptp(field.vertices, axis=0))


def test_the_cups_written_chunks_give_the_same_plan_bit_for_bit_whatever_their_size(monkeypatch):
    """The per-vertex pairs are written a few MB of coordinates at a time (the cup's one
    chunk of 22 MB, three times over, was its Bind's peak); each row's pairs and figures
    are its own, so chunks of any size give the same plan, every field bit for bit."""
    import dataclasses

    from gencoords.planning import figures
    from gencoords.planning.bind_steps import run_to_end

    scene = artist_cages.cup(0.3)
    request = BindRequest("harmonic", tolerance=FLOAT32, polygons=_polygons(scene), resolution=32, workers=1)
    chunks = []
    solve_points = figures.solve_points
    monkeypatch.setattr(figures, "solve_points", lambda *args, **kwargs: chunks.append(len(args[2])) or
                        solve_points(*args, **kwargs))
    plans = []
    for entries in (1 << 30, 100 * len(scene.cage_vertices)):  # one chunk; chunks of 100 points
        monkeypatch.setattr(figures, "FIELD_CHUNK_ENTRIES", entries)
        chunks.clear()
        plans.append(run_to_end(plan_bind(scene.mesh_vertices, scene.cage_vertices, scene.cage_triangles, request)))
    assert plans[0].storage == "SPARSE" and plans[0].node_indices is None  # the per-vertex pairs: written
    assert chunks.count(100) == len(scene.mesh_vertices) // 100  # and Automatic's sample before them
    for field in dataclasses.fields(plans[0]):
        first, second = getattr(plans[0], field.name), getattr(plans[1], field.name)
        if isinstance(first, np.ndarray):
            assert first.dtype == second.dtype and first.tobytes() == second.tobytes(), field.name
        else:
            assert repr(first) == repr(second), field.name


def test_the_multigrid_solve_in_workers_gives_what_one_process_gives(monkeypatch):
    from gencoords.cages.shapes import icosphere
    from gencoords.harmonic import solve as solve_module

    monkeypatch.setattr(solve_module, "elimination_plan", lambda *args: None)  # the iterative solver
    in_workers = []
    monkeypatch.setattr(solve_module, "_solve_in_workers",
                        lambda *args, solve=solve_module._solve_in_workers: in_workers.append(1) or solve(*args))
    vertices, triangles = icosphere(2)
    alone = grid_field.harmonic_field(vertices, triangles, resolution=24, workers=1)
    spread = grid_field.harmonic_field(vertices, triangles, resolution=24, workers=2)
    assert in_workers
    np.testing.assert_allclose(spread.node_coordinates, alone.node_coordinates, rtol=0, atol=1e-13)


def test_the_refusals_inside_lookup_counts_crossings_in_place(cup):
    """The 131^3 nodes of the cup's inside lookup (Bind's refusal, before any coordinates)
    are counted in 16 bits, summed in place, a few (facet, column) pairs at a time (float64
    counts, their summed copy and every pair at once took 26 MB beside what is kept), and
    say what winding numbers say."""
    import tracemalloc

    from gencoords.construction.boundary import winding_numbers
    from gencoords.evaluation.cage import Cage

    prepared = Cage(cup.cage_vertices, cup.cage_triangles, tolerance=FLOAT32)._prepared
    grid = fit_grid(prepared.vertices, 128)
    tracemalloc.start()
    try:
        inside = grid_module.inside_nodes(grid, prepared.facet_corners())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 3 * inside.size + (4 << 20)
    sample = np.argwhere(np.ones(grid.shape, dtype=bool))[::997]
    expected = winding_numbers(prepared, grid_module.node_positions(grid, sample) * prepared.scale + prepared.origin)
    # Where the lookup is read: cells the surface does not cross, as their lowest node.
    surface = surface_cells(grid, prepared.facet_corners(), 1e-6 * grid.spacing)
    read = ~surface[tuple(np.minimum(sample, np.array(surface.shape) - 1).T)]
    assert read.mean() > 0.9
    assert inside[tuple(sample[read].T)].tolist() == (expected[read] >= 0.5).tolist()


@pytest.mark.parametrize("name", ["cup", "hand"])  # triangles; quads, their patches
@pytest.mark.parametrize("measure", ["nearest", "crossings"])
def test_boundary_values_of_many_nodes_are_measured_a_block_at_a_time_bit_for_bit(name, measure, monkeypatch):
    """The nodes' nearest boundary points and segments' crossings are measured a block of
    rows at a time (their (node, facet) pairs all at once were 40 MB of the cup's Bind):
    the same values bit for bit, segments of any length (each block boxed with every
    segment's reach), a block's pairs in memory."""
    import tracemalloc

    from gencoords.harmonic import boundary_values

    scene = artist_cages.fixture(name, 0.1)
    grid = fit_grid(scene.cage_vertices, 48)
    polygons = _polygons(scene)
    near = surface_cells(grid, scene.cage_vertices[scene.cage_triangles], grid.spacing)  # nodes as the Bind's
    positions = grid_module.node_positions(grid, np.argwhere(near))
    if measure == "nearest":
        run = lambda: boundary_values.nearest_boundary_points(  # noqa: E731
            positions, scene.cage_vertices, polygons, 1.75 * grid.spacing)
    else:  # the grid's edges; then rays of every length (a thin part's across)
        steps = np.tile([[0.0, 0.0, 1.0]], (len(positions), 1)) * grid.spacing
        run = lambda: boundary_values.segment_crossings(positions, steps, scene.cage_vertices, polygons)  # noqa: E731
        rays = np.random.default_rng(1).normal(size=positions[::3].shape) * grid.spacing
        rays[::97] *= 4.0
        blocks = boundary_values.segment_crossings(positions[::3], rays, scene.cage_vertices, polygons)
        with monkeypatch.context() as whole:
            whole.setattr(boundary_values, "_ROWS_AT_A_TIME", len(positions))
            for part, again in zip(blocks, boundary_values.segment_crossings(positions[::3], rays, scene.cage_vertices,
                                                                             polygons)):
                assert part.tobytes() == again.tobytes()
    assert len(positions) > 4 * boundary_values._ROWS_AT_A_TIME
    tracemalloc.start()
    try:
        blocks = run()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    monkeypatch.setattr(boundary_values, "_ROWS_AT_A_TIME", len(positions))
    whole = run()
    for part, again in zip(blocks, whole):
        assert part.tobytes() == again.tobytes()
    assert peak < sum(part.nbytes for part in blocks) + (12 << 20)
