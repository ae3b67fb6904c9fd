"""The checker of each public parameter, by its name (:data:`CHECKS`): what it accepts,
what it converts to, and the message when it does not (:func:`gencoords.base.inputs.checked`
runs them).
"""

import numbers

import numpy as np

from .errors import CageError
from .topology import cage_topology
from ..surfaces.named import EVERY_KIND, MEAN_VALUE_QUADS
from .arrays import _as_array, _finite, _first_bad_row, _solver_tolerance, check_tolerance, real_array

__all__ = ["CHECKS", "OUTSIDE_MODES", "GAMMA_LIMIT", "RESOLUTION_LIMIT", "QUAD_KIND_FUNCTIONS"]

OUTSIDE_MODES = ("raise", "extrapolate", "project")
# The functions that take kind MEAN_VALUE_QUADS: coordinates and weights check their
# ``faces`` as ``polygons`` then (triangles and quads, mixed); the others refuse that kind.
QUAD_KIND_FUNCTIONS = ("coordinates", "weights", "needs_convex")
_RESULT_DTYPES = (np.dtype(np.float32), np.dtype(np.float64))


def _vertices(value, context, name="vertices"):
    array = real_array(value, name)
    if array.ndim != 2 or array.shape[1] < 2:  # too few vertices for a cage: validate_cage
        raise CageError("bad_faces", f"{name} must have shape (n, N) with N >= 2, "
                                     f"got {array.shape}")
    rows, dimension = array.shape
    if rows in (2, 3) and rows < dimension:  # too few vertices for that many dimensions
        raise CageError("transposed", f"{name} must have shape (n, N), one row per vertex: got "
                                      f"{array.shape}, {rows} vertices of a {dimension}D cage "
                                      f"(which needs at least {dimension + 1}); the vertices "
                                      f"look transposed: pass {name}.T, shape {array.shape[::-1]}")
    first, count = _first_bad_row(array)
    if first is not None:
        raise CageError("non_finite", f"cage vertex {first} has a non-finite coordinate "
                                      f"({count} such vertices)",
                        vertices=np.flatnonzero(~np.isfinite(array).all(axis=1))[:10])
    context.dimension, context.vertex_count, context.vertices = array.shape[1], len(array), array
    return array


def _faces(value, context, name="faces", width=None):
    if name == "faces" and context.kind == MEAN_VALUE_QUADS:  # quads and triangles
        return _polygons(value, context)
    array = _as_array(value, name)
    width = width or context.dimension
    if array.size == 0 and name == "quads":  # no quads to split (any empty list)
        array = array.reshape(0, 4).astype(np.int64)
    if array.dtype.kind not in "iu" or array.dtype == np.bool_:
        raise CageError("bad_faces", f"{name} must be integer vertex indices, got {array.dtype} "
                                     f"values")
    if name == "quads" and context.dimension != 3:
        raise ValueError(f"quads need 3D vertices, got {context.dimension}D")
    if width is not None and array.ndim == 1 and array.size % width == 0 and name == "quads":
        array = array.reshape(-1, width)  # a flat list of quad corners
    expected = f"(m, {width})" if width else "(m, N) with N >= 2"
    if array.ndim != 2 or (len(array) == 0 and name != "quads") or (array.shape[1] != width if width else array.shape[1] < 2):
        raise CageError("bad_faces", f"{name} must be integer {expected}"
                                     + (f" for a {width}D cage" if name != "quads" and width else "")
                                     + f", got shape {array.shape}")
    limit = context.vertex_count
    negative = array < 0
    if name == "polygons":  # a triangle's missing fourth corner
        negative[:, 3] &= array[:, 3] != -1
    out_of_range = (negative | (array >= limit)).any(axis=1) if limit else negative.any(axis=1)
    if out_of_range.any():
        first = int(np.flatnonzero(out_of_range)[0])
        upper = f"{limit - 1}" if limit else "(no upper limit)"
        raise CageError("bad_faces", f"{name[:-1]} {first} refers to a vertex index outside 0..{upper}",
                        faces=[first])
    array = array.astype(np.int64, copy=False)
    context.faces = array
    return array


def _polygons(value, context):
    """Triangles and quads, mixed: (m, 3) or (m, 4) int, or a list of 3- or 4-index lists
    -> (m, 4) int64, a triangle's fourth index -1."""
    if context.dimension != 3:
        raise ValueError(f"polygons need 3D vertices, got {context.dimension}D")
    rows = value.tolist() if isinstance(value, np.ndarray) else list(value)
    sizes = [len(row) if hasattr(row, "__len__") else 0 for row in rows]
    wrong = [i for i, size in enumerate(sizes) if size not in (3, 4)]
    if wrong or not rows:
        raise CageError("bad_faces", f"polygon {wrong[0]} has {sizes[wrong[0]]} corners; give triangles and "
                                     "quads (3 or 4 vertex indices)" if wrong else "polygons must not be empty",
                        faces=wrong[:1])
    padded = [list(row) + [-1] * (4 - size) for row, size in zip(rows, sizes)]
    return _faces(np.array(padded), context, "polygons", width=4)  # integers, in range but the -1


