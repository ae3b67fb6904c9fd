"""The paper's advanced API: ridge scalars, the general construction from any d,
numerical generating surfaces, Floater's construction and completeness.

Everyday use needs only the top level (``gencoords.coordinates``); these are the pieces
of Ju, Liepa and Warren's construction for users who supply their own surface or d.
"""

from .construction.completeness import floater_matrix, floater_scalars
from .construction.floater import floater_from_ridge_scalars, floater_weights, ridge_scalars_from_floater
from .construction.green_deform import stretch_factors
from .construction.validation import concave_facets, validate_cage
from .evaluation.barycentric import (OUTSIDE_MODES, ridge_scalars, ridge_scalars_from_surface, ridges,
                                     weights_from_ridge_scalars)
from .surfaces.named import CONVEX_ONLY_KINDS, KINDS

__all__ = [
    "ridges", "ridge_scalars", "ridge_scalars_from_surface", "weights_from_ridge_scalars",
    "floater_weights", "floater_matrix", "floater_scalars", "ridge_scalars_from_floater",
    "floater_from_ridge_scalars", "stretch_factors", "validate_cage", "concave_facets", "KINDS", "CONVEX_ONLY_KINDS", "OUTSIDE_MODES",
]
