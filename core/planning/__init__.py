"""A Bind without Blender: what it asks for and writes (``request``), the storage chosen
with its reasons (``storage_choice``), the coordinates written and the figures measured on
them (``figures``), and the generator that runs it (``bind_plan``)."""

from . import bind_plan, figures, request, storage_choice

__all__ = ["bind_plan", "request", "storage_choice", "figures"]
