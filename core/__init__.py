"""GenCoords core: generalized barycentric coordinates in simplicial cages.

Ju, Liepa and Warren's general construction (CAGD 2007) in pure numpy: one N-D routine
parameterised by ridge scalars d (a generating surface) gives Wachspress, mean value,
discrete harmonic and Voronoi coordinates, Floater's construction, and, by completeness,
every other set of coordinates. Mean value coordinates work in any closed, consistently
oriented cage, convex or not; the other kinds need a convex cage and say so
(``CONVEX_ONLY_KINDS``, ``needs_convex``). Conventions and formulas: ``docs/MATH.md``;
array shapes are in every docstring (k points, n vertices, m facets, r ridges, dimension N).
"""

from . import tolerances
from .boundary import BOUNDARY, INSIDE, OUTSIDE
from .construction import weights_from_ridge_scalars
from .cage import Cage
from .barycentric import (OUTSIDE_MODES, coordinates, needs_convex, point_locations, ridge_scalars,
                          ridge_scalars_from_surface, weights)
from .deformation import coordinate_summary, deform, field_colors, field_range
from .errors import AccuracyWarning, CageError, OutsideCageError, WorkerError, WorkerWarning
from .completeness import floater_matrix, floater_scalars
from .floater import floater_from_ridge_scalars, floater_weights, ridge_scalars_from_floater
from .generating_surfaces import CONVEX_ONLY_KINDS, KIND_TABLE, KINDS
from .orientation import orient_facets_outward
from .report import CoordinateReport, coordinate_report
from .topology import ridges
from .triangulation import triangulate_quads
from .validation import DEFAULT_TOLERANCE, validate_cage

__all__ = [
    "Cage", "coordinates", "weights", "ridges", "ridge_scalars", "ridge_scalars_from_surface", "weights_from_ridge_scalars",
    "floater_weights", "floater_matrix", "ridge_scalars_from_floater", "floater_from_ridge_scalars",
    "floater_scalars", "point_locations", "validate_cage", "needs_convex", "deform",
    "field_colors", "field_range", "coordinate_summary", "triangulate_quads", "orient_facets_outward",
    "CageError", "OutsideCageError", "WorkerError", "WorkerWarning", "AccuracyWarning", "KINDS", "KIND_TABLE",
    "coordinate_report", "CoordinateReport", "CONVEX_ONLY_KINDS", "OUTSIDE_MODES", "DEFAULT_TOLERANCE", "INSIDE", "BOUNDARY", "OUTSIDE",
]
