"""Reports on coordinate fields: colours and ranges for display, a summary of negative
coordinates, linear precision, and a kind's report in a cage (``coordinate_report``)."""

from .fields import coordinate_summary, field_colors, field_range, linear_precision
from .report import CoordinateReport, coordinate_report

__all__ = ["field_colors", "field_range", "coordinate_summary", "linear_precision", "coordinate_report",
           "CoordinateReport"]
