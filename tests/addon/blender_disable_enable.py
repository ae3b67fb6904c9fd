"""Subprocess: bind, disable the extension, edit the cage, enable it again, unbind; print
checks as JSON. In a subprocess: re-enabling imports the extension's modules anew, which
would leave the test session's references to them stale.
"""

import json

import bpy
import addon_utils  # noqa: I001 (importable once bpy is)
import numpy as np

from scene_helpers import (add_icosphere_cage, add_sphere, bind, evaluated_positions,
                           load_user_preferences, mesh_state, read_positions, write_positions)

PACKAGE = "bl_ext.user_default.gencoords"
load_user_preferences()
bpy.ops.wm.read_homefile(use_empty=True)
cage, obj = add_icosphere_cage(), add_sphere()
before = mesh_state(obj)
report = {"bind": sorted(bind(obj, cage))}
addon_utils.disable(PACKAGE, default_set=True)
report["disabled"] = PACKAGE not in bpy.context.preferences.addons
write_positions(cage.data, read_positions(cage.data) + (0.5, 0.0, 0.0))
report["follows_while_disabled"] = float(np.abs(evaluated_positions(obj) - before[0] - (0.5, 0, 0)).max())
addon_utils.enable(PACKAGE, default_set=True, handle_error=None)
from bl_ext.user_default.gencoords.gencoords_addon.ui import status  # noqa: E402 (imported anew)

report["status_after_enable"] = [text for text, _ in status.status_lines(obj)]
write_positions(cage.data, read_positions(cage.data) + (0.0, 0.25, 0.0))
report["follows_after_enable"] = float(np.abs(evaluated_positions(obj) - before[0] - (0.5, 0.25, 0)).max())
bpy.context.view_layer.objects.active = obj
report["unbind"] = sorted(bpy.ops.object.gencoords_unbind())
after = mesh_state(obj)
report["restored"] = bool(np.array_equal(after[0], before[0]) and after[1] == before[1])
report["modifiers"] = [m.name for m in obj.modifiers]
print("REPORT " + json.dumps(report), flush=True)
