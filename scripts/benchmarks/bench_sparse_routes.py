"""Native routes for sparse storage against Mesh Deform, in one Blender process.

Sparse storage keeps per mesh vertex its K largest coordinates as (cage vertex, weight)
pairs summing to 1; the vertex moves to ``P + sum_k w_k (C_{i_k} - R_{i_k})``. Routes:

  GN repeat    Geometry Nodes, a Repeat Zone of K iterations (Named Attribute index and
               weight, their names made from the iteration number, Sample Index of the
               cage's displacement, multiply-add): a group of constant size, the add-on's
               builder (``gencoords_addon/graph/gather.py``).
  GN lane      the same four nodes in a lane group instanced K times.
  GN plain     4 nodes per slot in the binding's own group.
  Armature     Blender's Armature modifier, one translation-only bone per cage vertex held
               on it by a Copy Location constraint (the cage's one-vertex vertex groups),
               the pairs as the mesh's vertex groups; the update includes the bones'
               evaluation.
  two-level    harmonic coordinates' layout: a grid of cubic cells fitted to the cage's
               box (``--resolutions``: cells along its longest side); the N grid nodes
               the mesh's cells touch carry K' = ``--node-slots`` pairs over the cage
               each (stacked in columns as long as the mesh), the group stores their
               displacements on a cloud of N points, then every vertex gathers its
               cell's 8 nodes (trilinear).

The weights are a stand-in with the access pattern of local coordinates (inverse squared
distance to the K nearest cage vertices; the grid nodes' likewise): cost depends on K and
where the indices point, not on the values. Each route's result is checked against
numpy under the demo's non-affine cage edit (max error, of the cage diagonal) and at rest
(bitwise).

Metrics: build = wall time to write the bind data (attributes or vertex groups) and
build the node group / rig from Python; update = median (and min) of ``--rounds`` live
updates, the routes taking turns in each round on their own mesh and cage (move one cage
vertex, ``view_layer.update()``, read the evaluated positions:
``scripts/common/playback.py``, as ``bench_blender.py``), with the ratios to Mesh Deform p5's and p6's in the same run: of
the medians, and of the minima (on a busy machine the least disturbed figure); CPU = the
process's CPU time over the update, all threads (varies far less on a shared machine).

Usage: bench_sparse_routes.py [--mesh character|sphere] [--slots 8 16 32] [--precisions 5 6]
"""

import argparse
import sys
import time
from types import SimpleNamespace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: scripts.common
from scripts.common import session  # noqa: E402

session.prepare()  # before bpy is imported
from scripts.common import scenes  # noqa: E402
import bpy  # noqa: E402
from scripts.common import playback  # noqa: E402
from scripts.common.playback import settle  # noqa: E402
from scripts.common.scenes import arrays  # noqa: E402

KEY = "bench"


# ------------------------------------------------------------------------ stand-in weights


def nearest_weights(points, cage_points, count):
    """The ``count`` nearest cage vertices of each point and inverse squared distance
    weights summing to 1: ((p, count) int, (p, count) float64)."""
    indices = np.empty((len(points), count), dtype=np.int64)
    for start in range(0, len(points), 4096):
        block = points[start:start + 4096]
        distance = ((block[:, None, :] - cage_points[None]) ** 2).sum(-1)
        indices[start:start + 4096] = np.argpartition(distance, count - 1, axis=1)[:, :count]
    squared = ((points[:, None, :] - cage_points[indices]) ** 2).sum(-1)
    weights = 1.0 / (squared + 1e-6)
    return indices, weights / weights.sum(axis=1, keepdims=True)


def grid_layout(points, cage_points, resolution):
    """Cubic cells fitted to the cage's box: each point's cell corners (indices into the
    N nodes the cells touch) and trilinear weights ((p, 8) each), and those nodes'
    positions ((N, 3))."""
    low, high = cage_points.min(axis=0), cage_points.max(axis=0)
    cell = (high - low).max() / resolution
    shape = np.ceil((high - low) / cell).astype(int) + 1  # nodes per axis
    scaled = (points - low) / cell
    base = np.clip(np.floor(scaled).astype(int), 0, shape - 2)
    t = scaled - base
    corners, weights = [], []
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                node = base + (dx, dy, dz)
                corners.append(np.ravel_multi_index(node.T, shape))
                weights.append(np.prod(np.where((dx, dy, dz), t, 1 - t), axis=1))
    corners = np.stack(corners, axis=1)
    used, local = np.unique(corners, return_inverse=True)
    nodes = low + np.stack(np.unravel_index(used, shape), axis=1) * cell
    return local.reshape(corners.shape), np.stack(weights, axis=1), nodes


