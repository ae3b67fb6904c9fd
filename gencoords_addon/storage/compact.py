"""Compact storage: each mesh vertex's coordinates projected on a basis of s cage motions.

Bind chooses a basis ``B`` ((rows, s) float64: ``core.storage.compact``, rows = n, or n + m
for Green coordinates) and stores, per mesh vertex i, its s projections ``u_i`` (float32,
three to a vector point attribute, as exact storage's slots: ``BindData.slot_names``) and
the basis itself on the mesh's first rows points, three columns to a vector attribute
(``BindData.basis_names``: ``.gencoords_<key>_basis<t>``). The group (``graph.deformer``)
first sums each basis column's cage motion ``E_l = sum_j B_jl D_j`` (one Attribute Statistic
per lane, inside the shared chunk groups of ``graph.chunks``), then adds ``u_il E_l``: the
vertex moves by ``sum_j (u_i B^T)_j D_j``, the coordinates as the basis reproduces them.
"""

from ...core.storage import Storage
from ..bind import attributes
from ..blender_io import mesh_arrays
from ..graph import deformer
from . import exact

STORAGE = Storage.COMPACT


def nbytes(data):
    """Bytes of the attributes: the slots' as in exact storage, and as many again for the
    basis (its attributes are as long as the mesh)."""
    return 2 * exact.nbytes(data)


def write_steps(mesh, data, result):
    """Write the slots ((k, s) float32) and the basis (``result.basis``, (rows, s)): a
    generator yielding the fraction written (``bind.attributes.write_steps``)."""
    return attributes.write_steps(mesh, [(data.slot_names, result.slots), (data.basis_names, result.basis)])


def _read_basis(mesh, data):
    """The stored basis on the mesh's points ((k, s) float32), or None."""
    return mesh_arrays.read_triples(mesh, data.basis_names, data.slot_count)


def read_coordinates(mesh, data):
    """The (k, rows) float32 coordinates the slots and basis reproduce, or None."""
    slots = exact.read_slots(mesh, data)
    if slots is None:
        return None
    basis = _read_basis(mesh, data)
    return None if basis is None else slots @ basis[:data.rows].T


def read_column(mesh, data, cage_vertex):
    """Every mesh vertex's reproduced coordinate for ``cage_vertex`` ((k,) float32), or None."""
    slots = exact.read_slots(mesh, data)
    if slots is None:
        return None
    basis = _read_basis(mesh, data)
    return None if basis is None else slots @ basis[cage_vertex]


def group_steps(name, data, result):
    """The binding's node group (``graph.deformer.group_steps``), a generator yielding the
    fraction built and returning the group. The basis is on the mesh's first rows points."""
    def offset_steps(build, mesh, moving):
        return deformer.chunk_offset_steps(build, STORAGE, {"Mesh": mesh, "Cage": moving[0]}, data.slot_names,
                                           data.basis_names)
    return deformer.group_steps(name, data.key, result.rest_cage, data.mesh_vertex_count, offset_steps,
                                data.attribute_names, result.triangles)
