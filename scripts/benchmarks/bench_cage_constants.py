"""What Bind spends keeping a cage's constants in the deformer's group (its rest positions;
Green's triangles): the installed add-on's ``Builder.index_switch`` (at most
``SWITCH_ITEMS`` constants to an Index Switch node, one more choosing among them) against
one Index Switch holding them all, in seconds, for cages of several sizes. An item added
to an Index Switch costs more the more it holds, so one node over all grows much faster
than the cage.

Usage: bench_cage_constants.py [--counts 322 1000 2000]
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()
import bpy  # noqa: E402


def seconds(count, items):
    """Wall time of keeping ``count`` vectors in a new group, ``items`` to a node."""
    builder = session.addon_module("graph.builder")
    group = bpy.data.node_groups.new("constants", 'GeometryNodeTree')
    build = builder.Builder(group, ("rest",))
    index = build.add('GeometryNodeInputIndex', "rest").outputs[0]
    vectors = [(float(i), 0.5 * i, -1.0) for i in range(count)]
    kept = builder.SWITCH_ITEMS
    builder.SWITCH_ITEMS = items
    try:
        start = time.perf_counter()
        build.index_switch("rest", index, vectors)
        return time.perf_counter() - start
    finally:
        builder.SWITCH_ITEMS = kept
        bpy.data.node_groups.remove(group)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--counts", type=int, nargs="+", default=[322, 1000, 2000])
    arguments = parser.parse_args()
    session.install_extension()
    items = session.addon_module("graph.builder").SWITCH_ITEMS
    print(f"| cage vertices | {items} to a node (s) | one node (s) |\n|---:|---:|---:|")
    for count in arguments.counts:
        print(f"| {count} | {seconds(count, items):.3f} | {seconds(count, count):.3f} |")


if __name__ == "__main__":
    main()
