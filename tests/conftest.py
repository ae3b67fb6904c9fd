"""Markers by folder: every test under tests/addon drives Blender (``blender``)."""

from pathlib import Path

import pytest

ADDON_TESTS = Path(__file__).resolve().parent / "addon"


def pytest_collection_modifyitems(items):
    for item in items:
        if ADDON_TESTS in Path(item.path).parents:
            item.add_marker(pytest.mark.blender)
