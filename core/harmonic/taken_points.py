"""Which of a set of points kept a later set is (a run of them, or every s-th of them),
so that :meth:`gencoords.harmonic.field.HarmonicField.sparse_rows` serves a Bind's
sample and written chunks from the rows of every point, located and placed once."""

import numpy as np

__all__ = ["taken_slice", "taken_rows"]

_FIRST_MATCHES = 4  # kept points where a run or sample may start (a point repeated: a few)


def taken_slice(kept, points):
    """The slice of the points ``kept`` ((k, 3)) that ``points`` ((j, 3)) are, or None: a
    run of them (a Bind's chunk) or every s-th of them from one on to about the last (a
    sample).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.taken_points import taken_slice
    >>> kept = np.arange(30.0).reshape(10, 3)
    >>> taken_slice(kept, kept[3:7]), taken_slice(kept, kept[::4]), taken_slice(kept, kept[1::4])
    (slice(3, 7, 1), slice(0, 9, 4), slice(1, 10, 4))
    >>> taken_slice(kept, kept[::-1]) is None
    True
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or not len(points) or len(points) > len(kept):
        return None
    for start in np.flatnonzero((kept == points[0]).all(axis=1))[:_FIRST_MATCHES]:
        every = max(1, (len(kept) - 1 - start) // max(1, len(points) - 1))
        for step in dict.fromkeys((1, every)):
            taken = slice(int(start), int(start) + step * (len(points) - 1) + 1, step)
            if len(kept[taken]) == len(points) and np.array_equal(kept[taken], points):
                return taken
    return None


def taken_rows(rows, taken):
    """``HarmonicField.sparse_rows``' rows (nodes, weights, cut, columns, values) of the
    points ``taken`` (a slice), from those of all: copies (each point's rows are its own).

    Examples
    --------
    >>> import numpy as np
    >>> from gencoords.harmonic.taken_points import taken_rows
    >>> cut = np.array([False, True, False, True])
    >>> rows = (np.arange(4)[:, None], np.ones((4, 1)), cut, np.array([[7], [9]]), np.array([[1.0], [1.0]]))
    >>> [part.tolist() for part in taken_rows(rows, slice(1, 4, 2))]
    [[[1], [3]], [[1.0], [1.0]], [True, True], [[7], [9]], [[1.0], [1.0]]]
    """
    nodes, weights, cut, columns, values = rows
    taken = np.arange(len(cut))[taken]
    pairs = (np.cumsum(cut) - 1)[taken[cut[taken]]]  # their rows among the cut points'
    return nodes[taken], weights[taken], cut[taken], columns[pairs], values[pairs]
