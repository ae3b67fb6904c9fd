"""How a Bind's coordinates are stored on the mesh: the storage ids (:class:`Storage`)
and one module each owning its encoding, decoding (``reproduce``) and byte count
(``exact``, ``compact``, ``sparse``, ``two_level``; ``codecs`` picks one by its id), with
the deviations they are measured by (``deviations``, ``pair_deviations``)."""

from . import codecs, compact, deviations, exact, pair_deviations, sparse, two_level
from .kinds import Storage

__all__ = ["Storage", "codecs", "exact", "compact", "sparse", "two_level", "deviations", "pair_deviations"]