# ------------------------------------------------------------------------------ routes


def add_nodes_modifier(mesh, cage, group):
    modifier = mesh.modifiers.new("Sparse", 'NODES')
    modifier.node_group = group
    session.addon_module("blender_io.compat").set_modifier_input(
        modifier, session.addon_module("graph.helpers").CAGE, cage)
    return modifier


def _lane_group(build):
    """A helper group: ``Sum + Weight(name) * Value(Source, at Index(name))``."""
    group = bpy.data.node_groups.get(".Sparse lane helper")
    if group is not None:
        return group
    group, lane, group_input, group_output = session.addon_module("graph.builder").new_group(
        ".Sparse lane helper", [("Source", 'NodeSocketGeometry'), ("Value", 'NodeSocketVector'),
                        ("Index Name", 'NodeSocketString'), ("Weight Name", 'NodeSocketString'),
                        ("Sum", 'NodeSocketVector')], [("Sum", 'NodeSocketVector')], "lane",
        session.addon_module("graph.helpers").HELPER_COLUMNS)
    index = lane.add('GeometryNodeInputNamedAttribute', "read", data_type='INT')
    lane.link(group_input.outputs["Index Name"], index.inputs["Name"])
    weight = lane.add('GeometryNodeInputNamedAttribute', "read", data_type='FLOAT')
    lane.link(group_input.outputs["Weight Name"], weight.inputs["Name"])
    gathered = lane.sample_index("combine", group_input.outputs["Source"],
                                 group_input.outputs["Value"], index.outputs["Attribute"])
    lane.link(lane.math("combine", 'MULTIPLY_ADD', gathered, weight.outputs["Attribute"],
                        group_input.outputs["Sum"]), group_output.inputs["Sum"])
    return group


def slot_names(key, slot_count, level):
    """(index attribute, weight attribute) of each slot."""
    layout = session.addon_module("bind_layout")
    return zip(layout.index_attribute_names(key, slot_count, level),
               layout.weight_attribute_names(key, slot_count, level))


def lane_gather(build, source, value, key, slot_count, level="vertex"):
    """One lane group instanced per slot: one node and three links per slot."""
    total = None
    for index_name, weight_name in slot_names(key, slot_count, level):
        node = build.add('GeometryNodeGroup', "accumulate", node_tree=_lane_group(build))
        build.link(source, node.inputs["Source"])
        build.link(value, node.inputs["Value"])
        node.inputs["Index Name"].default_value = index_name
        node.inputs["Weight Name"].default_value = weight_name
        if total is not None:
            build.link(total, node.inputs["Sum"])
        total = node.outputs["Sum"]
    return total


def plain_gather(build, source, value, key, slot_count, level="vertex"):
    """Four nodes per slot in the binding's own group."""
    total = None
    for index_name, weight_name in slot_names(key, slot_count, level):
        index = build.named_attribute("accumulate", index_name, 'INT')
        weight = build.named_attribute("accumulate", weight_name, 'FLOAT')
        gathered = build.sample_index("accumulate", source, value, index)
        total = build.math("accumulate", 'MULTIPLY_ADD', gathered, weight,
                           total if total is not None else (0.0, 0.0, 0.0))
    return total


GATHERS = {"repeat": None, "lane": lane_gather, "plain": plain_gather}  # None: the add-on's


def gn_route(mesh, cage, rest_cage, gather, pairs, nodes=None):
    """Bind a Geometry Nodes route, as sparse storage writes it (``storage.sparse``, in two
    levels ``storage.two_level``); returns the build seconds."""
    layout, gathers = session.addon_module("bind_layout"), session.addon_module("graph.gather")
    run_to_end = session.addon_module("steps").run_to_end
    start = time.perf_counter()
    indices, weights = pairs
    data = layout.BindData(storage=layout.Storage.SPARSE, key=KEY, slot_count=indices.shape[1],
                           mesh_vertex_count=len(mesh.data.vertices), cage_vertex_count=len(rest_cage),
                           node_count=0 if nodes is None else len(nodes[0]),
                           node_slot_count=0 if nodes is None else nodes[0].shape[1])
    result = SimpleNamespace(slots=weights, indices=indices, nodes=nodes, rest_cage=rest_cage, triangles=None)
    home = session.addon_module("storage").of(data)
    run_to_end(home.write_steps(mesh.data, data, result))
    original = gathers.weighted_gather
    if GATHERS[gather] is not None:
        gathers.weighted_gather = GATHERS[gather]
    try:
        group = run_to_end(home.group_steps(f"Sparse {gather}", data, result))
    finally:
        gathers.weighted_gather = original
    add_nodes_modifier(mesh, cage, group)
    return time.perf_counter() - start


