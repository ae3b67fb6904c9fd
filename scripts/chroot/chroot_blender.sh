#!/bin/sh
# A real `blender` executable for scripts/release/check_release.py on a machine without one:
# Debian's Blender in the screenshot chroot (scripts/chroot/panel_screenshots.sh --setup), on a
# virtual display (Workbench renders need an OpenGL context even with -b).
#   scripts/chroot/chroot_blender.sh --version
#   .venv/bin/python scripts/release/check_release.py scripts/chroot/chroot_blender.sh
# Needs root; /work and /tmp are bind-mounted so paths are the same inside.
set -eu
CHROOT=${GENCOORDS_CHROOT:-/work/chroot-blender}
for fs in proc sys dev work tmp; do
    mkdir -p "$CHROOT/$fs"
    mountpoint -q "$CHROOT/$fs" || mount --bind "/$fs" "$CHROOT/$fs"
done
exec chroot "$CHROOT" env HOME=/root BLENDER_USER_RESOURCES="${BLENDER_USER_RESOURCES:-}" \
    sh -c 'cd "$0" && exec xvfb-run -a -s "-screen 0 1280x800x24" blender "$@"' "$PWD" "$@"
