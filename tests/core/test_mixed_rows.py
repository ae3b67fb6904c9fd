"""``base.mixed_rows.MixedRows``: a matrix kept as dense rows and padded sparse pairs reads
back, row by row, as the dense matrix it stands for."""

import numpy as np
import pytest

from gencoords.base.mixed_rows import MixedRows


def _random_mixed(seed, count=60, width=7, pairs=3):
    """A MixedRows of ``count`` rows, a third dense in a shuffled order, the others with
    up to ``pairs`` pairs (padding pairs, column 0, value 0), and its dense matrix."""
    rng = np.random.default_rng(seed)
    matrix = np.zeros((count, width))
    dense_rows = rng.permutation(count)[:count // 3]
    matrix[dense_rows] = rng.random((len(dense_rows), width))
    mixed = MixedRows(matrix[dense_rows].copy(), dense_rows, count, pairs)
    sparse = np.setdiff1d(np.arange(count), dense_rows)
    columns = np.array([rng.permutation(width)[:pairs] for _ in sparse])
    values = rng.random(columns.shape)
    values[rng.random(values.shape) < 0.3] = 0.0
    columns[values == 0.0] = 0  # padding names column 0, which a real pair may hold too
    for row, row_columns, row_values in zip(sparse, columns, values):
        matrix[row, row_columns[row_values != 0.0]] = row_values[row_values != 0.0]
    mixed.set_pairs(sparse, columns, values)
    return mixed, matrix


@pytest.mark.parametrize("seed", range(4))
def test_rows_in_any_order_are_the_dense_matrixs_bit_for_bit(seed):
    mixed, matrix = _random_mixed(seed)
    ids = np.random.default_rng(seed).integers(0, len(matrix), 200)  # repeats, any order
    assert mixed.rows(ids).tobytes() == matrix[ids].tobytes()
    out = np.full((len(ids), matrix.shape[1]), np.nan)
    assert mixed.rows(ids, out) is out and out.tobytes() == matrix[ids].tobytes()
    assert mixed.toarray().tobytes() == matrix.tobytes() and mixed.shape == matrix.shape


def test_fewer_pairs_than_the_width_clear_the_rest_and_dense_rows_take_none():
    mixed, _ = _random_mixed(7)
    sparse = np.flatnonzero(mixed.row_of < 0)[:2]
    mixed.set_pairs(sparse, np.array([[4], [5]]), np.array([[1.0], [1.0]]))
    assert mixed.rows(sparse).tolist() == np.eye(7)[[4, 5]].tolist()
    with pytest.raises(ValueError, match="sparse rows"):
        mixed.set_pairs(np.flatnonzero(mixed.row_of >= 0)[:1], np.array([[0]]), np.array([[1.0]]))


def test_no_dense_row_at_all():
    mixed = MixedRows(np.zeros((0, 3)), np.zeros(0, dtype=int), 2, 2)
    mixed.set_pairs(np.array([1]), np.array([[2, 0]]), np.array([[0.5, 0.5]]))
    assert mixed.rows(np.array([1, 0, 1])).tolist() == [[0.5, 0.0, 0.5], [0.0, 0.0, 0.0], [0.5, 0.0, 0.5]]
