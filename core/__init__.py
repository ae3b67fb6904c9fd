"""GenCoords core: generalized barycentric coordinates in simplicial cages.

Ju, Liepa and Warren's general construction (CAGD 2007) in pure numpy: one N-D routine
parameterised by ridge scalars d (a generating surface) gives Wachspress, mean value,
discrete harmonic and Voronoi coordinates, Floater's construction, and, by completeness,
every other set of coordinates. Mean value coordinates work in any closed, consistently
oriented cage, convex or not; the other kinds need a convex cage and say so
(``needs_convex``, ``KIND_TABLE``). Conventions and formulas: ``docs/MATH.md``; array
shapes are in every docstring (k points, n vertices, m facets, r ridges, dimension N).

Installed as ``gencoords`` (``pip install .``); the folder is ``core/``. The top level is
the everyday API; the paper's advanced API is :mod:`gencoords.advanced`; beside them, by
purpose: :mod:`gencoords.cages` (preparing cages, example shapes, enclosing and tight
cages), :mod:`gencoords.reports` (colours, summaries, reports of coordinate fields),
:mod:`gencoords.storage` (how a Bind stores coordinates), :mod:`gencoords.skinning` (skins
from coordinates) and :mod:`gencoords.planning` (a Bind without Blender).
Layers, bottom up: ``base`` (frames, topology, input checks, tolerances, errors),
``surfaces`` (named, power and numerical generating surfaces), ``construction`` (the
general construction, boundary limits, Floater, completeness, Green), ``evaluation``
(the cage object, row evaluation, workers), ``harmonic`` (harmonic coordinates on a
grid: local and non-negative in any closed 3D cage); above them the folders by purpose.
"""

__version__ = "0.1.0"  # the one source: pyproject.toml reads it, the manifest repeats it

from .base.errors import AccuracyWarning, CageError, OutsideCageError, WorkerError, WorkerWarning
from .construction.boundary import BOUNDARY, INSIDE, OUTSIDE
from .construction.validation import DEFAULT_TOLERANCE
from .construction.green_deform import green_deform
from .construction.quad_cage import MEAN_VALUE_QUADS
from .evaluation.quad_coordinates import mean_value_quad_coordinates
from .evaluation.barycentric import coordinates, green_coordinates, needs_convex, point_locations, weights
from .evaluation.cage import Cage
from .evaluation.deformation import deform
from .surfaces.named import KIND_TABLE
from .harmonic import HarmonicField, harmonic_coordinates, harmonic_field, harmonic_quad_field
from . import advanced, cages, planning, reports, skinning, storage  # noqa: E402  (the named sub-APIs)

SUB_APIS = (advanced, cages, reports, storage, skinning, planning)  # each lists its names in __all__

__all__ = [
    "Cage", "coordinates", "weights", "point_locations", "deform", "green_coordinates", "green_deform",
    "harmonic_coordinates", "harmonic_field", "harmonic_quad_field", "HarmonicField", "mean_value_quad_coordinates", "MEAN_VALUE_QUADS",
    "KIND_TABLE", "needs_convex",
    "INSIDE", "BOUNDARY", "OUTSIDE", "DEFAULT_TOLERANCE",
    "CageError", "OutsideCageError", "WorkerError", "WorkerWarning", "AccuracyWarning",
]
