"""A Bind without Blender: what it asks for and writes (``request``), the storage chosen
with its reasons (``storage_choice``), the coordinates written and the figures measured on
them (``figures``), the generator that runs it (``bind_plan``), and its steps around the
Blender side, declared as tools (``bind_steps``)."""

from . import bind_plan, figures, request, storage_choice

__all__ = ["bind_plan", "request", "storage_choice", "figures"]
