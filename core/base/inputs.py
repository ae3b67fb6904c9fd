"""Checks of the public functions' arguments, in one place.

Every public function of the core is wrapped by :func:`checked`. It binds the call's
arguments and checks each one by its *name* (``points``, ``vertices``, ``faces``,
``tolerance``, ``dtype``, ...) with the checker of :data:`CHECKS`, passing the function
the converted value (float64 arrays, int64 faces, a float tolerance, a numpy dtype),
then cross-checks shapes between arguments (points of the cage's dimension, one
location per point, one scalar per ridge...). A parameter without a checker is an error
when the module is imported, so a new function or parameter cannot skip the checks.
The checkers are in :mod:`.parameters`, the array checks they share in :mod:`.arrays`.
Every message says what is wrong and what is accepted; errors are ``ValueError`` (cage
problems :class:`~gencoords.base.errors.CageError`, itself a ``ValueError``).
"""

import functools
import inspect

import numpy as np

from . import tolerances
from .arrays import _Context, bounding_frame
from .parameters import CHECKS

__all__ = ["checked"]


def _check_reach(context):
    """Points within ``tolerances.FARTHEST`` cage sizes of the cage (no overflow)."""
    origin, scale = bounding_frame(context.vertices)
    with np.errstate(over="ignore", invalid="ignore"):
        local = np.abs(context.points / scale - origin / scale).max(axis=1)
    far = ~(local <= tolerances.FARTHEST)
    if far.any():
        raise ValueError(f"{np.count_nonzero(far)} points lie more than {tolerances.FARTHEST:g} "
                         f"times the cage's size from it (first: {int(np.flatnonzero(far)[0])}); "
                         "the formulas would overflow there")


def _call_error(function, kwargs, error):
    """Python's message for arguments ``function`` does not take, with the likely fix."""
    name = function.__qualname__
    message = f"{name}(): {error}"
    if "tolerance" in kwargs and name.startswith("Cage."):
        message += ("; the tolerance belongs to the cage, whose checks and point locations "
                    "it sets: Cage(vertices, faces, tolerance=...)")
    return message


def checked(function):
    """Decorator: check and convert ``function``'s arguments by name (see :data:`CHECKS`)."""
    signature = inspect.signature(function)
    unknown = [name for name in signature.parameters if name not in CHECKS]
    if unknown:
        raise TypeError(f"{function.__qualname__}: no input check for parameter(s) {unknown}; "
                        "add them to gencoords.base.parameters.CHECKS")
    order = [name for name in CHECKS if name in signature.parameters]

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        try:
            bound = signature.bind(*args, **kwargs)
        except TypeError as error:
            raise TypeError(_call_error(function, kwargs, error)) from None
        bound.apply_defaults()
        context = _Context(function)
        for name in order:
            bound.arguments[name] = CHECKS[name](bound.arguments[name], context)
        if (context.vertices is not None and context.points is not None and len(context.points)
                and len(context.vertices) > context.dimension):  # fewer: validate_cage says so
            _check_reach(context)
        return function(*bound.args, **bound.kwargs)

    wrapper.checks_inputs = True
    return wrapper
