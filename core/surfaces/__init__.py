"""Generating surfaces: the named kinds (mean value, Wachspress, discrete harmonic, Voronoi,
the power family) and numerical surfaces."""
