"""Tools beside the construction: colours and summaries of coordinate fields, reports,
cage preparation (triangulation, orientation, enclosing cages), compact bind-data storage,
skinning (truncated coordinates, and skins fitted to a deformation), sparse storage,
example shapes, Bind planning, volumes, self-intersection, surface measures and tight
cages (the modules ``compact``, ``sparse``, ``skinning``, ``skin_fit``, ``shapes``,
``enclosing``, ``bind_plan``, ``volumes``, ``self_intersection``, ``surface``,
``tight_cage``).
"""

from ..base import tolerances
from ..base.orientation import orient_facets_outward
from ..base.triangulation import triangulate_quads
from ..evaluation.deformation import coordinate_summary, field_colors, field_range, linear_precision
from . import (bind_plan, compact, enclosing, self_intersection, shapes, skin_fit, skinning, sparse,
               surface, tight_cage, volumes)
from .report import CoordinateReport, coordinate_report

__all__ = [
    "field_colors", "field_range", "coordinate_summary", "linear_precision", "coordinate_report", "CoordinateReport",
    "triangulate_quads", "orient_facets_outward", "tolerances",
    "bind_plan", "compact", "enclosing", "shapes", "skin_fit", "skinning", "sparse", "volumes",
    "self_intersection", "surface", "tight_cage",
]
