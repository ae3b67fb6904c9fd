#!/usr/bin/env sh
# Print a working interpreter for Python $1 (e.g. 3.13): pythonX.Y on PATH, else pyenv's.
# Blender's pip wheels pin the Python version: bpy 4.2-5.0 need 3.11, 5.1 and later 3.13.
version="$1"
for candidate in "python$version" "$(pyenv root 2>/dev/null)/versions/$version"*/bin/"python$version" \
                 /root/.pyenv/versions/"$version"*/bin/"python$version" /usr/local/bin/"python$version" \
                 /usr/bin/"python$version"; do
    if "$candidate" -c "" >/dev/null 2>&1; then
        command -v "$candidate" 2>/dev/null || echo "$candidate"
        exit 0
    fi
done
echo "no Python $version found: install it (e.g. pyenv install $version)" >&2
exit 1
