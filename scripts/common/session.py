"""Starting Blender (``bpy``) from the scripts: a throw-away user folder, the built
extension installed into it, and quiet blocks.

Nothing happens on import. A script calls ``prepare()`` before it imports ``bpy``
(Blender reads ``BLENDER_USER_RESOURCES`` once, when ``bpy`` is imported), so installing
the extension never touches the user's own Blender configuration.
"""

import atexit
import contextlib
import importlib
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
OUT = REPO / "out"
DOCS = REPO / "docs"
DIST = REPO / "dist"


def prepare():
    """Put the repository on ``sys.path`` (``scripts.common`` imports from there) and point Blender at a throw-away user
    folder (removed at exit). Call before ``import bpy``; returns the folder."""
    if str(REPO) not in sys.path:
        sys.path.insert(0, str(REPO))
    if "bpy" in sys.modules:
        if getattr(sys.modules["bpy"].app, "binary_path", ""):  # inside a running Blender
            import_core_from_repository()  # (check_release.py): no venv, no gencoords
            return None  # its own user folder stays
        raise RuntimeError("prepare() must run before bpy is imported")
    folder = tempfile.mkdtemp(prefix="gencoords-blender-user-")
    atexit.register(shutil.rmtree, folder, True)
    os.environ["BLENDER_USER_RESOURCES"] = folder
    return folder


def import_core_from_repository():
    """Make ``import gencoords`` work where the core is not installed (a real Blender's
    own Python): the repository's ``core/`` folder under its installed name."""
    try:
        importlib.import_module("gencoords")
    except ImportError:
        spec = importlib.util.spec_from_file_location(
            "gencoords", REPO / "core" / "__init__.py", submodule_search_locations=[str(REPO / "core")])
        module = importlib.util.module_from_spec(spec)
        sys.modules["gencoords"] = module
        spec.loader.exec_module(module)


def _newest_source_time():
    """Latest modification time of anything that goes into the extension zip."""
    paths = [REPO / "blender_manifest.toml", REPO / "scripts" / "release" / "build_extension.py"]
    for folder in ("core", "gencoords_addon"):
        paths.extend((REPO / folder).rglob("*"))
    return max((p.stat().st_mtime for p in paths if p.is_file()), default=0.0)


def extension_zip(rebuild_if_stale=True):
    """Path of the built extension zip, building it first when missing or stale.

    ``make demo`` does not depend on ``make build``, so a demo run after editing the
    add-on would otherwise silently show the old zip's behaviour.
    """
    zips = sorted(DIST.glob("gencoords-*.zip"), key=lambda p: p.stat().st_mtime)
    if zips and not (rebuild_if_stale and zips[-1].stat().st_mtime < _newest_source_time()):
        return zips[-1]
    print("building the extension: scripts/release/build_extension.py", flush=True)
    subprocess.run([sys.executable, str(REPO / "scripts" / "release" / "build_extension.py")],
                   cwd=REPO, check=True)
    zips = sorted(DIST.glob("gencoords-*.zip"), key=lambda p: p.stat().st_mtime)
    if not zips:
        raise RuntimeError("scripts/release/build_extension.py wrote no dist/gencoords-*.zip")
    return zips[-1]


def install_extension():
    """Install and enable the built extension in this (throw-away) Blender profile.

    Returns the zip installed. Raises if the add-on's operators do not appear, so a
    broken package fails here with a clear message rather than later in a bind.
    """
    import bpy

    zip_path = extension_zip()
    with quiet():
        result = bpy.ops.extensions.package_install_files(
            filepath=str(zip_path), repo="user_default", enable_on_install=True)
    if "FINISHED" not in result or not hasattr(bpy.types.Object, "gencoords"):
        raise RuntimeError(f"installing {zip_path} did not register Object.gencoords ({result})")
    return zip_path


def addon_module(submodule):
    """A module of the installed add-on, e.g. ``addon_module("bind.bindings")``: the figures its
    panel shows (smallest coordinate, ...) come from there."""
    import bpy

    for name in bpy.context.preferences.addons.keys():
        if name.split(".")[-1] == "gencoords":
            return importlib.import_module(f"{name}.gencoords_addon.{submodule}")
    raise RuntimeError("the gencoords extension is not enabled")


@contextlib.contextmanager
def quiet():
    """Silence Blender's own console lines (render progress, headless EGL warnings,
    operator reports) for the block; failures still raise in Python with their message."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        os.dup2(null.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def report_header(title):
    """A benchmark report's first lines: its title, the command that made it, the date and
    the versions and machine (printed as it starts, written with the tables)."""
    import datetime
    import platform
    import shlex

    import bpy
    import numpy as np

    return [f"# {title}", "",
            f"Command: `{shlex.join([Path(sys.executable).name] + sys.argv)}`  ",
            f"Date: {datetime.datetime.now().isoformat(timespec='seconds')}; "
            f"Blender {bpy.app.version_string}, numpy {np.__version__}, "
            f"Python {platform.python_version()}, {os.cpu_count()} CPUs, {platform.machine()}"]
