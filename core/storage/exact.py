"""Exact storage: every coordinate of every point, as float32, three to a vector
attribute (the last one padded). The deformation is exact to float32 rounding; it costs
k x n numbers and multiply-adds.
"""

import numpy as np

__all__ = ["attribute_bytes"]


def attribute_bytes(point_count, slot_count):
    """Bytes of ``slot_count`` float32 slots per point, three to a vector attribute.

    Examples
    --------
    >>> from gencoords.storage.exact import attribute_bytes
    >>> attribute_bytes(1000, 42), attribute_bytes(1000, 43)  # 14 vectors, then 15
    (168000, 180000)
    """
    return point_count * 3 * -(-slot_count // 3) * 4


def encode(choice, coordinates, rest=None):
    """The slots of ``coordinates`` ((j, rows) float64): (j, rows) float32, no indices (None)."""
    return coordinates.astype(np.float32), None


def reproduce(choice, slots, indices=None, rows=None):
    """The coordinates the deformer reproduces from ``slots`` ((j, rows) float32): float64."""
    return slots.astype(np.float64)


def plan_bytes(plan):
    """Bytes of an exact plan's attributes."""
    return attribute_bytes(len(plan.slots), plan.slot_count)