def _points(value, context, name="points", single=False):
    if value is None and not single:  # optional points (coordinate_report)
        return None
    array = real_array(value, name)
    dim = context.dimension
    if single:
        if array.shape != (dim,):
            raise ValueError(f"{name} must have shape ({dim},) for a {dim}D cage, got {array.shape}")
        return _finite(array, name, "coordinates")
    if array.size == 0:
        array = array.reshape(0, dim)
    elif array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2 or array.shape[1] != dim:
        raise ValueError(f"{name} must have shape (k, {dim}) (or ({dim},) for one point) for a "
                         f"{dim}D cage, got {array.shape}")
    first, count = _first_bad_row(array)
    if first is not None:
        raise ValueError(f"{count} points have non-finite coordinates (first: {first}); every "
                         "coordinate must be a finite number")
    context.point_count, context.points = len(array), array
    return array


def _point(value, context):
    array = _points(value, context, "point", single=True)
    context.point_count, context.points = 1, array[None]
    return array


def _kind(value, context):
    if not isinstance(value, str) or value not in EVERY_KIND:
        raise ValueError(f"unknown kind {value!r}; expected one of {', '.join(EVERY_KIND)}")
    name = context.function.__qualname__
    if value == MEAN_VALUE_QUADS and name not in QUAD_KIND_FUNCTIONS:
        raise ValueError(f"kind {value!r} (each quad a bilinear patch) is computed by "
                         f"gencoords.coordinates and gencoords.weights with the cage's polygons, "
                         f"not by {name}()")
    context.kind = value
    return value


def _outside(value, context):
    if not isinstance(value, str) or value not in OUTSIDE_MODES:
        raise ValueError(f"outside must be one of {', '.join(OUTSIDE_MODES)}, got {value!r}")
    return value


def _dtype(value, context):
    try:
        dtype = np.dtype(value)
    except TypeError:
        dtype = None
    if value is None or dtype is None or dtype not in _RESULT_DTYPES:  # np.dtype(None) is float64
        raise ValueError(f"dtype must be numpy.float32 or numpy.float64 (the result's precision), "
                         f"got {value!r}")
    return dtype


def _locations(value, context):
    if value is None:
        return None
    count = context.point_count
    if not isinstance(value, np.ndarray) or value.shape != (count,):
        shape = getattr(value, "shape", type(value).__name__)
        raise ValueError(f"locations must be a numpy array of shape ({count},) (one per point), "
                         f"got {shape}")
    if not value.flags.writeable:
        raise ValueError("locations must be a writable array (it is filled in place)")
    if value.dtype.kind not in "if" or not np.can_cast(np.int8, value.dtype):
        raise ValueError(f"locations must hold the values -1, 0 and 1: a signed integer or float "
                         f"array (int8 is enough), got {value.dtype}")
    return value


def _inside(value, context):
    if value is None:
        return None
    count = context.point_count
    if not isinstance(value, np.ndarray) or value.shape != (count,) or value.dtype != np.bool_:
        shape = getattr(value, "shape", type(value).__name__)
        raise ValueError(f"inside must be a numpy bool array of shape ({count},) (one per point), got "
                         f"{shape} {getattr(value, 'dtype', '')}".rstrip())
    return value


def _progress(value, context):
    if value is not None and not callable(value):
        raise ValueError(f"progress must be a callable progress(fraction) or None, got {value!r}")
    return value


def _convex(value, context):
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"convex must be True or False, got {value!r}")
    return bool(value)


def _ridge_values(value, context, name):

    ridges = len(cage_topology(context.faces, context.vertex_count).ridges)
    array = np.atleast_2d(real_array(value, name))
    expected = (context.point_count, ridges)
    if array.shape != expected:
        raise ValueError(f"{name} must have shape (k, r) = {expected} (one value per point and "
                         f"ridge, ridges as gencoords.advanced.ridges(faces)), got {array.shape}")
    return _finite(array, name)


def _vertex_weights(value, context):
    array = real_array(value, "w")
    if array.shape != (context.vertex_count,):
        raise ValueError(f"w must have shape (n,) = ({context.vertex_count},) (one weight per cage "
                         f"vertex), got {array.shape}")
    return _finite(array, "w", "weights")


def _coordinates(value, context):
    array = real_array(value, "coordinates", keep_float32=True)
    if array.ndim != 2:
        raise ValueError(f"coordinates must have shape (k, n) (one row per point, one column per "
                         f"cage vertex), got {array.shape}")
    context.point_count, context.vertex_count = array.shape
    return _finite(array, "coordinates")


def _green_part(value, context, name):
    """Green coordinates' phi (k, n) or psi (k, m), after the cage and the other part."""
    array = real_array(value, name, keep_float32=True)
    if array.ndim == 1:
        array = array[None, :]
    columns = context.vertex_count if name == "phi" else len(context.faces)
    rows = context.point_count
    if array.ndim != 2 or array.shape[1] != columns or (rows is not None and len(array) != rows):
        raise ValueError(f"{name} must have shape ({'k' if rows is None else rows}, {columns}) (one row per "
                         f"point, one column per cage {'vertex' if name == 'phi' else 'face'}), got "
                         f"{array.shape}")
    context.point_count = len(array)
    return _finite(array, name)


