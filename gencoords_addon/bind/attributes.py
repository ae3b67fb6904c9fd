"""The bind data's attributes on the mesh through their life: written at Bind, parked
(renamed out of the deformer's reach, no copy) when an Unbind starts, then put back if it
fails or dropped once the modifier is gone, and removed when a Bind fails half-way."""

import numpy as np

from ..blender_io import mesh_arrays
from ..bind_layout import PARKED_PREFIX, attribute_prefix


def write(mesh, data, slots, basis=None, triangles=None):
    """Write a binding's attributes (named by ``data``, a ``BindData``): its slots ((k, s)),
    compact storage's basis ((rows, s)) and Green coordinates' cage triangles ((m, 3))."""
    mesh_arrays.write_triples(mesh, data.slot_names, slots)
    if data.basis_names is not None:
        mesh_arrays.write_triples(mesh, data.basis_names, basis)
    if data.triangle_name is not None:  # vertex indices, exact in float32 below 2^24
        mesh_arrays.write_triples(mesh, [data.triangle_name], triangles.astype(np.float32))


def remove_slots(mesh, key):
    """Delete every attribute of the binding ``key`` from ``mesh``."""
    prefix = attribute_prefix(key)
    for name in [a.name for a in mesh.attributes if a.name.startswith(prefix)]:
        mesh.attributes.remove(mesh.attributes[name])


def park_slots(mesh, key):
    """Take the binding ``key``'s attributes out of the deformer's reach, all or none,
    by renaming them (no copy of the bind data): the first step of an Unbind that can
    still be undone (:func:`put_back_slots`) or finished (:func:`drop_parked_slots`).

    Returns
    -------
    parked : dict of str -> str
        Parked name -> original name.
    """
    prefix = attribute_prefix(key)
    parked = {}
    try:
        for name in [a.name for a in mesh.attributes if a.name.startswith(prefix)]:
            attribute = mesh.attributes[name]
            attribute.name = PARKED_PREFIX + name
            parked[attribute.name] = name  # as Blender made it unique
    except Exception:
        put_back_slots(mesh, parked)
        raise
    return parked


def put_back_slots(mesh, parked):
    """Undo :func:`park_slots`."""
    for parked_name, name in parked.items():
        attribute = mesh.attributes.get(parked_name)
        if attribute is not None:
            attribute.name = name


def drop_parked_slots(mesh, parked):
    """Finish an Unbind: delete what :func:`park_slots` parked."""
    for parked_name in parked:
        attribute = mesh.attributes.get(parked_name)
        if attribute is not None:
            mesh.attributes.remove(attribute)
