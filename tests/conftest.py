"""Markers by folder: every test under tests/addon drives Blender (``blender``).

A core-only run, ``pytest -m "not blender"`` (or any marker expression that no test marked
``blender`` can satisfy, such as ``"not blender and not slow"``), does not even import
tests/addon (its conftest imports ``bpy``), so it runs where only numpy and the core are
installed.
"""

from pathlib import Path

import pytest
from _pytest.mark.expression import Expression

ADDON_TESTS = Path(__file__).resolve().parent / "addon"


def _in_addon_tests(path):
    path = Path(path)
    return path == ADDON_TESTS or ADDON_TESTS in path.parents


def _selects_some_blender_test(text):
    """Whether the marker expression ``text`` can select a test marked ``blender``.

    A test under tests/addon is marked ``blender`` and may carry any other markers, so the
    expression is evaluated with ``blender`` true and every other name it asks about (a
    marker, or a marker with arguments) tried both ways: the folder can be left out only
    when no combination selects. An expression pytest cannot read selects (pytest reports it).
    """
    if not text.strip():
        return True
    try:
        expression = Expression.compile(text)
    except SyntaxError:
        return True

    def selects(fixed):
        asked = []

        def matcher(name, /, **kwargs):
            key = (name, tuple(sorted(kwargs.items())))
            if key == ("blender", ()):
                return True
            if key not in fixed:
                asked.append(key)
            return fixed.get(key, False)

        if expression.evaluate(matcher):
            return True
        # Every unfixed name read false: fix the first one both ways (the names read
        # after it may change), until a combination selects or none is left.
        return bool(asked) and (selects({**fixed, asked[0]: False}) or selects({**fixed, asked[0]: True}))

    return selects({})


def pytest_ignore_collect(collection_path, config):
    if _in_addon_tests(collection_path) and not _selects_some_blender_test(config.getoption("markexpr")):
        return True
    return None


def pytest_collection_modifyitems(items):
    for item in items:
        if _in_addon_tests(item.path):
            item.add_marker(pytest.mark.blender)
