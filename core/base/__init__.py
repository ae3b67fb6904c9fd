"""Bottom layer: tolerances, errors, simplex frames, cage topology and input checks."""
