"""Sparse storage: each mesh vertex's K largest coordinates, as (cage vertex, weight) pairs.

Mesh vertex i keeps its K largest coordinates as pairs (cage vertex ``j_ik``, weight
``w_ik``), renormalised to sum 1 (translations stay exact: ``core.storage.sparse``), in 2K
point attributes: K INT attributes (indices, ``index_attribute_names``) and K FLOAT
attributes (weights, ``weight_attribute_names``). The group outputs

    P_i + strength * mask_i * sum_k w_ik (C_{j_ik} - R_{j_ik})

with one gather per slot (Sample Index of the cage's displacement ``C - R`` at the stored
index) inside a Repeat Zone of K iterations that reads slot k's attributes by name
(``graph.gather``): the group has the same 36 nodes for any K and any cage, so building it
costs milliseconds (``scripts/benchmarks/bench_sparse_routes.py`` measured it against a
lane group instanced K times, plain per-slot nodes and the Armature modifier: the three
Geometry Nodes routes play back within 10 % of each other, about 0.8x Mesh Deform p5's
CPU time at K = 16 on the 43k-vertex character; the Armature modifier 1.4x, and never
bitwise at rest). Harmonic coordinates are stored in two levels instead
(``storage.two_level``).

At rest ``C == R`` bitwise (the rest cage is read back through the group's own Object
Info node), every gathered displacement is exactly 0 and the mesh is unchanged bitwise.
The guard, strength, mask and attribute stripping are the deformer's own
(``graph.deformer``).
"""

import numpy as np

from ...core.storage import Storage
from ...core.storage import sparse
from ..bind_layout import index_attribute_names, weight_attribute_names
from ..blender_io import mesh_arrays
from ..graph import deformer, gather
from ..steps import at_once

STORAGE = Storage.SPARSE
DESCRIPTION = ("GenCoords cage deformation (sparse storage): moves the mesh with "
               "its cage (bind data in the mesh's point attributes)")


def nbytes(data):
    """Bytes of the attributes: an int32 and a float32 per pair and mesh vertex."""
    return 8 * data.mesh_vertex_count * data.slot_count


def write_pairs(mesh, key, indices, weights, level="vertex"):
    """Store sparse pairs on ``mesh``: ``indices`` ((rows, K) int, rows <= its vertex
    count) as INT and ``weights`` ((rows, K) float) as FLOAT point attributes (zeros
    beyond ``rows``)."""
    count = np.shape(indices)[1]
    mesh_arrays.write_columns(mesh, index_attribute_names(key, count, level), indices, 'INT')
    mesh_arrays.write_columns(mesh, weight_attribute_names(key, count, level), weights, 'FLOAT')


def write_steps(mesh, data, result):
    """Write each vertex's pairs (``result.indices``, (k, K) int32, and their weights
    ``result.slots``): a generator taking one step."""
    yield 0.0
    write_pairs(mesh, data.key, result.indices, result.slots)


def read_pairs(mesh, key, slot_count, level="vertex"):
    """The pairs :func:`write_pairs` stored ((k, K) int32 and float32), or None when an
    attribute is missing."""
    indices = mesh_arrays.read_columns(mesh, index_attribute_names(key, slot_count, level), 'INT')
    weights = mesh_arrays.read_columns(mesh, weight_attribute_names(key, slot_count, level), 'FLOAT')
    return None if indices is None or weights is None else (indices, weights)


def read_coordinates(mesh, data, nodes=None):
    """The (k, n) float32 coordinates the stored pairs stand for (in two levels through the
    grid nodes' ``nodes``, (N, K') indices and weights), or None when an attribute is
    missing."""
    pairs = read_pairs(mesh, data.key, data.slot_count)
    if pairs is None:
        return None
    return sparse.layout_coordinates(*pairs, data.cage_vertex_count, nodes).astype(np.float32)


def read_column(mesh, data, cage_vertex):
    """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
    coordinates = read_coordinates(mesh, data)
    return None if coordinates is None else coordinates[:, cage_vertex]


def group_steps(name, data, result, source_steps=None):
    """The binding's node group (``graph.deformer.group_steps``), built in one step: a
    generator returning the group. ``source_steps(build, mesh, cage_and_displacement)``
    gives the (geometry, field) the pairs' indices point into: the cage's displacement, or
    in two levels the grid nodes' (``storage.two_level``)."""
    def offset_steps(build, mesh, moving):
        source = moving if source_steps is None else source_steps(build, mesh, moving)
        return at_once(gather.weighted_gather(build, *source, data.key, data.slot_count))
    return deformer.group_steps(name, data.key, result.rest_cage, data.mesh_vertex_count, offset_steps,
                                data.attribute_names, description=DESCRIPTION)
