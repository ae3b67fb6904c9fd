"""Markers by folder: every test under tests/addon drives Blender (``blender``).

A core-only run, ``pytest -m "not blender"``, does not even import tests/addon (its
conftest imports ``bpy``), so it runs where only numpy and the core are installed.
"""

from pathlib import Path

import pytest

ADDON_TESTS = Path(__file__).resolve().parent / "addon"


def _in_addon_tests(path):
    path = Path(path)
    return path == ADDON_TESTS or ADDON_TESTS in path.parents


def pytest_ignore_collect(collection_path, config):
    if config.getoption("markexpr").strip() == "not blender" and _in_addon_tests(collection_path):
        return True
    return None


def pytest_collection_modifyitems(items):
    for item in items:
        if _in_addon_tests(item.path):
            item.add_marker(pytest.mark.blender)
