"""A Bind without Blender (``bind_plan``): its coordinates, the storage chosen with its reasons,
and the figures measured on what will be written."""

from . import bind_plan

__all__ = ["bind_plan"]
