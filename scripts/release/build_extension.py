"""Build dist/gencoords-<version>.zip and validate it, both with Blender's own tools.

Blender's extension command line (``blender_ext.py``) ships inside the ``bpy`` wheel and
runs as a plain script, so it is located from ``bpy``'s package folder without importing
``bpy`` (which would start Blender). Exits non-zero when building or validating fails.

The extension's top-level ``__init__.py`` (Blender imports the package as
``bl_ext.<repo>.gencoords``) is written into a staging folder next to copies of the
manifest, ``gencoords_addon/`` and ``core/``: the repository root itself stays a plain
folder, not a Python package that test runners or other tools would try to import.

Usage: python scripts/release/build_extension.py [--output-dir DIR]
"""

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BLENDER_EXT_RELATIVE = Path("scripts", "addons_core", "bl_pkg", "cli", "blender_ext.py")
PACKAGED = ("blender_manifest.toml", "LICENSE", "gencoords_addon", "core")
ENTRY_POINT = '''"""GenCoords Blender extension: the add-on is ``gencoords_addon``, the maths ``core``."""
from .gencoords_addon import register, unregister  # noqa: F401
from .gencoords_addon import BindingResult, binding_result, binding_results  # noqa: F401 (scripts)
'''


def stage_sources(staging):
    """Copy what the extension ships into ``staging`` and write its ``__init__.py``."""
    for name in PACKAGED:
        source = REPO / name
        if source.is_dir():
            shutil.copytree(source, staging / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        elif source.exists():
            shutil.copy2(source, staging / name)
    (staging / "__init__.py").write_text(ENTRY_POINT, encoding="utf-8")


def find_blender_ext():
    """Path of ``blender_ext.py`` inside the installed ``bpy`` package (``bpy/<x.y>/...``)."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("bpy is not installed in this Python; run `make setup` first")
    for package_dir in spec.submodule_search_locations:
        for candidate in sorted(Path(package_dir).glob("*/" + str(BLENDER_EXT_RELATIVE))):
            return candidate
    sys.exit("blender_ext.py not found inside the bpy package")


def run_blender_ext(blender_ext, *arguments):
    """Run one ``blender_ext.py`` sub-command; exit with its code when it fails."""
    completed = subprocess.run([sys.executable, str(blender_ext), *arguments], check=False)
    if completed.returncode != 0:
        sys.exit(f"blender_ext.py {arguments[0]} failed with exit code {completed.returncode}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=REPO / "dist")
    output_dir = parser.parse_args().output_dir.resolve()

    manifest = tomllib.loads((REPO / "blender_manifest.toml").read_text(encoding="utf-8"))
    package = output_dir / f"{manifest['id']}-{manifest['version']}.zip"
    output_dir.mkdir(parents=True, exist_ok=True)

    blender_ext = find_blender_ext()
    with tempfile.TemporaryDirectory(prefix="gencoords-build-") as staging:
        sources, built = Path(staging) / "sources", Path(staging) / package.name
        sources.mkdir()
        stage_sources(sources)
        run_blender_ext(blender_ext, "build", "--source-dir", str(sources), "--output-filepath", str(built))
        run_blender_ext(blender_ext, "validate", str(built))
        # Into place in one rename: a fuzz or a test installing the previous zip meanwhile
        # reads it whole, never a half-written one (a fuzz case once did).
        partial = package.with_name(f".{package.name}.{os.getpid()}.partial")
        shutil.copyfile(built, partial)
        os.replace(partial, package)
    print(f"built and validated {package}")


if __name__ == "__main__":
    main()
