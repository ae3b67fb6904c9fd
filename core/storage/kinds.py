"""The storage ids: what a Bind is asked for (a setting) and what it writes.

The values are the strings the panel's enum and the file's ``BindData.storage`` already
hold, so ``Storage("SPARSE")`` reads an older file and ``Storage.SPARSE == "SPARSE"``.
"""

import enum

__all__ = ["Storage"]


class Storage(str, enum.Enum):
    """A storage: ``AUTO`` (a setting only: Automatic measures and chooses), ``EXACT``
    (every coordinate), ``COMPACT`` (projections on a basis of cage motions) or ``SPARSE``
    (each vertex's largest (cage vertex, weight) pairs; for harmonic coordinates in two
    levels, each vertex its grid nodes and each node its pairs).

    Examples
    --------
    >>> from gencoords.storage import Storage
    >>> Storage("SPARSE") is Storage.SPARSE, Storage.EXACT == "EXACT"
    (True, True)
    """

    AUTO = "AUTO"
    EXACT = "EXACT"
    COMPACT = "COMPACT"
    SPARSE = "SPARSE"

    def __str__(self):
        return self.value

    def __repr__(self):  # as the string it equals: messages and printed tuples read the same
        return repr(self.value)
