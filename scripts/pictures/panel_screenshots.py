"""Screenshots of the GenCoords panel in a real Blender window (not ``-b``): run by
``scripts/chroot/panel_screenshots.sh``, which starts Blender under Xvfb with the extension
installed, as ``blender --python scripts/pictures/panel_screenshots.py -- <output folder>``.

Opens the scene of ``panel_screenshot_scene.py`` (Suzanne in a fitted 42-vertex cage),
unbound then bound, and saves the Properties editor's Modifiers tab and the 3D view with
its GenCoords sidebar tab for each, then with a coordinate field shown (the Properties
editor scrolled to its end). Each step runs in
a timer, so the window has drawn what the previous step changed before its screenshot.
"""

import struct
import subprocess
import sys
import traceback
from pathlib import Path

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository (or its staged copy)
from scripts.common.png import write_png  # noqa: E402

SCENES = OUTPUT = None  # set by main(), or by a script that reuses these helpers
EXTENSION = "bl_ext.user_default.gencoords"
STEP_SECONDS = 1.5  # time for the window to redraw between steps


def window_and_area(kind):
    window = bpy.context.window_manager.windows[0]
    return window, max((a for a in window.screen.areas if a.type == kind),
                       key=lambda a: a.width * a.height)


def region(area, kind='WINDOW'):
    return next(r for r in area.regions if r.type == kind)


def in_area(kind):
    """Context override for operators that act on the largest area of ``kind``."""
    window, area = window_and_area(kind)
    return bpy.context.temp_override(window=window, screen=window.screen, area=area,
                                     region=region(area))


def shoot(kind, name):
    """Save the largest area of ``kind`` as <OUTPUT>/<name>.png.

    Captured from the X server with ``xwd`` (x11-apps): under Xvfb, Blender's own
    screenshot operators read back black from the software OpenGL framebuffer.
    """
    with in_area(kind):
        bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=1)
    window, area = window_and_area(kind)
    screen = read_xwd(subprocess.run(["xwd", "-root", "-silent"], check=True,
                                     capture_output=True).stdout)
    top = window.height - (area.y + area.height)  # Blender counts rows from the bottom
    write_png(OUTPUT / f"{name}.png", screen[top:top + area.height, area.x:area.x + area.width])
    print(f"panel_screenshots: {name}.png", flush=True)


def read_xwd(data):
    """An X window dump of a 24-bit TrueColor screen as an (h, w, 3) uint8 RGB array."""
    header = struct.unpack(">25I", data[:100])
    header_size, width, height = header[0], header[4], header[5]
    bytes_per_line, colormap_entries = header[12], header[19]
    start = header_size + 12 * colormap_entries
    rows = np.frombuffer(data[start:start + bytes_per_line * height], dtype=np.uint8)
    pixels = rows.reshape(height, bytes_per_line)[:, :4 * width].reshape(height, width, 4)
    return pixels[:, :, 2::-1] if header[7] == 0 else pixels[:, :, 1:]  # BGRX or XRGB


def open_scene(name):
    """Open ``<SCENES>/<name>.blend`` keeping this window's layout, and set up the views."""
    if EXTENSION not in bpy.context.preferences.addons:
        bpy.ops.preferences.addon_enable(module=EXTENSION)
    bpy.ops.wm.open_mainfile(filepath=str(SCENES / f"{name}.blend"), load_ui=False)


def set_up_views():
    """Modifiers tab, sidebar shown, front view of the scene (a step after opening a file:
    the context is not valid again before the window has handled the load)."""
    # Standard: the field's colours as gencoords.reports.field_colors means them (AgX would tone-map).
    bpy.context.scene.view_settings.view_transform = 'Standard'
    _, properties = window_and_area('PROPERTIES')
    properties.spaces.active.context = 'MODIFIER'
    _, view = window_and_area('VIEW_3D')
    view.spaces.active.show_region_ui = True
    view.spaces.active.overlay.show_floor = False
    with in_area('VIEW_3D'):
        bpy.ops.view3d.view_axis(type='FRONT')
        bpy.ops.view3d.view_all()


def pick_sidebar_tab():
    """The GenCoords tab of the sidebar: settable once the sidebar has drawn its tabs."""
    _, view = window_and_area('VIEW_3D')
    region(view, 'UI').active_panel_category = "GenCoords"


def shoot_both(stage):
    shoot('PROPERTIES', f"properties_{stage}")
    shoot('VIEW_3D', f"sidebar_{stage}")


def show_field_colors():
    """What Show Coordinate does to the viewports (the field itself is in field.blend)."""
    _, view = window_and_area('VIEW_3D')
    view.spaces.active.shading.color_type = 'VERTEX'


def scroll_properties_down():
    """The field's controls and legend sit below the fold of a narrow Properties editor."""
    with in_area('PROPERTIES'):
        for _ in range(4):
            bpy.ops.view2d.scroll_down(page=True)


STEPS = [lambda: open_scene("unbound"), set_up_views, pick_sidebar_tab,
         lambda: shoot_both("unbound"), lambda: open_scene("bound"), set_up_views,
         lambda: shoot_both("bound"), lambda: open_scene("field"), set_up_views,
         show_field_colors, scroll_properties_down, lambda: shoot_both("field")]


def run_next_step():
    try:
        STEPS.pop(0)()
    except Exception:
        traceback.print_exc()
        bpy.ops.wm.quit_blender()
        sys.exit(1)  # after quit_blender's request: the exit status tells the wrapper
    if STEPS:
        return STEP_SECONDS
    bpy.ops.wm.quit_blender()
    return None


def main():
    global SCENES, OUTPUT
    SCENES, OUTPUT = map(Path, sys.argv[sys.argv.index("--") + 1:][:2])
    OUTPUT.mkdir(parents=True, exist_ok=True)
    # persistent: the timer carries on after each step opens a file
    bpy.app.timers.register(run_next_step, first_interval=3.0, persistent=True)


if __name__ == "__main__":
    main()
