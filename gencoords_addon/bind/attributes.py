"""The bind data's attributes on the mesh through their life, whatever the storage: written
at Bind (each storage's module says which, ``gencoords_addon.storage``), parked
(renamed out of the deformer's reach, no copy) when an Unbind starts, then put back if it
fails or dropped once the modifier is gone, and removed when a Bind fails half-way."""


from ..blender_io import mesh_arrays
from ..bind_layout import PARKED_PREFIX, attribute_prefix


# Attributes written between two steps of a Bind's writing (progress, Esc).
STEP_ATTRIBUTES = 16


def write_steps(mesh, parts):
    """Write vector point attributes three columns each, ``parts`` a list of (names,
    (rows, 3 len(names)) values) pairs, in steps of ``STEP_ATTRIBUTES`` attributes: a
    generator yielding the fraction written (what is written stays: :func:`remove_slots`
    removes it). Each storage says what it writes (``gencoords_addon.storage``)."""
    total, written = sum(len(names) for names, _ in parts), 0
    for names, values in parts:
        for start in range(0, len(names), STEP_ATTRIBUTES):
            yield written / total
            batch = names[start:start + STEP_ATTRIBUTES]
            mesh_arrays.write_triples(mesh, batch, values[:, 3 * start:3 * (start + len(batch))])
            written += len(batch)


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
