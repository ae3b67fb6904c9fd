"""Install the built extension once per session into a throw-away Blender user folder.

``bpy`` can be imported once per process and keeps its state between tests, so the
extension is installed once (as a user would: the built zip through Blender's extension
machinery) and every test starts from an empty file. Tests that need a fresh Blender
(reopening files, rendering like ``blender -b``) run scripts in a subprocess that shares
the same user folder, hence the same installed and enabled extension.
"""

import importlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from types import SimpleNamespace

import pytest

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
USER_RESOURCES = tempfile.mkdtemp(prefix="gencoords-blender-user-")
# Must be set before bpy is imported anywhere: Blender reads it at start-up.
os.environ["BLENDER_USER_RESOURCES"] = USER_RESOURCES

import bpy  # noqa: E402

PACKAGE = "bl_ext.user_default.gencoords"


@pytest.fixture(scope="session")
def package(tmp_path_factory):
    """The extension zip, freshly built and validated by scripts/build_extension.py."""
    output_dir = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, str(REPO / "scripts" / "build_extension.py"),
                    "--output-dir", str(output_dir)], check=True, capture_output=True)
    (zip_path,) = output_dir.glob("gencoords-*.zip")
    return zip_path


@pytest.fixture(scope="session")
def addon(package):
    """The installed, enabled extension's modules (``core``, ``binding``, ``storage``...)."""
    result = bpy.ops.extensions.package_install_files(
        filepath=str(package), repo="user_default", enable_on_install=True)
    assert result == {'FINISHED'}
    bpy.ops.wm.save_userpref()  # subprocesses using the same folder start with it enabled
    modules = {name: importlib.import_module(f"{PACKAGE}.gencoords_addon.{name}")
               for name in ("binding", "bones", "compat", "deformer", "status", "visualise")}
    yield SimpleNamespace(core=importlib.import_module(f"{PACKAGE}.core"), **modules)
    shutil.rmtree(USER_RESOURCES, ignore_errors=True)


@pytest.fixture
def gc(addon):
    """An empty scene with the extension enabled (``read_homefile`` keeps add-ons)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    return addon


_EXIT_STATUS = []


def pytest_sessionfinish(session, exitstatus):
    _EXIT_STATUS.append(int(exitstatus))


def pytest_unconfigure(config):
    """bpy 4.2 (pip) segfaults while the interpreter shuts down, after every test has
    run and pytest has printed its summary (seen on 4.2.23, not on 4.5 or later): leave
    with pytest's status before that teardown, so a passing run passes."""
    if bpy.app.version < (4, 3) and _EXIT_STATUS:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_EXIT_STATUS[-1])


def run_blender_script(script, *arguments, user_resources=USER_RESOURCES, timeout=180):
    """Run ``tests/addon/<script>`` in a fresh Python with bpy; returns its stdout.

    Fails the test with the script's output when it exits non-zero.
    """
    environment = dict(os.environ, BLENDER_USER_RESOURCES=str(user_resources))
    completed = subprocess.run([sys.executable, str(HERE / script), *map(str, arguments)],
                               env=environment, capture_output=True, text=True,
                               timeout=timeout, check=False)
    assert completed.returncode == 0, completed.stdout + completed.stderr
    return completed.stdout + completed.stderr
