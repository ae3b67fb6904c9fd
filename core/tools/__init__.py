"""Tools beside the construction: colours and summaries of coordinate fields, reports,
cage preparation (triangulation, orientation, enclosing cages), compact bind-data storage,
skinning (truncated coordinates, and skins fitted to a deformation) and example shapes
(the modules ``compact``, ``skinning``, ``skin_fit``, ``shapes``, ``enclosing``).
"""

from ..base import tolerances
from ..base.orientation import orient_facets_outward
from ..base.triangulation import triangulate_quads
from ..evaluation.deformation import coordinate_summary, field_colors, field_range, linear_precision
from . import compact, enclosing, shapes, skin_fit, skinning
from .report import CoordinateReport, coordinate_report

__all__ = [
    "field_colors", "field_range", "coordinate_summary", "linear_precision", "coordinate_report", "CoordinateReport",
    "triangulate_quads", "orient_facets_outward", "tolerances",
    "compact", "enclosing", "shapes", "skin_fit", "skinning",
]
