"""The artist's side: the settings (``properties``), the operators, the panel and its status
lines, Show Coordinate's colours (``visualise``)."""