def armature_route(mesh, cage, rest_cage, pairs):
    """One bone per cage vertex following it; the pairs as vertex groups."""
    bones = session.addon_module("bake.bones")
    start = time.perf_counter()
    names = bones.bone_names(len(rest_cage))
    for j, name in enumerate(names):
        cage.vertex_groups.new(name=name).add([j], 1.0, 'REPLACE')
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    bpy.context.scene.collection.objects.link(rig)
    bones._add_following_bones(rig, cage, names, rest_cage.astype(np.float64))
    dense = np.zeros((len(mesh.data.vertices), len(rest_cage)))
    np.put_along_axis(dense, pairs[0], pairs[1], axis=1)
    session.addon_module("blender_io.mesh_arrays").write_weights(mesh, names, dense)
    skin = mesh.modifiers.new("Armature", 'ARMATURE')
    skin.object = rig
    return time.perf_counter() - start


def mesh_deform_route(mesh, cage, precision):
    modifier = mesh.modifiers.new("MeshDeform", 'MESH_DEFORM')
    modifier.object, modifier.precision = cage, precision
    scenes.make_active(mesh)
    start = time.perf_counter()
    with session.quiet():
        bpy.ops.object.meshdeform_bind(modifier=modifier.name)
    return time.perf_counter() - start


# ---------------------------------------------------------------------------- measuring


def add_pair(name, cache={}):
    """The benchmark's mesh and its own cage, added to the scene; returns (mesh, cage)."""
    if name == "character":
        return scenes.add_character()
    if "sphere" not in cache:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=191, radius=1.4)
        obj = bpy.context.active_object
        cache["sphere"] = (arrays.read_positions(obj.data).copy(),
                           [tuple(p.vertices) for p in obj.data.polygons])
        bpy.data.objects.remove(obj)
    return scenes.add_mesh_object("Sphere", *cache["sphere"]), scenes.add_icosphere_cage(3)


def expected_displacement(route, cage_displacement):
    """numpy's ``sum_k w_k (C - R)`` of a route's pairs (two levels: nodes, then cells)."""
    moved = cage_displacement
    for indices, weights in route.get("levels", ()):
        moved = np.einsum("pk,pkc->pc", weights, moved[indices])
    return moved


def bind_route(scene, route):
    """Add the route's own mesh and cage and bind them; returns the route with them."""
    mesh, cage = add_pair(scene)
    rest_cage = arrays.read_positions(cage.data).copy()
    bpy.context.view_layer.update()
    kind = route["kind"]
    if kind == "md":
        build = mesh_deform_route(mesh, cage, route["precision"])
    elif kind == "armature":
        build = armature_route(mesh, cage, rest_cage, route["levels"][0])
    else:
        levels = route["levels"]
        build = gn_route(mesh, cage, rest_cage, kind, levels[-1],
                         nodes=levels[0] if len(levels) == 2 else None)
    group = next((m.node_group for m in mesh.modifiers if m.type == 'NODES'), None)
    size = (f"{len(group.nodes)} / {len(group.links)}" if group is not None else
            f"{len(rest_cage)} bones" if kind == "armature" else "-")
    return dict(route, mesh=mesh, cage=cage, rest_cage=rest_cage, build=build, size=size)


def check_route(route, rest_mesh):
    """Bitwise at rest, and the max error against numpy under the non-affine edit."""
    mesh, cage, rest_cage = route["mesh"], route["cage"], route["rest_cage"]
    route["rest"] = bool(np.array_equal(settle(mesh), rest_mesh))
    edited = scenes.nonaffine_edit(rest_cage)
    arrays.write_positions(cage.data, edited)
    moved = settle(mesh)
    arrays.write_positions(cage.data, rest_cage)
    settle(mesh)
    if route["kind"] == "md":
        route["error"] = None
        return
    expected = rest_mesh + expected_displacement(route, edited - rest_cage.astype(np.float64))
    route["error"] = float(np.abs(moved - expected).max()) / scenes.cage_size(rest_cage)


def time_interleaved(bound, rounds):
    """Each route's median update over ``rounds`` rounds, the routes taking turns in every
    round (a busy machine then slows all of them alike)."""
    state = [arrays.evaluated_positions(r["mesh"]).copy() for r in bound]
    times = [[] for _ in bound]
    for repeat in range(rounds):
        for i, route in enumerate(bound):
            seconds, _, state[i], cpu = playback.time_update(route["mesh"], route["cage"],
                                                             route["rest_cage"], repeat, state[i])
            times[i].append((seconds, cpu))
    for route, measured in zip(bound, times):
        arrays.write_positions(route["cage"].data, route["rest_cage"])
        wall, cpu = np.array(measured).T
        route["update"], route["update_min"], route["cpu"] = np.median(wall), wall.min(), np.median(cpu)


