"""Harmonic coordinates on a grid (core/harmonic): the properties docs/MATH.md states."""

import numpy as np
import pytest

import gencoords
from gencoords.harmonic.boundary_values import nearest_boundary_points
from gencoords.harmonic.multigrid import build_levels, solve
from gencoords.tools.shapes import block_cage, t_pose_blocks
from gencoords.tools.skinning import reproduce_points, top_k, truncate

TETRAHEDRON = (np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
               np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))


def cage_of(occupied):
    vertices, quads = block_cage(occupied)
    return vertices, gencoords.tools.triangulate_quads(vertices, quads)


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


def scipy_solution(field):
    """The same discrete system, assembled here and solved by scipy's sparse LU."""
    sparse = pytest.importorskip("scipy.sparse")
    linalg = pytest.importorskip("scipy.sparse.linalg")
    ids = np.full(field.shape, -1)
    ids[tuple(field.node_indices.T)] = np.arange(len(field.node_indices))
    unknown = np.flatnonzero(field.node_inside)
    # The Dirichlet nodes' values: their nearest boundary point's hat values.
    columns, values, _ = nearest_boundary_points(field.node_positions, field.vertices, field.faces, 1.0)
    hats = np.zeros((len(field.node_indices), len(field.vertices)))
    np.add.at(hats, (np.arange(len(hats))[:, None], columns), values)
    row_of = np.full(len(field.node_indices), -1)
    row_of[unknown] = np.arange(len(unknown))
    rows, columns, rhs = list(range(len(unknown))), list(range(len(unknown))), np.zeros((len(unknown), len(field.vertices)))
    values = [6.0] * len(unknown)
    for axis in range(3):
        for sign in (-1, 1):
            neighbour = field.node_indices[unknown].copy()
            neighbour[:, axis] += sign
            other = ids[tuple(neighbour.T)]
            solved = field.node_inside[other]
            rows += np.flatnonzero(solved).tolist()
            columns += row_of[other[solved]].tolist()
            values += [-1.0] * int(solved.sum())
            rhs[~solved] += hats[other[~solved]]
    matrix = sparse.csc_matrix((values, (rows, columns)), shape=(len(unknown), len(unknown)))
    return linalg.spsolve(matrix, rhs), unknown


@pytest.mark.parametrize("occupied", [np.ones((2, 1, 1), dtype=bool), t_pose_blocks()], ids=["bar", "t_pose"])
def test_the_multigrid_solution_is_the_discrete_systems_as_scipy_solves_it(occupied):
    vertices, triangles = cage_of(occupied)
    field = gencoords.harmonic_field(vertices, triangles, resolution=20)
    reference, unknown = scipy_solution(field)
    assert reference.min() > -1e-14  # the discrete maximum principle, independently
    # The field keeps the solution reweighted to place each node (docs/MATH.md).
    every = np.broadcast_to(np.arange(len(vertices)), reference.shape)
    placed, residual = reproduce_points(every, reference.clip(0.0), vertices, field.node_positions[unknown])
    assert residual.max() < 1e-12
    np.testing.assert_allclose(field.node_coordinates[unknown], placed, rtol=0, atol=1e-8)


def test_each_conjugate_gradient_iteration_reduces_the_residual_tenfold(t_pose):
    history = t_pose[3].convergence
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
    from scripts.common.character import body_points, cage_limb_vertices, character_cage, limb_labels
    vertices, quads = character_cage()
    triangles = gencoords.tools.triangulate_quads(vertices, quads)
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
