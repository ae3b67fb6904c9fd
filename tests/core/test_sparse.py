"""Sparse storage's pairs: rows sum to 1 (translations exact), the kept entries are the
largest, the deviations fall as K grows and agree with moving the cage, and the two-level
layout's residual is the interpolated node residual."""

import numpy as np
import pytest

import gencoords
from gencoords.cages.shapes import icosphere
from gencoords.storage import deviations, pair_deviations, sparse, two_level
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


@pytest.fixture(scope="module")
def cage_and_coordinates():
    rng = np.random.default_rng(23)
    vertices, faces = random_convex_polytope(rng, 3, 40)
    points = random_interior_points(rng, vertices, 300)
    return vertices, points, gencoords.coordinates(points, vertices, faces, kind="wachspress")


@pytest.mark.parametrize("count", [1, 4, 16, 40])
def test_pairs_sum_to_one_and_keep_the_largest(cage_and_coordinates, count):
    vertices, points, coordinates = cage_and_coordinates
    indices, weights = sparse.largest_pairs(coordinates, count)
    assert indices.shape == weights.shape == (len(points), count)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)
    kept = np.take_along_axis(coordinates, indices.astype(np.int64), axis=1)
    smallest_kept = kept.min(axis=1)
    dropped = coordinates.copy()
    np.put_along_axis(dropped, indices.astype(np.int64), -np.inf, axis=1)
    assert np.all(dropped.max(axis=1) <= smallest_kept + 1e-15)
    # A translated cage translates every point exactly, whatever K.
    shift = np.array([0.3, -1.2, 2.0])
    moved = sparse.dense_weights(indices, weights, len(vertices)) @ np.tile(shift, (len(vertices), 1))
    np.testing.assert_allclose(moved, np.tile(shift, (len(points), 1)), atol=1e-12)
    if count == len(vertices):  # every entry kept: the exact coordinates
        np.testing.assert_allclose(sparse.dense_weights(indices, weights, len(vertices)), coordinates,
                                   atol=1e-12)


def test_deviations_fall_with_count_and_match_moving_the_cage(cage_and_coordinates):
    vertices, _, coordinates = cage_and_coordinates
    drags = []
    for count in (4, 8, 16, 40):
        found, smooth, drag = sparse.fewest_slots(coordinates, vertices, 0.0, counts=(count,))
        assert found is None  # nothing is under a target of 0
        indices, weights = sparse.placed_pairs(coordinates, count, vertices)
        stored = sparse.dense_weights(indices, weights.astype(np.float32), len(vertices))
        moved = deviations.smooth_test_motion(vertices)
        direct = deviations.deviation(coordinates, stored, np.eye(len(vertices)), vertices, moved)
        assert smooth == pytest.approx(direct, rel=1e-9, abs=1e-15)
        drags.append(drag)
    assert drags == sorted(drags, reverse=True)
    assert drags[-1] < 1e-6  # float32 rounding only
    # Dense (Wachspress in a convex cage): only all 40 keep the drag under 1e-3.
    count, smooth, drag = sparse.fewest_slots(coordinates, vertices, 1e-3, counts=(4, 8, 16, 32, 40))
    assert count is not None and smooth < 1e-3 and drag < 1e-3
    assert sparse.fewest_slots(coordinates, vertices, 1e-3, counts=(4,))[0] is None


def test_two_level_residual_is_the_interpolated_node_residual(cage_and_coordinates):
    vertices, _, node_coordinates = cage_and_coordinates  # 300 "nodes"
    rng = np.random.default_rng(5)
    corners = rng.integers(0, len(node_coordinates), (50, 4))
    corner_weights = rng.dirichlet(np.ones(4), 50)
    points = pair_deviations.interpolated(node_coordinates, corners, corner_weights)
    np.testing.assert_allclose(points.sum(axis=1), 1.0, atol=1e-12)
    for count in (4, 12):
        _, smooth, drag = sparse.fewest_slots(node_coordinates, vertices, 0.0, counts=(count,),
                                             interpolation=(corners, corner_weights))
        indices, weights = sparse.placed_pairs(node_coordinates, count, vertices, span=True)  # as nodes are
        stored = sparse.dense_weights(indices, weights.astype(np.float32), len(vertices))
        residual = points - pair_deviations.interpolated(stored, corners, corner_weights)
        expected_smooth, expected_drag = deviations.residual_deviations(residual, vertices)
        assert smooth == pytest.approx(expected_smooth, rel=1e-9)
        assert drag == pytest.approx(expected_drag.max(), rel=1e-9)


