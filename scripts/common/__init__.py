"""Helpers shared by the scripts and the tests, one per idea.

Scripts in ``scripts/<purpose>/`` put the repository root on ``sys.path`` and import
``from scripts.common import session, scenes, pictures, png``; the tests import the same
modules (pytest's ``pythonpath = .``). ``png`` and ``mesh_arrays`` need only numpy (and
bpy for the mesh arrays), so Blender-side test scripts can use them too.
"""
