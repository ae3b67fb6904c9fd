"""The python blocks of the core's documentation run as pasted, in order, and quickly."""

import re
import time
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)


def core_blocks(path):
    """The python blocks of ``path`` that need no Blender (those are tested with bpy)."""
    return [block for block in BLOCK.findall(path.read_text(encoding="utf-8")) if "import bpy" not in block]


@pytest.mark.parametrize(("name", "count"), [("docs/CORE.md", 3), ("README.md", 1)])
def test_the_python_blocks_run_one_after_another_as_pasted(name, count):
    """As a reader pastes them: a block that starts with its imports is a complete
    example (a fresh session), the others continue the first example's session; each
    block within a few seconds (a slow one must say so and be cut down)."""
    blocks = core_blocks(DOCS.parent / name)
    assert len(blocks) >= count
    first = {"__name__": "__docs__"}
    for number, block in enumerate(blocks, start=1):
        complete = number > 1 and block.lstrip().startswith(("import ", "from "))
        namespace = {"__name__": "__docs__"} if complete else first
        started = time.perf_counter()
        exec(compile(block, f"{name} block {number}", "exec"), namespace)  # noqa: S102
        assert time.perf_counter() - started < 10.0, f"{name} block {number} is slow"
