"""Before a release: the built zip in a real Blender (the executable, not pip's bpy).

Given the path of a ``blender`` executable, in a throw-away Blender user folder
(``BLENDER_USER_RESOURCES``, so the maintainer's own Blender set-up is left alone):

1. ``blender --version``: the version, checked against the manifest's
   ``blender_version_min`` (and ``blender_version_max`` when set);
2. ``blender --command extension install-file -r user_default -e <zip>``: installs and
   enables the zip the way Blender's command line does;
3. ``blender -b --python scripts/release/check_release.py -- --inside <out>``: a fresh Blender
   that starts with those preferences (the extension enabled at start-up, as for an
   artist) builds the demo's scene (Suzanne in a 42-vertex cage, scripts/demo/demo.py), binds
   it through the operator, checks the mesh is unchanged at rest and follows a cage
   edit, renders a frame (Workbench) and saves the file; then the extension's own core
   computes coordinates in two worker processes from inside Blender (where
   ``sys.executable`` may be Blender itself) and checks them bitwise against one process;
4. prints a report and exits non-zero when any step fails.

Usage: python scripts/release/check_release.py BLENDER [--zip dist/gencoords-<version>.zip]
       [--out out/check_release]   (``make check-release BLENDER_BINARY=...`` builds first)
"""

import argparse
import importlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
MANIFEST = tomllib.loads((REPO / "blender_manifest.toml").read_text(encoding="utf-8"))
PACKAGE = f"bl_ext.user_default.{MANIFEST['id']}"


def version_tuple(text):
    return tuple(int(part) for part in text.split("."))


def run(command, environment, timeout):
    """Run ``command``; (exit code or None on timeout, output, seconds)."""
    start = time.monotonic()
    try:
        completed = subprocess.run(command, env=environment, capture_output=True, text=True,
                                   timeout=timeout, check=False)
        return completed.returncode, completed.stdout + completed.stderr, time.monotonic() - start
    except subprocess.TimeoutExpired:
        return None, f"(no exit within {timeout} s)", time.monotonic() - start


