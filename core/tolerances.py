"""Every tolerance of the package, in one place (as trimesh's ``tol``).

Lengths are relative to the cage's size (its bounding-box diagonal), so the same
numbers hold for cages of any scale.
"""

# Points this close to the boundary (of the cage's size) are on it; also the flatness
# and coincidence threshold of cage checks. For float64 input.
DEFAULT = 1e-9
# The same for data stored as float32 (Blender's positions): a flat face after a
# rotation is flat only to ~1e-7 of its size, so float32 data needs a wider margin.
FLOAT32 = 1e-6
# Below this a coordinate counts as negative (rounding noise of exact zeros is not).
NEGATIVE = 1e-9
# Guards a division by a length or sum that can be zero (degenerate input).
TINY = 1e-300
