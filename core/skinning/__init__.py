"""Skinning: a linear blend skin from coordinates (``skinning``: each vertex's largest weights,
placing it) and a skin fitted to a deformation (``skin_fit``)."""

from . import skin_fit, skinning

__all__ = ["skinning", "skin_fit"]
