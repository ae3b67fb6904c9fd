"""The add-on's preferences (Edit > Preferences > Add-ons > GenCoords): worker processes.

Bind (and Make Cage) compute in the core's worker processes, fresh Python interpreters
that Blender bundles. Where they cannot start (an antivirus blocking the bundled Python)
or fail, the operator computes in Blender instead and says so
(``bind.service.in_workers_or_blender``); the artist may also choose Blender's own process
from the start.
"""

import bpy


# The extension's top package (bl_ext.<repository>.gencoords): Blender files an add-on's
# preferences under the name it was enabled by, not under this subpackage.
ADDON = __package__.rpartition(".")[0]

WORKER_ITEMS = [
    ('AUTO', "Automatic", "As many processes as the cores, for Binds long enough to repay "
                          "starting them (about 0.2 s each)"),
    ('BLENDER', "1: Compute in Blender", "No worker processes: compute in Blender's own process "
                                         "(slower on several cores; for systems that block "
                                         "Blender's bundled Python)"),
    ('FIXED', "Fixed Number", "As many worker processes as set beside"),
]


class GenCoordsPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON

    workers: bpy.props.EnumProperty(
        name="Worker Processes", items=WORKER_ITEMS, default='AUTO',
        description="Processes that Bind computes in (the result is the same; where they "
                    "fail, Bind computes in Blender and says so)")
    worker_count: bpy.props.IntProperty(
        name="Processes", default=4, min=2, max=256,
        description="Worker processes for Fixed Number")

    def draw(self, context):
        row = self.layout.row()
        row.prop(self, "workers")
        count = row.row()
        count.enabled = self.workers == 'FIXED'
        count.prop(self, "worker_count")


def worker_count(context):
    """The worker processes the preferences ask for: None (automatic) or int (1: in
    Blender). None where the preferences cannot be read (the add-on not enabled by name)."""
    addon = context.preferences.addons.get(ADDON)
    preferences = None if addon is None else addon.preferences
    if preferences is None:
        return None
    return {'AUTO': None, 'BLENDER': 1}.get(preferences.workers, preferences.worker_count)
