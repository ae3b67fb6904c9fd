"""Subprocess: a pipeline script, written as the README tells one to be (no helper of
the project's): point Blender at a throw-away user folder, install the built zip with
``extensions.package_install_files``, start from ``read_homefile(use_empty=True)``, bind
inside ``temp_override`` and read what Bind found through ``binding_result``. Prints
checks as JSON. Argument: the extension zip.
"""

import json
import os
import shutil
import sys
import tempfile

user_folder = tempfile.mkdtemp(prefix="gencoords-pipeline-user-")
os.environ["BLENDER_USER_RESOURCES"] = user_folder  # read once, when bpy is imported

import bpy  # noqa: E402

report = {"installed": sorted(bpy.ops.extensions.package_install_files(
    filepath=sys.argv[1], repo="user_default", enable_on_install=True))}
import bl_ext.user_default.gencoords as gencoords  # noqa: E402

bpy.ops.wm.read_homefile(use_empty=True)  # an empty file; the extension stays enabled
report["enabled_after_read_homefile"] = hasattr(bpy.types.Object, "gencoords")


def add(operator, name, **arguments):
    operator(**arguments)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def bind(obj, cage, **settings):
    obj.gencoords.cage = cage
    for name, value in settings.items():
        setattr(obj.gencoords, name, value)
    with bpy.context.temp_override(active_object=obj, object=obj, selected_objects=[obj]):
        return sorted(bpy.ops.object.gencoords_bind())


def plain(result):
    """A BindingResult's fields as JSON values, its metadata's keys, ``is_current``."""
    values = {name: getattr(result, name) for name in result.__dataclass_fields__ if name != "metadata"}
    return dict(values, is_current=result.is_current, metadata_keys=sorted(result.metadata))


mesh = add(bpy.ops.mesh.primitive_uv_sphere_add, "Mesh", radius=1.0, segments=24, ring_count=12)
near = add(bpy.ops.mesh.primitive_ico_sphere_add, "Near", subdivisions=2, radius=2.0)
far = add(bpy.ops.mesh.primitive_ico_sphere_add, "Far", subdivisions=2, radius=2.5)
report["unbound"] = [gencoords.binding_result(mesh) is None, gencoords.binding_results(mesh) == ()]
report["bind"] = [bind(mesh, near, kind='MEAN_VALUE', storage='AUTO'),
                  bind(mesh, far, kind='WACHSPRESS', outside='PROJECT', storage='COMPACT', compact_size=12)]

results = gencoords.binding_results(mesh)
report["results"] = [plain(result) for result in results]
report["first_is_default"] = gencoords.binding_result(mesh) == results[0]
report["by_cage"] = gencoords.binding_result(mesh, far) == results[1]
report["cage_not_bound"] = gencoords.binding_result(near) is None
# The exact binding's coordinates as the mesh stores them (the extension's internals, to
# check the figure against what was written).
internal = gencoords.gencoords_addon.bind.bindings.binding(mesh, near)
report["stored_min_coordinate"] = float(internal.coordinates(mesh.data).min())
report["stored_slot_count"] = internal.coordinates(mesh.data).shape[1]
report["panel"] = [text for text, _ in gencoords.gencoords_addon.ui.status.status_lines(mesh)]

immutable = []
try:
    results[0].min_coordinate = 1.0
except AttributeError as error:  # dataclasses.FrozenInstanceError
    immutable.append(type(error).__name__)
try:
    results[0].metadata["storage"] = 'EXACT'
except TypeError as error:
    immutable.append(type(error).__name__)
report["immutable"] = immutable

with bpy.context.temp_override(active_object=mesh, object=mesh, selected_objects=[mesh]):
    report["unbind"] = sorted(bpy.ops.object.gencoords_unbind())
report["after_unbind"] = gencoords.binding_result(mesh) is None
report["earlier_result_kept"] = results[0].storage  # a record, not a view of the file

bpy.ops.wm.read_factory_settings(use_empty=True)
report["enabled_after_read_factory_settings"] = hasattr(bpy.types.Object, "gencoords")
shutil.rmtree(user_folder, ignore_errors=True)
print("REPORT " + json.dumps(report), flush=True)
