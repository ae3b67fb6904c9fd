"""Harmonic coordinates on a grid (core/harmonic): the properties docs/MATH.md states."""

import numpy as np
import pytest

import gencoords
from gencoords.harmonic.boundary_values import nearest_boundary_points
from gencoords.harmonic import elimination
from gencoords.harmonic.multigrid import build_levels, solve
from gencoords.harmonic.solve import NEAREST_CROSSING, solve_nodes, solved_rows
from gencoords.cages.shapes import block_cage, t_pose_blocks
from gencoords.skinning.skinning import reproduce_points, top_k, truncate

TETRAHEDRON = (np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
               np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))


def cage_of(occupied):
    vertices, quads = block_cage(occupied)
    return vertices, gencoords.cages.triangulate_quads(vertices, quads)


def points_in(occupied, count, seed=0, depth=0.0):
    """Points uniformly in the filled cubes, at least ``depth`` inside each cube's faces
    that are on the surface (depth 0: anywhere)."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(0.0, occupied.shape, size=(6 * count, 3))
    cube = np.floor(points).astype(int)
    keep = occupied[tuple(cube.T)]
    if depth:
        padded = np.pad(occupied, 1)
        for axis in range(3):
            step = np.eye(3, dtype=int)[axis]
            fraction = points[:, axis] - cube[:, axis]
            keep &= padded[tuple((cube + 1 - step).T)] | (fraction >= depth)
            keep &= padded[tuple((cube + 1 + step).T)] | (fraction <= 1.0 - depth)
    return points[keep][:count]


@pytest.fixture(scope="module")
def t_pose():
    occupied = t_pose_blocks()
    vertices, triangles = cage_of(occupied)
    field = gencoords.harmonic_field(vertices, triangles, resolution=32)
    return occupied, vertices, triangles, field


def test_coordinates_are_non_negative_and_rows_sum_to_one(t_pose):
    occupied, vertices, _, field = t_pose
    coordinates = field.coordinates(points_in(occupied, 3000))
    for values in (coordinates, field.node_coordinates):
        assert values.min() >= 0.0
        np.testing.assert_allclose(values.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_points_are_their_cells_trilinear_mix_of_node_coordinates_or_their_own_placing_pairs(t_pose):
    occupied, vertices, _, field = t_pose
    points = points_in(occupied, 500, seed=1)
    nodes, weights = field.interpolation(points)
    assert nodes.shape == weights.shape == (len(points), 8) and weights.min() >= 0.0
    # The nodes are the corners of the points' cells: trilinear weights reproduce the points.
    np.testing.assert_allclose(np.einsum("kc,kcN->kN", weights, field.node_positions[nodes]), points,
                               rtol=0, atol=1e-12)
    mixed = np.einsum("kc,kcn->kn", weights, field.node_coordinates[nodes])
    coordinates, cut = field.coordinates(points), field.cut(nodes)
    assert 0 < cut.sum() < len(points)
    np.testing.assert_allclose(mixed[~cut], coordinates[~cut], rtol=0, atol=1e-15)
    # At the cage: a few largest entries, reweighted to place the point.
    assert ((coordinates[cut] > 0).sum(axis=1) <= gencoords.harmonic.field.CUT_SUPPORT).all()
    np.testing.assert_allclose(coordinates[cut] @ vertices, points[cut], rtol=0, atol=1e-12)


def test_a_tetrahedron_gives_its_barycentric_coordinates_at_any_resolution():
    # Non-negative, summing to 1 and placing each point: in a tetrahedron only the
    # barycentric coordinates are all three.
    vertices, faces = TETRAHEDRON
    points = np.random.default_rng(2).dirichlet(np.ones(4), size=2000)[:, 1:]
    barycentric = np.column_stack([1.0 - points.sum(axis=1), points])
    for resolution in (8, 16, 32):
        coordinates = gencoords.harmonic_coordinates(points, vertices, faces, resolution=resolution)
        np.testing.assert_allclose(coordinates, barycentric, rtol=0, atol=1e-12)


def first_crossing(start, step, vertices, triangles):
    """The first crossing of one segment with the cage, by solving each triangle's 3 x 3
    system ``a + u e1 + v e2 = start + t step``: (t, hat values (n,)), or (inf, None)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    systems = np.stack([b - a, c - a, np.broadcast_to(-step, a.shape)], axis=2)
    usable = np.abs(np.linalg.det(systems)) > 1e-12
    u, v, t = np.linalg.solve(systems[usable], (start - a[usable])[:, :, None])[:, :, 0].T
    hit = (u >= -1e-12) & (v >= -1e-12) & (u + v <= 1 + 1e-12) & (t >= -1e-12) & (t <= 1)
    if not hit.any():
        return np.inf, None
    best = np.argmin(np.where(hit, t, np.inf))
    hats = np.zeros(len(vertices))
    np.add.at(hats, triangles[usable][best], [1 - u[best] - v[best], u[best], v[best]])
    return t[best], hats


