"""The add-on's mesh arrays and its Bind operator, as scripts and tests reach them
(bpy and numpy only: Blender-side test scripts import it too)."""

import importlib.util
from pathlib import Path

import bpy
import numpy as np

REPO = Path(__file__).resolve().parents[2]


def _load_mesh_arrays():
    """The add-on's mesh_arrays.py by path: it imports only bpy and numpy, and the demo
    also runs parts without the extension installed."""
    path = REPO / "gencoords_addon" / "blender_io" / "mesh_arrays.py"
    spec = importlib.util.spec_from_file_location("gencoords_mesh_arrays", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# read_positions, write_positions, evaluated_positions, read_loop_triangles...
arrays = _load_mesh_arrays()


def add_mesh_object(name, vertices, faces=(), edges=(), collection=None):
    """A mesh object from arrays, linked to ``collection`` (the scene's by default)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(vertices, dtype=float).tolist(),
                     [tuple(e) for e in np.asarray(edges, dtype=int).reshape(-1, 2)],
                     [tuple(f) for f in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def make_active(obj):
    """Select ``obj`` alone and make it active: what the bind operators act on."""
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def bind(obj, cage, kind=None, outside="RAISE", storage=None, compact_size=None):
    """Bind ``obj`` to ``cage`` through the extension's operator, as a user would:
    the settings on ``obj.gencoords`` (``kind``: the core's or the enum's name, None the
    setting's default; ``storage`` and ``compact_size`` only when given), ``obj`` active
    and alone selected. Returns the operator's result set."""
    obj.gencoords.cage = cage
    kinds = type(obj.gencoords).bl_rna.properties["kind"]
    obj.gencoords.kind = kinds.default if kind is None else kind.upper()
    obj.gencoords.outside = outside
    if storage is not None:
        obj.gencoords.storage = storage
    if compact_size is not None:
        obj.gencoords.compact_size = compact_size
    make_active(obj)
    return bpy.ops.object.gencoords_bind()
