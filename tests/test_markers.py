"""A core-only run needs no bpy: with any marker expression that no ``blender`` test can
satisfy, tests/conftest.py leaves tests/addon (whose conftest imports ``bpy``) uncollected."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def collect_addon_tests(expression, tmp_path):
    """``pytest --collect-only -m expression tests`` where ``import bpy`` fails.

    The whole of tests/ (the folder's conftest is read before any ignore when tests/addon
    is named itself); ``-k`` deselects every test after collection, so none is listed.
    """
    (tmp_path / "bpy.py").write_text('raise ModuleNotFoundError("No module named \'bpy\'", name="bpy")\n')
    environment = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(tmp_path)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    return subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                           "-m", expression, "-k", "no_test_has_this_name", "tests"], cwd=REPO, env=environment,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow  # a pytest collection of tests/ each, 2 s
@pytest.mark.parametrize("expression", ["not blender", "not blender and not slow", "not (blender or slow)"])
def test_an_expression_no_blender_test_satisfies_leaves_the_addon_tests_uncollected(expression, tmp_path):
    completed = collect_addon_tests(expression, tmp_path)
    output = completed.stdout + completed.stderr
    assert completed.returncode == pytest.ExitCode.NO_TESTS_COLLECTED, output
    assert "bpy" not in output, output


@pytest.mark.slow
@pytest.mark.parametrize("expression", ["slow", "not blender or slow"])
def test_an_expression_a_blender_test_may_satisfy_collects_the_addon_tests(expression, tmp_path):
    completed = collect_addon_tests(expression, tmp_path)
    assert "ModuleNotFoundError: No module named 'bpy'" in completed.stdout + completed.stderr
