"""Whether a change to the Bind keeps its plans bit for bit (issue 35): every field of the
``BindPlan`` the add-on's request (as ``bind_split.py``'s) makes on
``tests/fixtures/artist_cages.py``'s fixtures, saved from one checkout's core and compared
with another's.

    .venv/bin/python scripts/benchmarks/plan_digests.py --save /tmp/before.npz [--core /other/checkout/core]
    .venv/bin/python scripts/benchmarks/plan_digests.py --compare /tmp/before.npz [--fixtures hand cup]

``--core`` imports ``gencoords`` from that folder instead of the installed one (a copy of
another commit: ``git archive COMMIT | tar -x -C DIR``). A field that differs is named with
its largest difference, absolute and relative to the field's largest magnitude.
"""

import argparse
import sys
import tempfile
from dataclasses import fields
from pathlib import Path

import numpy as np


def _import_from(core):
    """``gencoords`` from the folder ``core``, ahead of the installed one."""
    folder = Path(tempfile.mkdtemp(prefix="gencoords-core-"))
    (folder / "gencoords").symlink_to(Path(core).resolve(), target_is_directory=True)
    sys.path.insert(0, str(folder))


def _plan_fields(plan):
    """Each field of a BindPlan as an array (None: an empty object array)."""
    return {item.name: np.asarray(getattr(plan, item.name)) if getattr(plan, item.name) is not None
            else np.array([], dtype=object) for item in fields(plan)}


def _difference(before, after):
    """How two saved fields differ, in words, or None where bit for bit the same."""
    if before.dtype != after.dtype or before.shape != after.shape:
        return f"{before.dtype}{before.shape} -> {after.dtype}{after.shape}"
    if before.tobytes() == after.tobytes():
        return None
    if before.dtype.kind not in "fiu":
        return f"{before!r} -> {after!r}"
    gap = np.abs(before.astype(np.float64) - after.astype(np.float64)).max()
    scale = np.abs(before.astype(np.float64)).max()
    return f"largest difference {gap:.3g} ({gap / scale if scale else np.inf:.3g} of its largest magnitude)"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=["hand", "quadruped", "cup", "cape", "character"])
    parser.add_argument("--detail", type=float, default=0.6)
    parser.add_argument("--core", help="import gencoords from this folder")
    action = parser.add_mutually_exclusive_group(required=True)
    action.add_argument("--save", help="an .npz file to write the plans' fields to")
    action.add_argument("--compare", help="an .npz file --save wrote, to compare these plans with")
    arguments = parser.parse_args()
    if arguments.core:
        _import_from(arguments.core)
    sys.path.insert(1, str(Path(__file__).resolve().parent))
    import bind_split  # noqa: E402  (after --core: it imports gencoords)
    print("gencoords from", Path(bind_split.Cage.__module__ and sys.modules["gencoords"].__file__).parent)
    saved = {}
    for name in arguments.fixtures:
        plan = bind_split.bind(bind_split.artist_cages.fixture(name, arguments.detail))
        saved.update({f"{name}/{field}": value for field, value in _plan_fields(plan).items()})
    if arguments.save:
        np.savez(arguments.save, **saved)
        print(f"saved {len(saved)} fields of {len(arguments.fixtures)} plans")
        return 0
    with np.load(arguments.compare, allow_pickle=True) as before:
        differing = 0
        for key, value in saved.items():
            difference = _difference(before[key], value)
            if difference is not None:
                differing += 1
                print(f"{key}: {difference}")
    print(f"{len(saved) - differing} of {len(saved)} fields bit for bit the same")
    return 1 if differing else 0


if __name__ == "__main__":
    sys.exit(main())
