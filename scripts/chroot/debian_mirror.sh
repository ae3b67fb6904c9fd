#!/bin/sh
# Prints the Debian mirror this machine's own apt configuration uses (its first
# deb.sources "URIs:" or sources.list "deb" line whose suite is a Debian one), so that no
# registry host is written into the repository. DEBIAN_MIRROR overrides it.
#   CHROOT_MIRROR=$(sh scripts/chroot/debian_mirror.sh)
set -eu
if [ -n "${DEBIAN_MIRROR:-}" ]; then
    echo "$DEBIAN_MIRROR"
    exit 0
fi
for file in /etc/apt/sources.list.d/*.sources /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
    [ -r "$file" ] || continue
    mirror=$(awk '
        /^URIs:/ { for (i = 2; i <= NF; i++) if ($i !~ /security/) { print $i; exit } }
        /^deb[ \t]/ { for (i = 2; i <= NF; i++) if ($i ~ /^[a-z+]+:\/\//) { if ($i !~ /security/) { print $i; exit } } }
    ' "$file")
    if [ -n "$mirror" ]; then
        echo "${mirror%/}"
        exit 0
    fi
done
echo "no Debian mirror found in /etc/apt: set DEBIAN_MIRROR" >&2
exit 1
