"""How a Bind's coordinates are stored on the mesh: the storage ids (:class:`Storage`) and,
one module each, the storages' encodings, decodings and byte counts."""

from . import compact, sparse
from .kinds import Storage

__all__ = ["Storage", "compact", "sparse"]