def scipy_solution(field):
    """The Shortley-Weller system (docs/MATH.md), assembled here from the cage's crossings
    of the grid's edges and solved by scipy's sparse LU."""
    sparse = pytest.importorskip("scipy.sparse")
    linalg = pytest.importorskip("scipy.sparse.linalg")
    ids = np.full(field.shape, -1)
    ids[tuple(field.node_indices.T)] = np.arange(len(field.node_indices))
    unknown = np.flatnonzero(field.node_inside)
    row_of = np.full(len(field.node_indices), -1)
    row_of[unknown] = np.arange(len(unknown))
    rows, columns, values = [], [], []
    diagonal, rhs = np.zeros(len(unknown)), np.zeros((len(unknown), len(field.vertices)))
    for axis in range(3):
        for sign in (-1, 1):
            neighbour = field.node_indices[unknown].copy()
            neighbour[:, axis] += sign
            other = ids[tuple(neighbour.T)]
            solved = field.node_inside[other]
            rows += np.flatnonzero(solved).tolist()
            columns += row_of[other[solved]].tolist()
            values += [-1.0] * int(solved.sum())
            diagonal[solved] += 1.0
            step = np.zeros(3)
            step[axis] = sign * field.spacing
            for row in np.flatnonzero(~solved):
                t, hats = first_crossing(field.node_positions[unknown[row]], step, field.vertices, field.faces)
                if hats is None:  # to a Dirichlet node inside, on the cage: its own hat values
                    t, hats = 1.0, np.zeros(len(field.vertices))
                    corners, barycentric, _ = nearest_boundary_points(
                        field.node_positions[other[row]][None], field.vertices, field.faces, 1.0)
                    np.add.at(hats, corners[0], barycentric[0])
                weight = 1.0 / max(t, NEAREST_CROSSING)
                diagonal[row] += weight
                rhs[row] += weight * hats
    rows += list(range(len(unknown)))
    columns += list(range(len(unknown)))
    values += diagonal.tolist()
    matrix = sparse.csc_matrix((values, (rows, columns)), shape=(len(unknown), len(unknown)))
    return linalg.spsolve(matrix, rhs), unknown


@pytest.mark.parametrize("solver", ["elimination", "multigrid"])
@pytest.mark.parametrize("occupied", [np.ones((2, 1, 1), dtype=bool), t_pose_blocks()], ids=["bar", "t_pose"])
def test_the_solution_is_the_discrete_systems_as_scipy_solves_it(occupied, solver, monkeypatch):
    if solver == "multigrid":  # the iterative solver wherever it is offered
        monkeypatch.setattr(elimination, "MULTIGRID_FLOPS_PER_PAIR", 0)
    vertices, triangles = cage_of(occupied)
    field = gencoords.harmonic_field(vertices, triangles, resolution=20)
    assert (len(field.convergence) == 2) == (solver == "elimination")  # no iterations
    reference, unknown = scipy_solution(field)
    assert reference.min() > -1e-14  # the discrete maximum principle, independently
    # The field keeps the solution reweighted to place each node (docs/MATH.md).
    every = np.broadcast_to(np.arange(len(vertices)), reference.shape)
    # The system is exact for linear functions: its solution places the nodes already, but
    # for the Dirichlet nodes on the cage (to within NEAREST_CROSSING of a cell) it uses.
    assert np.linalg.norm(reference @ vertices - field.node_positions[unknown], axis=1).max() < (
        NEAREST_CROSSING * field.spacing)
    placed, _ = reproduce_points(every, reference.clip(0.0), vertices, field.node_positions[unknown])
    np.testing.assert_allclose(field.node_coordinates[unknown], placed, rtol=0, atol=1e-8)