def routes(scene, slots, resolutions, node_slots):
    """Every route to measure, with its stand-in pairs (computed once per scene)."""
    scenes.reset_scene()
    mesh, cage = add_pair(scene)
    points = arrays.read_positions(mesh.data).astype(np.float64)
    cage_points = arrays.read_positions(cage.data).astype(np.float64)
    found = []
    for count in slots:
        pairs = nearest_weights(points, cage_points, count)
        for kind in ("repeat", "lane", "plain"):
            found.append({"name": f"GN {kind}", "kind": kind, "slots": count, "levels": [pairs]})
        found.append({"name": "Armature", "kind": "armature", "slots": count, "levels": [pairs]})
    for resolution in resolutions:
        corners, trilinear, nodes = grid_layout(points, cage_points, resolution)
        if len(nodes) > len(points):
            print(f"  two-level at {resolution} cells: {len(nodes)} nodes > {len(points)} "
                  "vertices, skipped", flush=True)
            continue
        for count in node_slots:
            node_pairs = nearest_weights(nodes, cage_points, count)
            found.append({"name": f"two-level {resolution} cells, {len(nodes)} nodes x {count}",
                          "kind": "repeat", "slots": 8, "levels": [node_pairs, (corners, trilinear)]})
    bpy.data.objects.remove(mesh)
    bpy.data.objects.remove(cage)
    return points.astype(np.float32), len(cage_points), found


def table(bound, references):
    lines = ["| route | K | group nodes / links | build | update median / min | median / MD p5 "
             "| min / MD p5 min | min / MD p6 min | CPU median | CPU / MD p5 | rest bitwise "
             "| max error (of diagonal) |",
             "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---|---:|"]
    for route in bound:
        error = "-" if route["error"] is None else f"{route['error']:.1e}"
        ratios = [f"{route[key] / references[p][key]:.2f}" if p in references else "-"
                  for p, key in ((5, "update"), (5, "update_min"), (6, "update_min"), (5, "cpu"))]
        lines.append(
            f"| {route['name']} | {route.get('slots', '-')} | {route['size']} | {route['build']:.3f} s "
            f"| {route['update'] * 1e3:.2f} / {route['update_min'] * 1e3:.2f} ms | {' | '.join(ratios[:3])} "
            f"| {route['cpu'] * 1e3:.2f} ms | {ratios[3]} "
            f"| {'yes' if route['rest'] else 'NO'} | {error} |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh", choices=("character", "sphere"), default="character")
    parser.add_argument("--slots", nargs="+", type=int, default=[8, 16, 32])
    parser.add_argument("--precisions", nargs="+", type=int, default=[5, 6])
    parser.add_argument("--resolutions", nargs="+", type=int, default=[32, 64])
    parser.add_argument("--node-slots", nargs="+", type=int, default=[16, 48])
    parser.add_argument("--rounds", type=int, default=15, help="timed updates per route")
    parser.add_argument("--output", type=Path, default=session.OUT / "bench_sparse_routes.md")
    args = parser.parse_args()
    header = session.report_header("Sparse storage's native routes against Mesh Deform (Blender)")
    print("\n".join(header), flush=True)
    session.install_extension()
    rest_mesh, cage_vertices, found = routes(args.mesh, args.slots, args.resolutions, args.node_slots)
    print(f"{args.mesh}: {len(rest_mesh)} vertices, cage {cage_vertices} vertices\n", flush=True)
    found = [{"name": f"Mesh Deform p{p}", "kind": "md", "precision": p} for p in args.precisions] + found
    bound = []
    for route in found:
        bound.append(bind_route(args.mesh, route))
        print(f"  bound {route['name']} K={route.get('slots', '-')}: {bound[-1]['build']:.3f} s",
              flush=True)
    bpy.context.view_layer.update()
    time_interleaved(bound, args.rounds)
    for route in bound:
        check_route(route, rest_mesh)
    references = {r["precision"]: r for r in bound if r["kind"] == "md"}
    body = table(bound, references)
    print("\n" + body, flush=True)
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text("\n".join(header) + f"\n\n{args.mesh}: {len(rest_mesh)} vertices, cage "
                           f"{cage_vertices} vertices\n\n" + body + "\n")
    print(f"written to {args.output}")


if __name__ == "__main__":
    main()