def outside(arguments):
    """Steps 1 to 4, driving the executable; returns the process exit code."""
    blender = str(Path(arguments.blender).expanduser())
    package = arguments.zip or REPO / "dist" / f"{MANIFEST['id']}-{MANIFEST['version']}.zip"
    if not Path(package).is_file():
        sys.exit(f"{package} not found: run `make build` first")
    out = Path(arguments.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    user_folder = tempfile.mkdtemp(prefix="gencoords-release-user-")
    environment = dict(os.environ, BLENDER_USER_RESOURCES=user_folder)
    failures = []
    try:
        code, output, _ = run([blender, "--version"], environment, 120)
        found = re.search(r"Blender (\d+\.\d+\.\d+)", output)
        if code != 0 or not found:
            sys.exit(f"{blender} --version failed ({code}):\n{output}")
        version = found.group(1)
        print(f"Blender {version} ({blender})")
        minimum, maximum = MANIFEST["blender_version_min"], MANIFEST.get("blender_version_max")
        if version_tuple(version) < version_tuple(minimum):
            failures.append(f"Blender {version} is older than blender_version_min {minimum}")
        if maximum and version_tuple(version) >= version_tuple(maximum):
            failures.append(f"Blender {version} is not below blender_version_max {maximum}")

        code, output, seconds = run([blender, "--command", "extension", "install-file",
                                     "-r", "user_default", "-e", str(package)], environment, 300)
        print(f"install-file {Path(package).name}: exit {code} ({seconds:.1f} s)")
        if code != 0:
            failures.append(f"install-file failed ({code}):\n{output}")
        else:
            code, output, seconds = run(
                [blender, "-b", "--python-exit-code", "1", "--python", str(Path(__file__).resolve()),
                 "--", "--inside", str(out)], environment, 600)
            reports = [line for line in output.splitlines() if line.startswith("REPORT ")]
            print(f"blender -b --python (bind, deform, render): exit {code} ({seconds:.1f} s)")
            if code != 0 or len(reports) != 1:
                failures.append(f"the scene check failed ({code}):\n{output}")
            else:
                report = json.loads(reports[0][len("REPORT "):])
                for key, value in report.items():
                    print(f"  {key}: {value}")
                failures += report["failures"]
    finally:
        shutil.rmtree(user_folder, ignore_errors=True)
    for failure in failures:
        print(f"FAILED: {failure}")
    print("release check " + ("FAILED" if failures else "passed"))
    return 1 if failures else 0


def inside(out):
    """Step 3, inside Blender: prints one ``REPORT <json>`` line."""
    import bpy
    import numpy as np

    sys.path.insert(0, str(REPO))
    from scripts.common import pictures, session
    session.prepare()  # inside Blender: the repository's core as gencoords for the scenes
    from scripts.common.scenes import arrays
    from scripts.demo import demo

    failures = []
    enabled = PACKAGE in bpy.context.preferences.addons
    if not enabled:
        failures.append(f"{PACKAGE} is not enabled at start-up")
    report = {"blender": bpy.app.version_string, "numpy": np.__version__,
              "extension enabled at start-up": enabled}
    if enabled:
        scene, mesh, cage = demo.deformation_scene(shape_key=True)
        rest = arrays.read_positions(mesh.data)
        report["bind seconds"] = round(demo.bind(mesh, cage, demo.scenes.MEAN_VALUE), 2)
        modifiers = [m.name for m in mesh.modifiers if m.type == 'NODES']
        report["modifiers"] = modifiers
        demo.settle()
        at_rest = float(np.abs(arrays.evaluated_positions(mesh) - rest).max())
        cage.data.shape_keys.key_blocks["Pull and twist"].value = 1.0
        demo.settle()
        moved = float(np.abs(arrays.evaluated_positions(mesh) - rest).max())
        report["change at rest"], report["largest move after the cage edit"] = at_rest, moved
        if modifiers != ["GenCoords"]:
            failures.append(f"expected one GenCoords modifier, found {modifiers}")
        if at_rest > 1e-6 or not moved > 0.1:
            failures.append(f"the mesh does not follow the cage (rest {at_rest}, moved {moved})")
        picture = Path(out) / "after.png"
        demo.render_with_cage_wire(cage, picture)  # Suzanne, the cage as a thin wire
        pixels = pictures.load_png(picture)
        report["render"] = f"{picture} ({pixels.shape[1]}x{pixels.shape[0]})"
        if pixels[..., :3].std() < 0.01:
            failures.append("the rendered frame is blank")
        path = Path(out) / "check_release.blend"
        with session.quiet():
            bpy.ops.wm.save_as_mainfile(filepath=str(path))
        report["saved"] = str(path)
        failures += workers_inside_blender(report)
    report["failures"] = failures
    print("REPORT " + json.dumps(report), flush=True)


def workers_inside_blender(report):
    """The installed extension's core in worker processes started from this Blender;
    returns failures."""
    import numpy as np

    gencoords = importlib.import_module(f"{PACKAGE}.core")  # the extension's bundled copy
    interpreters = importlib.import_module(f"{PACKAGE}.core.evaluation.interpreters")
    shapes = importlib.import_module(f"{PACKAGE}.core.cages.shapes")
    vertices, faces = shapes.icosphere(2)
    points = np.random.default_rng(0).uniform(-0.5, 0.5, (5000, 3))
    report["sys.executable"] = sys.executable
    try:
        report["worker Python"] = interpreters.python_executable()
        with gencoords.Cage(vertices, faces) as cage:
            alone = cage.coordinates(points, workers=1)  # the default kind, mean value
            spread = cage.coordinates(points, workers=2)
        report["core in 2 workers equals 1 process bitwise"] = bool(np.array_equal(alone, spread))
    except gencoords.WorkerError as error:
        return [f"worker processes failed inside Blender: {error}"]
    return [] if np.array_equal(alone, spread) else ["workers differ from one process"]


def main():
    if "--inside" in sys.argv:  # run by Blender: our arguments follow "--"
        inside(sys.argv[sys.argv.index("--inside") + 1])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("blender", help="path of the blender executable")
    parser.add_argument("--zip", type=Path, help="the extension zip (default: dist/)")
    parser.add_argument("--out", default=str(REPO / "out" / "check_release"),
                        help="where the rendered frame and the saved .blend go")
    sys.exit(outside(parser.parse_args()))


if __name__ == "__main__":
    main()
