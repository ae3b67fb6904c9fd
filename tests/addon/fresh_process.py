"""Running the tests' Blender scripts (``tests/addon/blender_*.py``) in a fresh Python
with bpy, sharing the session's throw-away user folder, hence its installed extension.

A module of its own, not ``conftest``: tests import it (``from fresh_process import
run_blender_script``); ``conftest`` imports it first, so ``BLENDER_USER_RESOURCES`` is
set before ``bpy`` is imported anywhere.
"""

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
USER_RESOURCES = tempfile.mkdtemp(prefix="gencoords-blender-user-")
# Must be set before bpy is imported anywhere: Blender reads it at start-up.
os.environ["BLENDER_USER_RESOURCES"] = USER_RESOURCES

PACKAGE = "bl_ext.user_default.gencoords"
# Set for subprocesses when ``bpy.ops.wm.read_userpref()`` crashes (scene_helpers).
ENABLE_INSTEAD_OF_READING_PREFERENCES = "GENCOORDS_TEST_ENABLE_INSTEAD_OF_READ_USERPREF"


# How long a script may take to exit once it printed its report.
EXIT_GRACE_SECONDS = 20


def run_blender_script(script, *arguments, user_resources=USER_RESOURCES, timeout=180,
                       survive_exit_bug=False):
    """Run ``tests/addon/<script>`` in a fresh Python with bpy; returns its output.

    Fails the test with the script's output when it exits non-zero or runs past
    ``timeout``. Scripts print their results on a line ``REPORT <json>`` as their last
    act; with ``survive_exit_bug``, a crash or hang after that line (a known bpy bug at
    interpreter exit, see ``test_graph_files_and_render``) is killed after
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
        import bpy  # after BLENDER_USER_RESOURCES is set (above)

        warnings.warn(f"bpy {bpy.app.version_string}: {script} {what} after its report "
                      "(known bpy bug at interpreter exit, see test_graph_files_and_render)")
        return output
    pytest.fail(f"{script} {what}{'' if reported_at else ' before its report'}:\n{output}")


def report_of(output):
    """The JSON a subprocess script printed on its ``REPORT`` line."""
    (line,) = [line for line in output.splitlines() if line.startswith("REPORT ")]
    return json.loads(line[len("REPORT "):])
