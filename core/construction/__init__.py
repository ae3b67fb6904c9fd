"""The construction: the general N-D routine, cage preparation and validation, length
units, boundary limits, Floater, completeness, polar duals and Green coordinates."""
