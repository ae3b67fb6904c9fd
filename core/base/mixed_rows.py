"""A (g, n) matrix kept as whole rows where they are dense and as a few (column, value)
pairs where they are sparse: a harmonic field's node coordinates (the cup's: 9,700 solved
nodes dense, 25,000 boundary nodes of at most 32 non-zero coordinates of 322, 25 + 10 MB
against 90 MB dense)."""

import numpy as np

__all__ = ["MixedRows"]


class MixedRows:
    """Rows of a (g, n) float64 matrix, each held whole or as padded sparse pairs.

    Parameters
    ----------
    dense : (d, n) float
        The rows held whole, in any order (kept, not copied: the caller's array).
    dense_rows : (d,) int
        Which of the g rows each is (distinct).
    count : int
        g: every row not in ``dense_rows`` is sparse, zero until :meth:`set_pairs`.
    width : int
        Pairs a sparse row holds at most.

    Attributes
    ----------
    dense : (d, n) float
    row_of : (g,) int
        Row i is ``dense[row_of[i]]`` where ``row_of[i] >= 0``, else sparse row
        ``-1 - row_of[i]``.
    columns, values : (s, width) int32 and float
        The sparse rows' pairs; a padding pair's value is 0.

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.base.mixed_rows import MixedRows
    >>> rows = MixedRows(np.array([[0.5, 0.5, 0.0]]), np.array([1]), 3, 2)
    >>> rows.set_pairs(np.array([2]), np.array([[2, 0]]), np.array([[0.75, 0.25]]))
    >>> rows.rows(np.array([2, 1, 0])).tolist()
    [[0.25, 0.0, 0.75], [0.5, 0.5, 0.0], [0.0, 0.0, 0.0]]
    """

    def __init__(self, dense, dense_rows, count, width):
        self.dense = dense
        sparse = np.ones(count, dtype=bool)
        sparse[dense_rows] = False
        self.row_of = np.empty(count, dtype=np.int64)
        self.row_of[dense_rows] = np.arange(len(dense_rows))
        self.row_of[sparse] = -1 - np.arange(np.count_nonzero(sparse))
        self.columns = np.zeros((count - len(dense_rows), width), dtype=np.int32)
        self.values = np.zeros((count - len(dense_rows), width))

    @property
    def shape(self):
        return len(self.row_of), self.dense.shape[1]

    @property
    def nbytes(self):
        return self.dense.nbytes + self.row_of.nbytes + self.columns.nbytes + self.values.nbytes

    def set_pairs(self, rows, columns, values):
        """Sparse ``rows`` ((k,) int) set to their pairs ((k, w) int and float, w at most
        the width; columns distinct within a row where values are non-zero)."""
        sparse = -1 - self.row_of[rows]
        if (sparse < 0).any():
            raise ValueError("only sparse rows take pairs")
        width = columns.shape[1]
        self.columns[sparse, :width], self.values[sparse, :width] = columns, values
        self.columns[sparse, width:], self.values[sparse, width:] = 0, 0.0

    def rows(self, ids, out=None):
        """Rows ``ids`` ((k,) int) whole: (k, n) float64, into ``out`` where given."""
        out = np.empty((len(ids), self.shape[1])) if out is None else out
        where = self.row_of[ids]
        if len(self.dense):
            np.take(self.dense, np.maximum(where, 0), axis=0, out=out, mode="clip")  # "raise" copies first
        sparse = np.flatnonzero(where < 0) if len(self.dense) else np.arange(len(ids))
        if len(sparse):
            out[sparse] = 0.0
            pairs = -1 - where[sparse]
            values = self.values[pairs]
            real = values != 0.0  # padding, and zeros: the row holds 0 there already
            out[np.broadcast_to(sparse[:, None], real.shape)[real], self.columns[pairs][real]] = values[real]
        return out

    def toarray(self):
        """Every row whole: (g, n) float64, a new array."""
        return self.rows(np.arange(len(self.row_of)))
