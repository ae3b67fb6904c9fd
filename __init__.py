"""GenCoords Blender extension entry point.

Blender imports this folder (or the built zip) as ``bl_ext.<repo>.gencoords``; the add-on
lives in ``gencoords_addon`` and the mathematics in ``core``, both reached relatively.
"""
from .gencoords_addon import register, unregister  # noqa: F401