def t_pose_system(resolution):
    """The Shortley-Weller system of the T-pose cage, as ``harmonic_field`` builds it."""
    vertices, triangles = cage_of(t_pose_blocks())
    captured = {}

    def spy(inside, rhs, cage, *args, **kwargs):
        captured.update(inside=inside, rhs=rhs, cage=cage)
        return solved_rows(inside, rhs, cage, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(gencoords.harmonic.grid_field, "solved_rows", spy)
        gencoords.harmonic_field(vertices, triangles, resolution=resolution)
    return captured["inside"], captured["rhs"], captured["cage"]


def test_slab_elimination_and_multigrid_agree_along_every_axis():
    inside, rhs, cage = t_pose_system(24)
    iterative, history = solve_nodes(inside, rhs, cage, 1e-12, method="multigrid", workers=1)
    reduction = (history[-1] / history[0]) ** (1.0 / (len(history) - 1))
    assert history[-1] < 1e-12 and len(history) <= 16 and reduction < 0.2, history
    right = np.zeros((int(inside.sum()), len(cage[0])))
    np.add.at(right, rhs[0][:2], rhs[0][2])
    for axis in range(3):
        direct = elimination.solve_by_slabs(inside, rhs[1], axis, right)
        assert direct.min() > -1e-15  # the discrete maximum principle, to rounding
        np.testing.assert_allclose(direct, iterative, rtol=0, atol=1e-10)
        # The field keeps elimination's rows in slab order, named by ``order``: no copy permuted.
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(gencoords.harmonic.solve, "slab_axis", lambda *args, axis=axis: (axis, 0.0, 0.0))
            rows, order, _ = solved_rows(inside, rhs, cage, method="elimination")
        assert sorted(order) == list(range(len(rows))) and (axis == 0) == (np.diff(order) > 0).all()
        np.testing.assert_allclose(rows[np.argsort(order)], iterative, rtol=0, atol=1e-10)


def test_slab_elimination_keeps_only_the_columns_the_next_slab_couples_to():
    """The Schur complements' inverses are never held whole (the cup at 96 cells: 596 MB):
    the solve holds each slab's columns the next slab reads, one slab's matrix and its
    inverse, and solves the system. On the thin-walled cup at 48 cells (the Bind's grid)
    the columns kept are 8.6 MB where the inverses take 20.5."""
    import tracemalloc
    from gencoords.harmonic.multigrid import apply_matrix, level_of
    from tests.fixtures import artist_cages
    scene = artist_cages.fixture("cup", 0.1)
    captured = {}

    def spy(inside, rhs, cage, *args, **kwargs):
        captured.update(inside=inside, rhs=rhs, columns=len(cage[0]))
        raise StopIteration  # the system is all this test needs

    with pytest.MonkeyPatch.context() as patch, pytest.raises(StopIteration):
        patch.setattr(gencoords.harmonic.grid_field, "solved_rows", spy)
        gencoords.harmonic_quad_field(scene.cage_vertices, scene.cage_faces, resolution=48)
    inside, (rows, diagonal), columns = captured["inside"], captured["rhs"], captured["columns"]
    layout = elimination.slab_layout(inside, elimination.slab_axis(inside, columns)[0])
    values = np.zeros((int(inside.sum()), columns))
    position = np.empty(len(values), dtype=np.int64)
    position[layout.order] = np.arange(len(values))
    np.add.at(values, (position[rows[0]], rows[1]), rows[2])
    right = np.zeros((len(values) + 1, columns))
    right[layout.order] = values
    sizes = np.diff(layout.bounds).astype(np.int64)
    coupled = sum(int(sizes[i]) * len(layout.links[i + 1][0]) for i in range(len(sizes) - 1))
    assert coupled < 0.5 * int((sizes ** 2).sum())  # the inverses whole: twice as many entries
    # The kept columns, a slab's matrix and inv's two (its copy, its result), two slabs' rows.
    held = 8 * (coupled + 3 * int(sizes.max()) ** 2) + 2 * 8 * int(sizes.max()) * columns + (256 << 10)
    tracemalloc.start()
    try:
        elimination.solve_in_slab_order(layout, diagonal, values)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= held
    found = np.zeros_like(right)
    found[layout.order] = values
    residual = apply_matrix(level_of(inside, diagonal=diagonal), found) - right
    assert np.abs(residual).max() < 1e-12 * np.abs(right).max()


def test_elimination_is_chosen_for_limbs_and_multigrid_for_a_fine_solid_block():
    inside, _, _ = t_pose_system(48)
    assert elimination.elimination_plan(inside, 50) is not None
    solid = np.zeros((82, 82, 82), dtype=bool)
    solid[1:-1, 1:-1, 1:-1] = True  # 80 x 80 slabs: 6,400 cubed per slab
    assert elimination.elimination_plan(solid, 8) is None
    axis, _, _ = elimination.slab_axis(np.pad(np.ones((30, 3, 10), dtype=bool), 1), 8)
    assert axis == 0  # the most slabs, each the smallest


def test_each_conjugate_gradient_iteration_reduces_the_residual_tenfold(t_pose, monkeypatch):
    monkeypatch.setattr(elimination, "MULTIGRID_FLOPS_PER_PAIR", 0)
    _, vertices, triangles, _ = t_pose
    history = gencoords.harmonic_field(vertices, triangles, resolution=32).convergence
    assert history[-1] < 1e-10 and len(history) <= 16
    reduction = (history[-1] / history[0]) ** (1.0 / (len(history) - 1))
    assert reduction < 0.2, history


def test_the_solver_alone_on_a_cube_of_unknowns():
    inside = np.zeros((20, 20, 20), dtype=bool)
    inside[1:-1, 1:-1, 1:-1] = True
    levels = build_levels(inside)
    assert len(levels) >= 3
    rhs = np.zeros((levels[0].count + 1, 2))
    rhs[:-1] = np.random.default_rng(3).uniform(size=(levels[0].count, 2))
    x, history = solve(levels, rhs, 1e-11)
    residual = rhs[:-1] - (6.0 * x[:-1] - x[levels[0].neighbours].sum(axis=1))
    assert np.abs(residual).max() < 1e-9 * np.abs(rhs).max() and len(history) < 15


def linear_precision(vertices, triangles, points, resolution=gencoords.harmonic.DEFAULT_RESOLUTION):
    field = gencoords.harmonic_field(vertices, triangles, resolution=resolution)
    coordinates = field.coordinates(points)
    diagonal = np.linalg.norm(np.ptp(vertices, axis=0))
    return np.linalg.norm(coordinates @ vertices - points, axis=1).max() / diagonal, field, coordinates


# A turn about (1, 2, 3): no cage face parallel to the grid's (an axis-aligned box whose
# faces fall on grid nodes is exact, which would prove nothing).
TURN = np.linalg.qr(np.array([[1.0, 2.0, 3.0], [-2.0, 1.0, 0.5], [0.3, -1.0, 1.0]]).T)[0]


@pytest.mark.parametrize("occupied", [np.ones((3, 3, 3), dtype=bool), t_pose_blocks()], ids=["box", "t_pose"])
def test_linear_precision_is_exact_and_coordinates_stay_non_negative(occupied):
    vertices, triangles = cage_of(occupied)
    points = points_in(occupied, 1500, seed=4)
    if len(occupied) == 3:
        vertices, points = vertices @ TURN, points @ TURN
    error, field, coordinates = linear_precision(vertices, triangles, points)
    print("linear precision / diagonal at the default resolution:", error)
    assert error < 1e-12 and coordinates.min() >= 0.0
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    # Grid nodes deeper than two cells keep few weights that still span them: 32, placed, exact.
    deep = points_in(occupied, 500, seed=5, depth=2.0 * field.spacing)
    deep = deep @ TURN if len(occupied) == 3 else deep
    indices, weights = top_k(field.coordinates(deep), 32)
    corrected, residual = reproduce_points(indices, weights, vertices, deep)
    assert residual.max() < 1e-12 * np.linalg.norm(np.ptp(vertices, axis=0)) and corrected.min() >= 0.0


def test_one_limb_moves_nothing_in_the_other_limbs(t_pose):
    occupied, vertices, _, field = t_pose
    points = points_in(occupied, 4000, seed=6)
    coordinates = field.coordinates(points)
    hand = vertices[:, 0] == 0.0  # the left arm's end
    elsewhere = (points[:, 0] > 10.0) | (points[:, 2] < 4.0)  # the right arm, the legs
    largest = coordinates[np.ix_(elsewhere, hand)].max()
    print("left hand's coordinates in the other limbs, largest:", largest)
    assert largest < 1e-5
    assert coordinates[np.ix_(points[:, 0] < 1.0, hand)].max() > 0.1  # but its own hand


def test_progress_reports_and_a_raising_progress_cancels():
    vertices, triangles = cage_of(np.ones((2, 1, 1), dtype=bool))
    fractions = []
    gencoords.harmonic_field(vertices, triangles, resolution=16, progress=fractions.append)
    assert fractions and all(0.0 <= f <= 1.0 for f in fractions) and fractions[-1] == pytest.approx(1.0)

    class Cancelled(Exception):
        pass

    def cancel(fraction):
        raise Cancelled

    with pytest.raises(Cancelled):
        gencoords.harmonic_field(vertices, triangles, resolution=16, progress=cancel)


def test_points_outside_raise_or_take_their_nearest_boundary_points():
    vertices, triangles = cage_of(np.ones((2, 1, 1), dtype=bool))
    field = gencoords.harmonic_field(vertices, triangles, resolution=16)
    outside = np.array([[-0.5, 0.5, 0.5], [1.0, 0.5, 3.0]])
    with pytest.raises(gencoords.OutsideCageError) as raised:
        field.coordinates(np.vstack([[[1.0, 0.5, 0.5]], outside]))
    assert raised.value.indices.tolist() == [1, 2]
    projected = field.coordinates(outside, outside="project")
    np.testing.assert_array_equal(projected, field.coordinates([[0.0, 0.5, 0.5], [1.0, 0.5, 1.0]]))
    with pytest.raises(ValueError, match="extrapolate"):
        field.coordinates(outside, outside="extrapolate")


def test_bad_input_is_refused_clearly():
    vertices, triangles = TETRAHEDRON
    with pytest.raises(ValueError, match="resolution"):
        gencoords.harmonic_field(vertices, triangles, resolution=1)
    with pytest.raises(gencoords.CageError):
        gencoords.harmonic_field(vertices, triangles[:3])  # open
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(gencoords.CageError, match="3D"):
        gencoords.harmonic_field(square, np.array([[0, 1], [1, 2], [2, 3], [3, 0]]))


def test_top_k_keeps_the_largest_renormalised_and_truncate_agrees():
    coordinates = np.random.default_rng(7).dirichlet(np.ones(10), size=50)
    indices, weights = top_k(coordinates, 4)
    assert indices.shape == weights.shape == (50, 4)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    kept = np.take_along_axis(coordinates, indices, axis=1)
    assert (np.diff(kept, axis=1) <= 0).all()  # largest first
    assert (kept[:, -1:] >= np.sort(coordinates, axis=1)[:, -5:-4]).all()  # none larger left out
    dense = np.zeros_like(coordinates)
    np.put_along_axis(dense, indices, weights, axis=1)
    np.testing.assert_array_equal(dense, truncate(coordinates, 4))


def test_workers_give_what_one_process_gives():
    vertices, triangles = cage_of(t_pose_blocks())
    alone = gencoords.harmonic_field(vertices, triangles, resolution=40, workers=1)
    fractions = []
    spread = gencoords.harmonic_field(vertices, triangles, resolution=40, workers=2, progress=fractions.append)
    # The same blocks of columns in every process; only BLAS threads may round differently.
    np.testing.assert_allclose(spread.node_coordinates, alone.node_coordinates, rtol=0, atol=1e-13)
    assert fractions[-1] == pytest.approx(1.0)
    assert len(spread.convergence) == len(alone.convergence)


def test_on_the_artists_character_a_hand_moves_nothing_elsewhere_and_sparse_weights_are_exact():
    from tests.fixtures.character import body_points, cage_limb_vertices, character_cage, limb_labels
    vertices, quads = character_cage()
    triangles = gencoords.cages.triangulate_quads(vertices, quads)
    points = body_points(3000, seed=1)
    coordinates = gencoords.harmonic_coordinates(points, vertices, triangles, resolution=48)
    assert coordinates.min() >= 0.0
    hand = cage_limb_vertices(vertices, "left_arm")
    elsewhere = np.isin(limb_labels(points), ["right_arm", "right_leg", "left_leg"])
    print("character, left hand in the other limbs:", coordinates[np.ix_(elsewhere, hand)].max())
    assert coordinates[np.ix_(elsewhere, hand)].max() < 1e-5
    assert np.linalg.norm(coordinates @ vertices - points, axis=1).max() < 1e-12  # linear precision
    indices, weights = top_k(coordinates, 32)
    corrected, residual = reproduce_points(indices, weights, vertices, points)
    assert residual.max() < 1e-12 and corrected.min() >= 0.0


def test_the_trilinear_interpolation_places_points_and_is_continuous_across_cells():
    from types import SimpleNamespace
    from gencoords.harmonic.interpolation import trilinear

    grid = SimpleNamespace(origin=np.array([0.5, -1.0, 2.0]), spacing=0.25, cells=(6, 5, 7))
    rng = np.random.default_rng(11)
    points = grid.origin + rng.uniform(0.0, 1.0, (3000, 3)) * np.array(grid.cells) * grid.spacing
    corners, weights = trilinear(grid, points)
    assert corners.shape == (3000, 8, 3) and weights.min() >= 0.0
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    # Linear precision: the weights reproduce the point from the corners' positions.
    np.testing.assert_allclose(np.einsum("kc,kcN->kN", weights, grid.origin + grid.spacing * corners), points,
                               rtol=0, atol=1e-12)
    # Conforming: a function given at the nodes, interpolated just either side of the cells'
    # faces, agrees to the step.
    values = rng.uniform(size=tuple(c + 1 for c in grid.cells))

    def interpolated(at):
        corners, weights = trilinear(grid, at)
        return (weights * values[tuple(corners.transpose(2, 0, 1))]).sum(axis=1)

    for axis in range(3):  # on a cell face: that coordinate a whole number of cells
        across = points.copy()
        across[:, axis] = grid.origin[axis] + grid.spacing * rng.integers(1, grid.cells[axis], len(points))
        step = np.eye(3)[axis] * 1e-9
        np.testing.assert_allclose(interpolated(across - step), interpolated(across + step), rtol=0, atol=1e-7)


def test_the_interpolation_does_not_bend_along_the_cells_diagonals():
    """Issue 35: posed characters creased along the grid cells' diagonals. Inside a cell
    the interpolation's gradient is continuous: just either side of a plane through the
    cell's diagonal (where two of a point's fractions are equal, the faces along which
    piecewise-linear interpolation on Freudenthal's tetrahedra bends) it agrees to the
    step, for any values at the nodes."""
    from types import SimpleNamespace
    from gencoords.harmonic.interpolation import trilinear

    grid = SimpleNamespace(origin=np.array([0.5, -1.0, 2.0]), spacing=0.25, cells=(6, 5, 7))
    rng = np.random.default_rng(12)
    values = rng.uniform(size=tuple(c + 1 for c in grid.cells))  # gradients of about 1 / spacing

    def gradient(at, h=1e-6):
        def interpolated(x):
            corners, weights = trilinear(grid, x)
            return (weights * values[tuple(corners.transpose(2, 0, 1))]).sum(axis=1)
        return np.stack([(interpolated(at + h * e) - interpolated(at - h * e)) / (2 * h) for e in np.eye(3)], axis=1)

    cell = rng.integers(0, np.array(grid.cells), (2000, 3))
    fraction = rng.uniform(0.05, 0.95, (2000, 3))
    fraction[:, 1] = fraction[:, 0]  # on the plane f_x = f_y through the cell's diagonal
    on = grid.origin + grid.spacing * (cell + fraction)
    across = np.array([1.0, -1.0, 0.0]) * 1e-5
    jump = np.linalg.norm(gradient(on + across) - gradient(on - across), axis=1)
    assert jump.max() < 1e-2 * np.linalg.norm(gradient(on), axis=1).mean()


def test_the_nearest_exact_node_search_finds_what_a_search_of_every_node_finds():
    """The nearest exact node in the smallest block around the point (up to 7 nodes
    across) that holds one, as a search of every exact node finds it."""
    from gencoords.base.grid import node_positions
    from gencoords.harmonic.field import _nearest_exact_nodes

    vertices, faces = gencoords.cages.shapes.octahedron()  # convex: many nodes outside, not exact
    field = gencoords.harmonic_field(vertices, faces, resolution=16)
    grid, frame = field._grid, field._prepared
    exact_indices = field.node_indices[field.node_exact]
    points = frame.local(np.random.default_rng(12).uniform(-1.2, 1.2, (400, 3)))
    nearest, found = _nearest_exact_nodes(grid, field._ids, field.node_exact, points)
    centre = np.rint((points - grid.origin) / grid.spacing)
    reach = np.abs(exact_indices[None] - centre[:, None]).max(axis=2)  # (points, exact nodes), in nodes
    gaps = np.linalg.norm(points[:, None] - node_positions(grid, exact_indices)[None], axis=2)
    assert found.any() and (~found).any()
    np.testing.assert_array_equal(found, reach.min(axis=1) <= 3)
    assert field.node_exact[nearest[found]].all()
    block = np.maximum(reach.min(axis=1, keepdims=True), 1)  # blocks 3, 5 and 7 nodes across
    expected = np.where(reach <= block, gaps, np.inf).min(axis=1)[found]
    got = np.linalg.norm(node_positions(grid, field.node_indices[nearest[found]]) - points[found], axis=1)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
