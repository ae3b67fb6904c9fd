#!/bin/sh
# Builds build/cgal_reference (scripts/chroot/cgal_reference.cpp) for `scripts/benchmarks/bench_core.py --cgal`.
#
# CGAL 6.x is header-only; with its headers and Boost's on this machine (CGAL_INCLUDE=...)
# the build is one g++ line. Otherwise, as root, `--setup` makes a Debian testing chroot
# with libcgal-dev (CGAL 6; Debian 12 ships 5.5, which has no 3D barycentric coordinates)
# and the binary is built there, linked statically so that it runs on this machine.
#   sh scripts/chroot/cgal_reference.sh --setup   # once, as root (~400 MB in $GENCOORDS_CGAL_CHROOT)
#   sh scripts/chroot/cgal_reference.sh           # writes build/cgal_reference
#   .venv/bin/python scripts/benchmarks/bench_core.py --cgal build/cgal_reference
set -eu
CHROOT=${GENCOORDS_CGAL_CHROOT:-/work/chroot-cgal}
REPO=$(cd "$(dirname "$0")/../.." && pwd)
FLAGS="-O3 -DNDEBUG -std=c++17 -static"
# CGAL's headers reference GMP and MPFR (its exact number types) even where unused.
LIBS="-lmpfr -lgmp"
mkdir -p "$REPO/build"

if [ "${1:-}" = "--setup" ]; then
    command -v debootstrap >/dev/null || apt-get install -y debootstrap
    debootstrap --variant=minbase testing "$CHROOT" "$(sh "$REPO/scripts/chroot/debian_mirror.sh")"
    cp /etc/resolv.conf "$CHROOT/etc/resolv.conf"
    chroot "$CHROOT" sh -c "apt-get -o Acquire::Check-Valid-Until=false update && \
        DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends libcgal-dev libboost-dev g++"
    exit 0
fi

if [ -n "${CGAL_INCLUDE:-}" ]; then
    g++ $FLAGS -I"$CGAL_INCLUDE" "$REPO/scripts/chroot/cgal_reference.cpp" -o "$REPO/build/cgal_reference" $LIBS
else
    [ -d "$CHROOT/usr/include/CGAL" ] || { echo "no CGAL in $CHROOT: run $0 --setup" >&2; exit 1; }
    mkdir -p "$CHROOT/tmp/cgal_reference"
    cp "$REPO/scripts/chroot/cgal_reference.cpp" "$CHROOT/tmp/cgal_reference/"
    chroot "$CHROOT" g++ $FLAGS /tmp/cgal_reference/cgal_reference.cpp -o /tmp/cgal_reference/cgal_reference $LIBS
    cp "$CHROOT/tmp/cgal_reference/cgal_reference" "$REPO/build/cgal_reference"
fi
echo "built $REPO/build/cgal_reference ($(grep -h 'define CGAL_VERSION ' "${CGAL_INCLUDE:-$CHROOT/usr/include}/CGAL/version.h"))"
