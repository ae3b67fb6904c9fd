"""Harmonic coordinates on a grid: local and non-negative in any closed cage.

Modules, bottom up (on ``gencoords.base.grid``: cubic cells fitted to the cage's box,
inside nodes): ``boundary_values`` (the cage's hat values at nodes outside it, and where
grid edges cross it), ``elimination`` and ``multigrid`` (the Laplace solvers: direct by
slabs, iterative), ``solve`` (every cage vertex's Shortley-Weller problem),
``interpolation`` (trilinear lookup, 8 nodes a point), ``reproduction`` (weights
reweighted to place their points exactly), ``inside`` (whether points are inside the
cage, its quads their patches), ``field`` (the public :class:`HarmonicField`),
``grid_field`` (solving one: :func:`harmonic_field`).
"""

from .field import DEFAULT_RESOLUTION, HarmonicField
from .grid_field import harmonic_coordinates, harmonic_field, harmonic_quad_field

__all__ = ["DEFAULT_RESOLUTION", "HarmonicField", "harmonic_field", "harmonic_quad_field", "harmonic_coordinates"]