def _cage_positions(value, context):
    array = real_array(value, "cage_positions")
    if array.ndim != 2 or len(array) != context.vertex_count:
        raise ValueError(f"cage_positions must have shape (n, N) with n = {context.vertex_count} "
                         f"(the coordinates' columns), got {array.shape}")
    context.dimension = array.shape[1]
    return _finite(array, "cage_positions")


def _out(value, context):
    if value is None:
        return None
    expected = (context.point_count, context.dimension)
    if not isinstance(value, np.ndarray) or value.shape != expected:
        raise ValueError(f"out must be a numpy array of shape {expected}, got "
                         f"{getattr(value, 'shape', type(value).__name__)}")
    if value.dtype.kind != "f" or not value.flags.writeable:
        raise ValueError(f"out must be a writable float array, got {value.dtype}"
                         + ("" if value.flags.writeable else " (read-only)"))
    return value


def _values(value, context):
    array = real_array(value, "values")
    if array.ndim != 1:
        raise ValueError(f"values must have shape (k,) (one coordinate per point), got {array.shape}")
    return _finite(array, "values", "values")


def _cage_self(value, context):
    """A :class:`gencoords.Cage` method's cage: its vertices and faces are already checked."""
    context.dimension, context.vertex_count = value.vertices.shape[1], len(value.vertices)
    context.vertices, context.faces = value.vertices, value.faces
    return value


def _workers(value, context):
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"workers must be a positive integer or None (as many as the machine "
                         f"allows, for long calls), got {value!r}")
    return int(value)


# The power family's heights l^(gamma+1) and their products leave float64's range for
# larger |gamma| (measured on random 3D/4D polytopes: exact to 1e-12 up to |gamma| = 20,
# errors of 1e-3 from gamma = -40); positivity is lost long before (docs/POWER.md).
GAMMA_LIMIT = 16.0


def _gamma(value, context):
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) \
            or not abs(float(value)) <= GAMMA_LIMIT:
        raise ValueError(f"gamma must be a real number in [-{GAMMA_LIMIT:g}, {GAMMA_LIMIT:g}] (the "
                         f"power family's exponent: -1 Wachspress, 1 Voronoi; beyond that its "
                         f"heights leave the range of float64) or None, got {value!r}")
    return float(value)


# Cells along the harmonic grid's longest side: 1024 is 1e9 nodes in a cube, far past memory.
RESOLUTION_LIMIT = 1024


def _resolution(value, context):
    if value is None:  # the default grid
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) \
            or not 2 <= value <= RESOLUTION_LIMIT:
        raise ValueError(f"resolution must be an integer from 2 to {RESOLUTION_LIMIT} (cells along the "
                         f"longest side of the cage's box), got {value!r}")
    return int(value)


def _radius(value, context):
    if not callable(value):
        raise ValueError(f"radius must be a callable radius(points, directions) returning "
                         f"distances, got {value!r}")
    return value


def _levels(value, context):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(f"levels must be a non-negative integer (subdivisions of each ridge's "
                         f"spherical simplex), got {value!r}")
    return int(value)


def _samples(value, context):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"samples must be a positive integer, got {value!r}")
    return int(value)


def _point_count(value, context):
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 0:
        raise ValueError(f"point_count must be a non-negative integer, got {value!r}")
    return int(value)


# Checkers by parameter name, in the order they run (later ones use what earlier ones
# learnt: faces need the vertex count, points the dimension...).
CHECKS = {
    "self": _cage_self,
    "kind": _kind,  # before the faces: kind MEAN_VALUE_QUADS takes quads
    "vertices": _vertices,
    "coordinates": _coordinates,
    "cage_positions": _cage_positions,
    "faces": _faces,
    "facets": lambda value, context: _faces(value, context, "facets"),
    "quads": lambda value, context: _faces(value, context, "quads", width=4),
    "polygons": _polygons,
    "phi": lambda value, context: _green_part(value, context, "phi"),
    "psi": lambda value, context: _green_part(value, context, "psi"),
    "points": _points,
    "point": _point,
    "values": _values,
    "out": _out,
    "outside": _outside,
    "tolerance": lambda value, context: check_tolerance(value),
    "dtype": _dtype,
    "locations": _locations,
    "inside": _inside,
    "progress": _progress,
    "convex": _convex,
    "c": lambda value, context: _ridge_values(value, context, "c"),
    "d": lambda value, context: _ridge_values(value, context, "d"),
    "w": _vertex_weights,
    "workers": _workers,
    "point_count": _point_count,
    "gamma": _gamma,
    "samples": _samples,
    "radius": _radius,
    "levels": _levels,
    "resolution": _resolution,
    "solver_tolerance": lambda value, context: _solver_tolerance(value),
}