def test_stacked_columns_put_every_slot_where_the_deformer_reads_it():
    rng = np.random.default_rng(2)
    values = rng.integers(1, 1000, (7, 11))
    columns, per_column = sparse.stacked_columns(values, 30)
    assert per_column == 4 and columns.shape == (30, 3)
    for a in range(7):
        for j in range(11):
            assert columns[(j % per_column) * 7 + a, j // per_column] == values[a, j]
    assert np.count_nonzero(columns) == values.size  # nothing else written
    with pytest.raises(ValueError):
        sparse.stacked_columns(values, 6)  # more nodes than rows


def test_used_nodes_renumber_the_corners():
    corners = np.random.default_rng(4).integers(0, 50, (20, 4))
    used, local = two_level.used_nodes(corners)
    np.testing.assert_array_equal(used[local], corners)
    assert len(used) == len(np.unique(corners))


def test_two_level_layout_meets_the_target_with_the_fewest_node_pairs(cage_and_coordinates):
    vertices, _, node_coordinates = cage_and_coordinates  # 300 "grid nodes"
    rng = np.random.default_rng(8)
    used, corners = two_level.used_nodes(rng.integers(0, 200, (500, 4)))  # the last 100 nodes unused
    kept = node_coordinates[used]
    corner_weights = rng.dirichlet(np.ones(4), 500)
    layout = two_level.two_level_layout(kept, corners, corner_weights, vertices, 1e-3, counts=(4, 8, 16, 32, 40))
    assert layout.node_count == len(used) <= 200
    np.testing.assert_array_equal(layout.corners, corners)
    assert max(layout.deviation_smooth, layout.deviation_drag) < 1e-3 and layout.reason is None
    fewer = (4, 8, 16, 32, 40)[(4, 8, 16, 32, 40).index(layout.node_slot_count) - 1]
    missed = pair_deviations.deviations(kept, *sparse.placed_pairs(kept, fewer, vertices), vertices,
                               (layout.corners, layout.corner_weights))
    assert max(missed[:2]) >= 1e-3 * two_level.SAMPLE_MARGIN  # one count fewer misses
    assert (layout.node_weights >= 0).all()  # non-negative coordinates stay so
    np.testing.assert_allclose(layout.node_weights.sum(axis=1), 1.0, atol=1e-6)
    # Each node's pairs place it where its coordinates do (float32 weights).
    places = np.einsum("nk,nkc->nc", layout.node_weights.astype(np.float64), vertices[layout.node_indices])
    np.testing.assert_allclose(places, kept @ vertices, atol=1e-6 * np.ptp(vertices))



@pytest.mark.parametrize("target", [1e-1, 1e-2, 3e-3, 1e-3])
def test_counts_tried_on_every_eighth_point_first_choose_as_every_point_does(cage_and_coordinates, monkeypatch,
                                                                             target):
    """The screen (a count missing on every SCREEN_STEP-th point misses on all) skips
    work only: the count, its deviations and pairs are those of trying each on all."""
    vertices, _, coordinates = cage_and_coordinates  # 300 points: screened
    counts = (4, 8, 16, 24, 32, 40)
    assert len(coordinates) > sparse.SCREEN_STEP * sparse.SCREEN_POINTS
    screened = sparse.fewest_pairs(coordinates, vertices, target, counts)
    monkeypatch.setattr(sparse, "SCREEN_POINTS", 10**9)
    everywhere = sparse.fewest_pairs(coordinates, vertices, target, counts)
    assert screened[:3] == everywhere[:3]
    np.testing.assert_array_equal(screened[3], everywhere[3])
    np.testing.assert_array_equal(screened[4], everywhere[4])


@pytest.mark.parametrize("target", [3e-2, 1e-2, 5e-3])
def test_the_screened_nodes_pairs_kept_for_every_point_are_those_of_placing_all_nodes(cage_and_coordinates,
                                                                                     monkeypatch, target):
    """Two levels: a count is tried on every 64th point's nodes, then every 8th's, then
    every node's, each try keeping the nodes placed before and placing the others; the
    count, deviations and pairs are bit for bit those of placing every node at each count."""
    vertices, _, node_coordinates = cage_and_coordinates  # 300 grid nodes
    rng = np.random.default_rng(12)
    corners = rng.integers(0, len(node_coordinates), (2100, 4))  # screened on 33 points, then on 263
    interpolation = (corners, rng.dirichlet(np.ones(4), len(corners)))
    counts = (4, 8, 16, 24, 32, 40)
    placed, place = [], sparse.placed_pairs
    monkeypatch.setattr(sparse, "placed_pairs", lambda rows, *rest: placed.append(len(rows)) or place(rows, *rest))
    screened = sparse.fewest_pairs(node_coordinates, vertices, target, counts, interpolation)
    assert placed[0] == len(np.unique(corners[::sparse.SCREEN_STEP ** 2])) < len(node_coordinates) / 2
    monkeypatch.setattr(sparse, "SCREEN_POINTS", 10**9)
    everywhere = sparse.fewest_pairs(node_coordinates, vertices, target, counts, interpolation)
    assert screened[0] not in (None, counts[-1])  # a count before the last passed its screen
    assert screened[:3] == everywhere[:3]
    np.testing.assert_array_equal(screened[3], everywhere[3])
    np.testing.assert_array_equal(screened[4], everywhere[4])


def test_two_level_node_pairs_are_each_nodes_own_whatever_the_sample(cage_and_coordinates):
    """The sample's nodes keep the pairs chosen on it, the others are placed after: each
    node's pairs are those of placing every node at once (rows computed alone)."""
    vertices, _, node_coordinates = cage_and_coordinates
    rng = np.random.default_rng(9)
    corners = rng.integers(0, 150, (4500, 4))
    corners[1::2] += 150  # the sample (every 2nd point) uses the first 150 nodes only
    used, corners = two_level.used_nodes(corners)
    assert len(used) == 300 and len(corners[::max(1, len(corners) // two_level.SAMPLE_POINTS)]) < 4500
    layout = two_level.two_level_layout(node_coordinates[used], corners, rng.dirichlet(np.ones(4), 4500), vertices,
                                        1e-2, counts=(4, 8, 16))
    indices, weights = sparse.placed_pairs(node_coordinates[used], layout.node_slot_count, vertices, span=True)
    np.testing.assert_array_equal(layout.node_indices, indices)
    np.testing.assert_array_equal(layout.node_weights, weights.astype(np.float32))


def test_kept_pairs_of_both_signs_are_completed_to_1_without_growing_beyond_the_missing_sum():
    """Rows of both signs whose kept values nearly cancel (power coordinates with gamma 16,
    extrapolated, as fuzz seed 261 bound them): divided by their sum they would grow
    hundreds of times; completed by size they grow by at most the missing sum, still sum
    to 1, and keep each value's sign. Non-negative rows are divided, exactly as before."""
    rng = np.random.default_rng(5)
    large = rng.uniform(1.0, 50.0, size=(200, 4))
    cancel = rng.uniform(-0.01, 0.01, size=200)  # what the 8 largest sum to
    small = rng.uniform(0.0, 2.0, size=(200, 22))
    small *= ((1.0 - cancel) / small.sum(axis=1))[:, None]  # coordinates: rows sum to 1
    signed = np.hstack([large, -large[:, ::-1], small])
    signed[:, 4] += cancel
    indices, weights = sparse.largest_pairs(signed, 8)
    kept = np.take_along_axis(signed, indices.astype(np.int64), axis=1)
    missing = np.abs(1.0 - kept.sum(axis=1))
    assert (np.abs(1.0 / kept.sum(axis=1)) > 100).any()  # a division would multiply some rows 100 times
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)
    assert (np.abs(weights).sum(axis=1) <= np.abs(kept).sum(axis=1) + missing + 1e-9).all()
    assert (np.sign(weights) == np.sign(kept)).all()
    positive = np.abs(signed[:20]) / np.abs(signed[:20]).sum(axis=1, keepdims=True)
    indices, weights = sparse.largest_pairs(positive, 8)
    kept = np.take_along_axis(positive, indices.astype(np.int64), axis=1)
    np.testing.assert_array_equal(weights, kept / kept.sum(axis=1, keepdims=True))

def test_placed_pairs_place_their_points_with_non_negative_weights(cage_and_coordinates):
    vertices, points, coordinates = cage_and_coordinates
    for count in (6, 16):
        largest = sparse.largest_pairs(coordinates, count)
        indices, weights = sparse.placed_pairs(coordinates, count, vertices, span=True)
        assert (weights > 0).all()
        np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)
        miss = np.linalg.norm(np.einsum("pk,pkc->pc", weights, vertices[indices]) - points, axis=1)
        dropped = np.linalg.norm(np.einsum("pk,pkc->pc", largest[1], vertices[largest[0]]) - points, axis=1)
        assert dropped.max() > 1e-2 and (miss < 1e-12).all()  # every point placed again
        # The largest cage vertices kept where they hold the point in their hull (most with 16 of 40); the
        # others keep 4 vertices that do.
        same = (indices == largest[0]).all(axis=1)
        assert same.mean() > (0.99 if count == 16 else 0.1)
        assert (np.isin(indices[~same], largest[0][~same]).sum(axis=1) >= count - 4).all()
    # Rows with a negative entry keep the truncated weights.
    mixed = coordinates[:5] + np.array([-0.05] + [0.05 / 39] * 39)
    np.testing.assert_array_equal(sparse.placed_pairs(mixed, 40, vertices)[1], sparse.largest_pairs(mixed, 40)[1])


def test_stacked_columns_of_triples_unstack_to_the_same_values():
    values = np.random.default_rng(9).random((5, 7, 3)).astype(np.float32)
    columns, per_column = sparse.stacked_columns(values, 12)
    assert per_column == 2 and columns.shape == (12, 4, 3)
    np.testing.assert_array_equal(sparse.unstacked(columns, 5, 7), values)


@pytest.mark.parametrize("point_count,node_count", [(43236, 5524), (1000, 999), (500, 20)])
def test_filled_node_slot_counts_take_no_more_columns_than_the_counts_asked(point_count, node_count):
    asked = two_level.NODE_SLOT_COUNTS
    filled = two_level.filled_node_slot_counts(asked, point_count, node_count, 196)
    assert list(filled) == sorted(set(filled)) and filled[-1] <= 196

    def columns(count):  # as the deformer stores them: three to a vector, stacked
        return sparse.stacked_columns(np.ones((node_count, -(-count // 3)), np.float32), point_count)[0].shape[1]

    for count in asked:
        kept = next(filled_count for filled_count in filled if filled_count >= min(count, 196))
        assert columns(kept) == columns(min(count, 196))  # the spare slots of the same columns


def test_the_last_count_places_every_row_without_copying_the_rows():
    """Measured on every row (the last stage, the only one of a single count), the rows
    are placed as given, not copied once for the stage and again for those to place
    (the hand's two-level Bind: its peak)."""
    import tracemalloc

    vertices, _ = icosphere(2)
    rng = np.random.default_rng(0)
    rows = rng.dirichlet(np.full(len(vertices), 0.05), 20000)
    interpolation = rng.integers(0, len(rows), (30000, 8)), rng.dirichlet(np.ones(8), 30000)
    tracemalloc.start()
    try:
        before, _ = tracemalloc.get_traced_memory()
        count, *_ = sparse.fewest_pairs(rows, vertices, 1e-3, (16,), interpolation=interpolation)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert count in (16, None) and peak - before < 1.5 * rows.nbytes  # two copies beside: 2.7 times


def test_a_two_level_layout_places_its_points_a_block_of_nodes_at_a_time():
    """Where the stored weights place the points, bit for bit the whole (N, K', 3) gather's
    result, with no such gather beside (the quadruped's Bind: 35 MB, its peak)."""
    import tracemalloc

    from gencoords.storage.pair_deviations import interpolated

    vertices, _ = icosphere(2)
    rng = np.random.default_rng(5)
    nodes, slots, points = 9000, 96, 20000
    layout = two_level.TwoLevelLayout(
        rng.integers(0, nodes, (points, 8)).astype(np.int32), rng.dirichlet(np.ones(8), points).astype(np.float32),
        rng.integers(0, len(vertices), (nodes, slots)).astype(np.int32),
        rng.dirichlet(np.ones(slots), nodes).astype(np.float32), 0.0, 0.0, 0)
    whole = np.einsum("nk,nkc->nc", layout.node_weights.astype(np.float64), vertices[layout.node_indices])
    tracemalloc.start()
    try:
        placed = layout.placed_points(vertices)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert placed.tobytes() == interpolated(whole, layout.corners, layout.corner_weights).tobytes()
    assert peak < 0.35 * nodes * slots * 3 * 8


def test_pairs_placed_a_block_of_rows_at_a_time_are_those_of_all_at_once():
    """fewest_pairs places the rows PLACED_ROWS at a time (a copy of every row not yet
    placed was 5.6 MB of the cup's Bind): each row's pairs are its own, bit for bit."""
    rng = np.random.default_rng(5)
    vertices, faces = random_convex_polytope(rng, 3, 40)
    points = random_interior_points(rng, vertices, 3 * sparse.PLACED_ROWS + 17)
    rows = gencoords.coordinates(points, vertices, faces, kind="mean_value", workers=1)
    assert len(rows) > 3 * sparse.PLACED_ROWS
    _, _, _, indices, weights = sparse.fewest_pairs(rows, vertices, 1e-3, counts=(8,))
    whole = sparse.placed_pairs(rows, 8, vertices, places=rows @ vertices)
    np.testing.assert_array_equal(indices, whole[0])
    np.testing.assert_array_equal(weights, whole[1])
