"""The least a Geometry Nodes deformer costs to play back, against Mesh Deform p5 in the
same run, on the harmonic issue's fixtures (issue 35's playback target: is it reachable
with a deformer that Blender evaluates from a node group?).

Routes, each on its own copy of the fixture's mesh, bound to the same cage:
  MD p5        Blender's Mesh Deform at precision 5 (its C loop over ~50 stored
               influences a vertex).
  GN empty     a Geometry Nodes modifier whose group passes the mesh through: what any
               node group costs before it does anything.
  GN floor K   the smallest deformer with K (cage vertex, weight) pairs a vertex, unrolled
               (no Repeat Zone): Object Info of the cage, K Sample Index gathers of its
               positions weighted by stored attributes, Set Position. K=1 is the floor of
               any deformer that reads the cage; K=8 a trilinear cell's nodes, K=12 the per-vertex
               pairs Automatic gives the cup and the cape.
  GenCoords    Harmonic at default settings (Automatic grid and storage), as Bind makes it.

The weights are a stand-in (the K nearest cage vertices, inverse distance): cost depends
on K and the access pattern, not on the values. Playback: ``playback.time_updates`` (one
cage vertex moved, ``view_layer.update()``, the evaluated mesh read), the median of
``--rounds`` rounds in which the routes take turns.

Usage: playback_floor.py [--fixtures hand quadruped cup cape character] [--detail 0.6]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.benchmarks import bench_local  # noqa: E402 (prepares the session, imports bpy)
from scripts.common import playback, scenes, session  # noqa: E402
from tests.fixtures import artist_cages  # noqa: E402
import bpy  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402

FIXTURES = ("hand", "quadruped", "cup", "cape", "character")


def node_group(name, pairs):
    """A modifier group: the mesh through (``pairs`` 0) or moved to the weighted sum of
    ``pairs`` cage positions read from attributes ``floor_index_k`` and ``floor_weight_k``."""
    group = bpy.data.node_groups.new(name, 'GeometryNodeTree')
    group.is_modifier = True
    group.interface.new_socket("Geometry", in_out='INPUT', socket_type='NodeSocketGeometry')
    group.interface.new_socket("Geometry", in_out='OUTPUT', socket_type='NodeSocketGeometry')
    nodes, links = group.nodes, group.links
    source, sink = nodes.new('NodeGroupInput'), nodes.new('NodeGroupOutput')
    if pairs == 0:
        links.new(source.outputs[0], sink.inputs[0])
        return group
    cage = nodes.new('GeometryNodeObjectInfo')
    cage.inputs["Object"].default_value = bpy.data.objects["FloorCage"]
    cage.transform_space = 'RELATIVE'
    position = nodes.new('GeometryNodeInputPosition')
    total = None
    for k in range(pairs):
        index, weight = nodes.new('GeometryNodeInputNamedAttribute'), nodes.new('GeometryNodeInputNamedAttribute')
        index.data_type, weight.data_type = 'INT', 'FLOAT'
        index.inputs["Name"].default_value, weight.inputs["Name"].default_value = f"floor_index_{k}", f"floor_weight_{k}"
        sample = nodes.new('GeometryNodeSampleIndex')
        sample.data_type, sample.domain = 'FLOAT_VECTOR', 'POINT'
        links.new(cage.outputs["Geometry"], sample.inputs["Geometry"])
        links.new(position.outputs[0], sample.inputs["Value"])
        links.new(index.outputs["Attribute"], sample.inputs["Index"])
        scaled = nodes.new('ShaderNodeVectorMath')
        scaled.operation = 'SCALE'
        links.new(sample.outputs[0], scaled.inputs[0])
        links.new(weight.outputs["Attribute"], scaled.inputs["Scale"])
        if total is None:
            total = scaled
        else:
            added = nodes.new('ShaderNodeVectorMath')
            added.operation = 'ADD'
            links.new(total.outputs[0], added.inputs[0])
            links.new(scaled.outputs[0], added.inputs[1])
            total = added
    moved = nodes.new('GeometryNodeSetPosition')
    links.new(source.outputs[0], moved.inputs["Geometry"])
    links.new(total.outputs[0], moved.inputs["Position"])
    links.new(moved.outputs[0], sink.inputs[0])
    return group


def stand_in_pairs(mesh_points, cage_points, pairs):
    """The K nearest cage vertices of each mesh vertex and inverse-distance weights summing
    to 1: (indices (V, K) int, weights (V, K) float)."""
    distances = np.linalg.norm(mesh_points[:, None, :] - cage_points[None, :, :], axis=2)
    nearest = np.argsort(distances, axis=1)[:, :pairs]
    weights = 1.0 / (np.take_along_axis(distances, nearest, axis=1) + 1e-6)
    return nearest.astype(np.int32), weights / weights.sum(axis=1, keepdims=True)


def add_floor(scene, pairs):
    """A copy of the fixture's mesh with a ``pairs`` floor modifier (0: pass-through)."""
    mesh = scenes.add_mesh_object(f"Floor{pairs}", scene.mesh_vertices, scene.mesh_faces)
    if pairs:
        indices, weights = stand_in_pairs(scene.mesh_vertices, scene.cage_vertices, pairs)
        for k in range(pairs):
            index = mesh.data.attributes.new(f"floor_index_{k}", 'INT', 'POINT')
            index.data.foreach_set("value", indices[:, k])
            weight = mesh.data.attributes.new(f"floor_weight_{k}", 'FLOAT', 'POINT')
            weight.data.foreach_set("value", weights[:, k].astype(np.float32))
    modifier = mesh.modifiers.new("Floor", 'NODES')
    modifier.node_group = node_group(f"Floor {pairs}", pairs)
    return mesh


def measure(scene, rounds):
    """Each route's median playback seconds on ``scene``: {route: seconds}."""
    scenes.reset_scene()
    cage = scenes.add_mesh_object("FloorCage", scene.cage_vertices, scene.cage_faces)
    routes = {}
    for label, method in (("MD p5", ("md", 5)), ("GenCoords", ("gencoords", HARMONIC))):
        mesh = scenes.add_mesh_object(label, scene.mesh_vertices, scene.mesh_faces)
        bench_local.bind(mesh, cage, method)
        routes[label] = mesh
    for pairs in (0, 1, 8, 12):
        routes["GN empty" if pairs == 0 else f"GN floor {pairs}"] = add_floor(scene, pairs)
    rest = scene.cage_vertices.astype(np.float32)
    times = {label: [] for label in routes}
    for _ in range(rounds):
        for label, mesh in routes.items():
            for other in routes.values():  # only the mesh timed is evaluated
                other.hide_viewport = other is not mesh
            bpy.context.view_layer.update()
            times[label].append(playback.time_updates(mesh, cage, rest)[0])
    return {label: float(np.median(seconds)) for label, seconds in times.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=list(FIXTURES))
    parser.add_argument("--detail", type=float, default=0.6, help="mesh density (1: 12k to 45k vertices)")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    print("\n".join(session.report_header("The least a Geometry Nodes deformer costs, against Mesh Deform")))
    session.install_extension()
    rows = []
    for name in args.fixtures:
        scene = artist_cages.fixture(name, args.detail)
        found = measure(scene, args.rounds)
        reference = found["MD p5"]
        rows.append(f"| {name} ({len(scene.mesh_vertices)}) | " + " | ".join(
            f"{seconds * 1e3:.2f} ({seconds / reference:.2f}x)" for seconds in found.values()) + " |")
        print(rows[-1], flush=True)
    print("\n| fixture (vertices) | " + " | ".join(found) + " |")
    print("|---|" + "---:|" * len(found))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
