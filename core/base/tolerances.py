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
# The accepted range of a user's tolerance: (0, LARGEST]. Beyond 1e-3 of the cage's
# size the "boundary limit" is taken visibly off the boundary (0.1 moves coordinates by
# ~0.2) and distinct vertices of fine cages start to "coincide".
LARGEST = 1e-3
# Coordinates as stored (float32 in Blender, compact storage's reproduction) must place
# their point, sum_j b_j v_j, within this of the cage's size: huge coordinates (power
# coordinates with large |gamma| in irregular cages reach 1e9) lose it to float32 rounding.
LINEAR_PRECISION = 1e-5
# ... and sum to 1 within this: a cage translated by d leaves the points behind by this
# share of d. Looser than the placing, which refuses huge coordinates first wherever it
# is checked (power coordinates with gamma -8 in Suzanne's fitted cage reach 563 and miss
# by 2e-5 as float32, and place their points within it); sparse storage, whose dropped
# pairs move points by design, is held to this alone.
TRANSLATION_PRECISION = 1e-4
# A vertex's weights also multiply the float32 rounding of the cage's positions (half an
# epsilon of their distance from the origin they are measured from): as the cage moves,
# the vertex jitters by up to sum_j |w_j| such roundings. Up to this many is what any
# deformer has (Mesh Deform's non-negative weights: 1 rounding); beyond it, the jitter is
# held to TRANSLATION_PRECISION of the cage's size (Suzanne's power coordinates with gamma
# -8 sum to 1,900 in magnitude, 4e-5 of its size in jitter; fuzz seed 261's sparse pairs
# reached 1e4 when their renormalisation divided by a small sum).
ROUNDING_AMPLIFICATION = 8
# Below this a coordinate counts as negative (rounding noise of exact zeros is not).
NEGATIVE = 1e-9
# Guards a division by a length or sum that can be zero (degenerate input).
TINY = 1e-300
# Target weights w are homogeneous at x when the least-squares residual of Floater's
# system is below this, relative to |w| (rounding gives ~1e-14; a wrong w, ~1e-1).
HOMOGENEOUS = 1e-8
# Cages and points are mapped to a frame where the cage has unit size. The smallest
# cage diagonal accepted: below it the vertices' differences are subnormal numbers
# with too few bits to be relied on.
SMALLEST_SIZE = 2.0 ** -1000
# Points farther than this many cage sizes from the cage are refused: the formulas'
# products of up to ~6 such distances would overflow float64.
FARTHEST = 1e30
# Mean value extrapolation outside a cage whose thinnest extent is below this fraction
# of its size can lose accuracy (cancellation in near-flat solid angles: 1:1:1e-4
# loses 0.15, 1:1:1e-2 3e-7): such results are re-evaluated to estimate their error...
FLAT = 1e-2
# ... and an AccuracyWarning is given when that estimate exceeds this.
ACCURACY = 1e-6
# A measured length degree (construction/units.py) this close to an integer is that integer.
INTEGER_DEGREE = 1e-9
# coordinate_report's boundary sample: points moved inward by this of the cage's size.
REPORT_NEAR_BOUNDARY = 1e-3
# coordinate_report calls the coordinates well defined while the smallest weight sum
# (of the weights' magnitudes) stays above this.
WELL_DEFINED_WEIGHT_SUM = 1e-6
# Coordinates more negative than this cannot become skinning weights; less negative ones
# (float32 rounding, compact storage's reproduction) are clamped to 0 by the vertex
# groups, and the deviation that makes is measured.
SKINNING_NEGATIVE = 1e-5
