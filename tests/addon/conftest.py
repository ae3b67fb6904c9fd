"""Install the built extension once per session into a throw-away Blender user folder.

``bpy`` can be imported once per process and keeps its state between tests, so the
extension is installed once (as a user would: the built zip through Blender's extension
machinery) and every test starts from an empty file. Tests that need a fresh Blender
(reopening files, rendering like ``blender -b``) run scripts in a subprocess that shares
the same user folder, hence the same installed and enabled extension.
"""

import importlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import warnings
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
# Set for subprocesses when ``bpy.ops.wm.read_userpref()`` crashes (scene_helpers).
ENABLE_INSTEAD_OF_READING_PREFERENCES = "GENCOORDS_TEST_ENABLE_INSTEAD_OF_READ_USERPREF"


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
    if read_userpref_crashes():
        # bpy 4.2.x (pip module, Linux; seen on 4.2.0 and 4.2.23, not on 4.5 and later):
        # bpy.ops.wm.read_userpref() dies with SIGSEGV on any preferences file, even one
        # bpy itself just saved with no add-on enabled. The subprocess scripts then
        # enable the extension through addon_utils instead of reading the preferences.
        # Upstream: no report found in Blender's tracker (projects.blender.org cannot be
        # reached from this project's machines to search it or file one); fixed by 4.5.
        warnings.warn(f"bpy {bpy.app.version_string}: wm.read_userpref() crashes; "
                      f"subprocesses enable {PACKAGE} with addon_utils instead")
        os.environ[ENABLE_INSTEAD_OF_READING_PREFERENCES] = PACKAGE
    modules = {name: importlib.import_module(f"{PACKAGE}.gencoords_addon.{name}")
               for name in ("binding", "bones", "compat", "deformer", "status", "visualise",
                            "enums", "bind_layout", "mesh_arrays")}
    yield SimpleNamespace(core=importlib.import_module(f"{PACKAGE}.core"), **modules)
    shutil.rmtree(USER_RESOURCES, ignore_errors=True)


def read_userpref_crashes():
    """Whether ``bpy.ops.wm.read_userpref()`` kills a fresh Blender (a signal, not an
    exception) with this session's preferences."""
    probe = subprocess.run([sys.executable, "-c", "import bpy; bpy.ops.wm.read_userpref()"],
                           env=dict(os.environ, BLENDER_USER_RESOURCES=USER_RESOURCES),
                           capture_output=True, timeout=180, check=False)
    return probe.returncode < 0


@pytest.fixture
def gc(addon):
    """An empty scene with the extension enabled (``read_homefile`` keeps add-ons)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    return addon


# How long a script may take to exit once it printed its report.
EXIT_GRACE_SECONDS = 20


def run_blender_script(script, *arguments, user_resources=USER_RESOURCES, timeout=180,
                       survive_exit_bug=False):
    """Run ``tests/addon/<script>`` in a fresh Python with bpy; returns its output.

    Fails the test with the script's output when it exits non-zero or runs past
    ``timeout``. Scripts print their results on a line ``REPORT <json>`` as their last
    act; with ``survive_exit_bug``, a crash or hang after that line (a known bpy bug at
    interpreter exit, see ``test_addon_files_and_render``) is killed after
    ``EXIT_GRACE_SECONDS``, reported as a warning and the output is kept.
    """
    environment = dict(os.environ, BLENDER_USER_RESOURCES=str(user_resources))
    process = subprocess.Popen([sys.executable, str(HERE / script), *map(str, arguments)],
                               env=environment, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True)
    lines, reported_at = [], []

    def read():
        for line in process.stdout:
            lines.append(line)
            if line.startswith("REPORT "):
                reported_at.append(time.monotonic())

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    deadline, code = time.monotonic() + timeout, None
    while code is None and time.monotonic() < deadline:
        if reported_at:
            deadline = min(deadline, reported_at[0] + EXIT_GRACE_SECONDS)
        try:
            code = process.wait(timeout=0.2)
        except subprocess.TimeoutExpired:
            pass
    if code is None:
        process.kill()
        process.wait()
    reader.join(timeout=10)
    output = "".join(lines)
    if code == 0:
        return output
    if code is None:
        what = "hung at exit" if reported_at else f"ran past {timeout} s"
    else:
        what = f"exited with {code}"
    if survive_exit_bug and reported_at and (code is None or code < 0):
        warnings.warn(f"bpy {bpy.app.version_string}: {script} {what} after its report "
                      "(known bpy bug at interpreter exit, see test_addon_files_and_render)")
        return output
    pytest.fail(f"{script} {what}{'' if reported_at else ' before its report'}:\n{output}")


def report_of(output):
    """The JSON a subprocess script printed on its ``REPORT`` line."""
    (line,) = [line for line in output.splitlines() if line.startswith("REPORT ")]
    return json.loads(line[len("REPORT "):])
