"""Each storage's home: a module per storage (``exact``, ``compact``, ``sparse``, and
``two_level``: sparse storage of harmonic coordinates) that writes and reads its attributes,
counts their bytes and builds its part of the deformer's node group, with the same
functions (``nbytes``, ``write_steps``, ``read_coordinates``, ``read_column``,
``group_steps``); :func:`of` picks a binding's. The attributes' names are the file's layout
(``bind_layout``); the mechanics the storages share stay shared (``graph.deformer``,
``graph.chunks``, ``bind.attributes``).
"""

from ...core.storage import Storage
from . import compact, exact, sparse, two_level

# The storage a binding is written in -> its module (two levels: see :func:`of`).
MODULES = {Storage.EXACT: exact, Storage.COMPACT: compact, Storage.SPARSE: sparse}


def of(data):
    """The module of the storage the binding ``data`` (a ``BindData``) is written in:
    sparse storage with grid nodes is ``two_level``."""
    storage = Storage(data.storage)
    return two_level if storage is Storage.SPARSE and data.node_count else MODULES[storage]


__all__ = ["MODULES", "Storage", "of"]
