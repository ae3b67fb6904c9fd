"""Each storage's module, by its id: what a plan's storage encodes, reproduces and
counts with (``encode``, ``reproduce``, ``plan_bytes``), so the planner asks the enum,
not a chain of string comparisons."""

from . import compact, exact, sparse, two_level
from .kinds import Storage

__all__ = ["codec"]

_CODECS = {Storage.EXACT: exact, Storage.COMPACT: compact, Storage.SPARSE: sparse}


def codec(storage):
    """The module of ``storage`` (a :class:`Storage` or its value; not ``AUTO``).

    Examples
    --------
    >>> from gencoords.storage import Storage
    >>> from gencoords.storage.codecs import codec
    >>> codec(Storage.SPARSE).__name__, codec("EXACT").__name__
    ('gencoords.storage.sparse', 'gencoords.storage.exact')
    """
    return _CODECS[Storage(storage)]


def plan_codec(plan):
    """The module of a plan's storage: two levels where its pairs are the grid nodes'."""
    return two_level if plan.node_count else codec(plan.storage)
