"""Cages: preparing one (``triangulate_quads``, ``orient_facets_outward``), example shapes
(``shapes``), enclosing cages (``enclosing``: convex, from supporting half-spaces; ``tight_cage``:
pushed out of a mesh), and the checks Make Cage Tight needs (``surface``: normals, pinched
vertices, gaps between parts; ``self_intersection``, ``volumes``)."""

from ..base.orientation import orient_facets_outward
from ..base.triangulation import triangulate_quads
from . import enclosing, self_intersection, shapes, surface, tight_cage, volumes

__all__ = ["triangulate_quads", "orient_facets_outward",
           "shapes", "enclosing", "tight_cage", "surface", "self_intersection", "volumes"]
