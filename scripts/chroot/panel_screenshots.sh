#!/bin/sh
# Screenshots of the GenCoords panel in a real Blender window, for the README.
#
# Blender runs under Xvfb inside a Debian chroot (outside git), so nothing is installed
# on this machine but debootstrap:
#   scripts/chroot/panel_screenshots.sh --setup   # once, as root: builds the chroot (~1.5 GB)
#   scripts/chroot/panel_screenshots.sh           # as root: writes docs/pictures/*.png
#   scripts/chroot/panel_screenshots.sh --check   # as root: an artist's session driven by real
#                                          # keys (scripts/release/gui_check.py): out/gui_check/
#   scripts/chroot/panel_screenshots.sh --timing  # as root: Bind from the window against a
#                                          # script's (scripts/release/gui_bind_timing.py)
# The chroot is Debian unstable (sid) with its Blender package, from the mirror this
# machine's apt uses (scripts/chroot/debian_mirror.sh); GENCOORDS_CHROOT picks another folder.
set -eu

CHROOT=${GENCOORDS_CHROOT:-/work/chroot-blender}
REPO=$(cd "$(dirname "$0")/../.." && pwd)
STAGE=/tmp/gencoords-screenshots   # inside the chroot
PICTURES="$REPO/docs/pictures"
SCRIPT=pictures/panel_screenshots.py
if [ "${1:-}" = "--check" ]; then  # the same window, driven by keys instead of photographed
    SCRIPT=release/gui_check.py
    PICTURES="$REPO/out/gui_check"
elif [ "${1:-}" = "--timing" ]; then
    SCRIPT=release/gui_bind_timing.py
    PICTURES="$REPO/out/gui_bind_timing"
fi
APT="apt-get -o Acquire::Check-Valid-Until=false"  # the mirror's dates may trail the clock

mount_system() {
    for fs in proc sys dev; do
        mountpoint -q "$CHROOT/$fs" || mount --bind "/$fs" "$CHROOT/$fs"
    done
    cp /etc/resolv.conf "$CHROOT/etc/resolv.conf"
}

if [ "${1:-}" = "--setup" ]; then
    command -v debootstrap >/dev/null || apt-get install -y debootstrap
    debootstrap --variant=minbase sid "$CHROOT" "$(sh "$REPO/scripts/chroot/debian_mirror.sh")"
    mount_system
    chroot "$CHROOT" sh -c "$APT update && DEBIAN_FRONTEND=noninteractive $APT install -y \
        --no-install-recommends blender xvfb xauth libgl1-mesa-dri x11-apps xdotool \
        python3-numpy python3-cattr python3-requests"
    exit 0
fi

[ -x "$CHROOT/usr/bin/blender" ] || { echo "no Blender in $CHROOT: run $0 --setup" >&2; exit 1; }
mount_system

rm -rf "$CHROOT$STAGE"
mkdir -p "$CHROOT$STAGE/shots"
# The extension zip (Blender's own tools), and the scene bound with pip bpy 5.0.1 here:
# (a file bound by one Blender opens bound in another: the deformer is Geometry Nodes).
"$REPO/.venv/bin/python" "$REPO/scripts/pictures/panel_screenshot_scene.py" "$CHROOT$STAGE"
"$REPO/.venv/bin/python" "$REPO/scripts/release/build_extension.py" >/dev/null  # the zip of this tree
ZIP=$(ls -t "$REPO"/dist/gencoords-*.zip | head -n 1)
cp -r "$REPO/scripts" "$REPO/gencoords_addon" "$CHROOT$STAGE/"  # scripts.common loads blender_io/mesh_arrays.py by path
mkdir -p "$CHROOT$STAGE/tests" && cp -r "$REPO/tests/fixtures" "$CHROOT$STAGE/tests/"  # the timing's character
cp "$ZIP" "$CHROOT$STAGE/gencoords.zip"

# A throw-away user folder: the extension installed and enabled, no splash screen.
status=0
chroot "$CHROOT" env HOME=/root BLENDER_USER_RESOURCES="$STAGE/user" sh -ec "
    blender --command extension install-file -r user_default -e $STAGE/gencoords.zip
    blender -b --factory-startup --python-expr 'import bpy; \
bpy.context.preferences.view.show_splash = False; \
bpy.ops.preferences.addon_enable(module=\"bl_ext.user_default.gencoords\"); \
bpy.ops.wm.save_userpref()'
    xvfb-run -a -s '-screen 0 1440x900x24' blender --window-geometry 0 0 1440 900 \
        --python $STAGE/scripts/$SCRIPT -- $STAGE $STAGE/shots
" || status=$?
mkdir -p "$PICTURES"
cp "$CHROOT$STAGE"/shots/*.png "$PICTURES/" 2>/dev/null || true
ls -l "$PICTURES"
exit $status
