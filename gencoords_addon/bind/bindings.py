"""The bindings in the file, read back from their modifiers: lookups, keeping a binding in
step with its cage object, and removing bindings (all or none).

A binding is a Geometry Nodes modifier whose node group carries ``METADATA`` (a
``BindData``), and the bind data's attributes on the mesh (``bind.attributes``).
"""

from dataclasses import dataclass, replace

import bpy
import numpy as np

from .. import messages, storage
from ..blender_io import compat, mesh_io
from ..bind_layout import BAKE_INFO, METADATA, BindData
from ..graph import deformer, helpers
from . import attributes


@dataclass
class Binding:
    """A committed binding, read back from its modifier."""

    modifier: bpy.types.Modifier
    group: bpy.types.NodeTree
    data: BindData  # its METADATA

    @property
    def key(self):
        return self.data.key

    @property
    def cage(self):
        """The cage object the modifier reads (None when it was deleted)."""
        return compat.get_modifier_input(self.modifier, deformer.CAGE)

    @property
    def deleted_cage(self):
        """Name of the cage deleted while bound (see ``follow_cage``), or None."""
        return self.data.deleted_cage if self.cage is None else None

    @property
    def rest_cage(self):
        """The cage at bind time ((n, 3) float32, the mesh's local space), as the deformer
        keeps it; None when the node group lost it."""
        return deformer.read_rest_cage(self.group, self.data.cage_vertex_count)

    def coordinates(self, mesh):
        """The (k, rows) float32 coordinates the mesh deforms with (compact: as reproduced
        by its slots and basis; sparse: its pairs'), or None when the bind data is missing."""
        return storage.of(self.data).read_coordinates(mesh, self.data)

    def coordinate_column(self, mesh, cage_vertex):
        """Every mesh vertex's coordinate for ``cage_vertex`` ((k,) float32), or None."""
        return storage.of(self.data).read_column(mesh, self.data, cage_vertex)


def bindings(obj):
    """The bindings of ``obj``, in modifier stack order."""
    found = []
    for modifier in getattr(obj, "modifiers", ()):
        group = getattr(modifier, "node_group", None) if modifier.type == 'NODES' else None
        stored = group.get(METADATA) if group is not None else None
        if stored is not None:
            found.append(Binding(modifier, group, BindData.from_properties(stored.to_dict())))
    return found


def binding(obj, cage=None, *, missing_cage=False):
    """The first binding of ``obj`` (to ``cage`` when given; with ``missing_cage``, to
    no cage: it was deleted), or None."""
    if missing_cage:
        found = [b for b in bindings(obj) if b.cage is None]
    else:
        found = [b for b in bindings(obj) if cage is None or b.cage == cage]
    return found[0] if found else None


def is_deleted(obj):
    """Whether the local object ``obj`` was deleted by the artist yet lives on, held by a
    modifier input or a setting: it is in no collection of any scene."""
    return obj is not None and obj.library is None and not obj.users_collection


def follow_cage(obj, found):
    """Keep the binding ``found`` of ``obj`` in step with its cage object: let go of a
    cage the artist deleted (unlinked from every collection but still held: the deformer
    then passes the mesh through), note the cage's name while it lives and, once it is
    gone, which cage that was (``Binding.deleted_cage``, for the panel).

    Returns the name of a cage found gone just now, else None.
    """
    cage = found.cage
    if is_deleted(cage):
        compat.set_modifier_input(found.modifier, deformer.CAGE, None)
        cage = None
    data = found.data
    if cage is not None:
        # Renamed since Bind, or a deletion undone in memory (see ``hold_cage``).
        if data.cage_name != cage.name or data.deleted_cage is not None:
            _store(found, replace(data, cage_name=cage.name, deleted_cage=None))
        return None
    if data.deleted_cage is not None or data.cage_name is None:
        return None
    _store(found, replace(data, deleted_cage=data.cage_name))
    # Blender's Delete clears the input without re-evaluating the mesh, which then
    # shows the last deformation until something else changes.
    obj.update_tag()
    return data.cage_name


def hold_cage(obj, found, cage):
    """Give the binding ``found`` of ``obj`` back the cage ``follow_cage`` let go of, as
    Ctrl+Z of the Delete should have: Blender's undo keeps in memory the data whose saved
    state is the same in both undo steps, and the letting go came after the Delete's step
    was saved, so the undo keeps it."""
    compat.set_modifier_input(found.modifier, deformer.CAGE, cage)
    follow_cage(obj, found)  # reads the input again: clears the deleted cage's name
    obj.update_tag()


def _store(found, data):
    """Write ``data`` as the binding ``found``'s metadata."""
    found.group[METADATA] = data.to_properties()
    found.data = data


def remove_orphaned_groups():
    """Delete binding node groups nothing uses any more (left by Apply of the modifier),
    then the helper groups only they used."""
    orphans = [group for group in bpy.data.node_groups
               if group.users == 0 and group.library is None and METADATA in group]
    for group in orphans:
        bpy.data.node_groups.remove(group)
    if orphans:
        helpers.remove_unused_helpers()


def meshes_driven_by(cage):
    """The objects with a binding to ``cage``, in ``bpy.data`` order."""
    return [obj for obj in bpy.data.objects
            if obj.type == 'MESH' and any(found.cage == cage for found in bindings(obj))]


def drives(obj, cage):
    """Whether ``cage`` follows ``obj``, directly or through chains of bound cages."""
    seen, pending = set(), [cage]
    while pending:
        cage = pending.pop()
        if cage is None or cage.session_uid in seen:
            continue
        if cage == obj:
            return True
        seen.add(cage.session_uid)
        pending.extend(found.cage for found in bindings(cage))
    return False


def armatures_following(obj, cage):
    """The enabled Armature modifiers of ``obj`` whose armature was baked from ``cage``:
    a bone follows one of its vertices (a Copy Location onto it), or Bake to Bones'
    Fitted mode recorded it. As (modifier name, armature object name) pairs: the mesh
    already moves with the cage (or replays its baked motion) through them, so a binding
    to the same cage moves it twice."""
    found = []
    for modifier in obj.modifiers:
        rig = modifier.object if modifier.type == 'ARMATURE' else None
        if rig is None or not modifier.show_viewport or rig.pose is None:
            continue
        baked = rig.data.get(BAKE_INFO)
        if (baked is not None and "cage" in baked and baked["cage"] == cage.name) or any(
                constraint.type == 'COPY_LOCATION' and constraint.target == cage
                for bone in rig.pose.bones for constraint in bone.constraints):
            found.append((modifier.name, rig.name))
    return found


def keys_used_elsewhere(obj):
    """Keys of the bindings that other objects sharing the mesh of ``obj`` (linked
    duplicates, Alt+D) deform with: their bind data on the shared mesh must stay."""
    return {found.key for other in bpy.data.objects
            if other != obj and other.type == 'MESH' and other.data == obj.data
            for found in bindings(other)}


def remove(obj, bindings):
    """Delete ``bindings`` of ``obj`` (their modifiers, node groups and attributes), all
    or, as far as Blender lets anything fail, none.

    The attributes are parked first (renamed, no copy: :func:`attributes.park_slots`) and
    put back if anything fails before a modifier is gone; then the modifiers go (the step
    after which the mesh no longer follows the cage), then the parked attributes and the
    node groups nobody uses any more. The mesh data is left exactly as it was before
    those Binds.

    Returns
    -------
    removed : list of str
        Names of the modifiers removed: all of them, or on an exception (re-raised with
        this list as its ``gencoords_removed`` attribute) the ones already gone.
    """
    names = [each.modifier.name for each in bindings]  # a removed modifier's RNA is gone
    parked, removed = {}, []
    shared = keys_used_elsewhere(obj)
    try:
        for each in bindings:  # bind data a linked duplicate deforms with stays
            parked[each.key] = {} if each.key in shared else attributes.park_slots(obj.data, each.key)
        for name, each in zip(names, bindings):
            group = each.group
            compat.remove_nodes_modifier(obj, each.modifier)
            removed.append(name)
            attributes.drop_parked_slots(obj.data, parked[each.key])
            if group.users == 0:
                bpy.data.node_groups.remove(group)
        helpers.remove_unused_helpers()
    except Exception as error:
        for name, each in zip(names, bindings):
            if name not in removed:  # still bound: its data back
                attributes.put_back_slots(obj.data, parked.get(each.key, {}))
        error.gencoords_removed = removed
        raise
    return removed


def deformation_problem(obj, found, depsgraph=None):
    """Why the deformer passes the mesh of ``obj`` through unchanged, or None.

    The node group checks the same conditions it can see (vertex counts, finite cage);
    this says them in words, and also notices cage face changes it cannot see.
    """
    data = found.data
    if not data.is_current:
        return (f"The bind data of '{obj.name}' is from another version of GenCoords: "
                "Bind again or Unbind")
    mesh_attributes = obj.data.attributes
    if any(name not in mesh_attributes for name in data.attribute_names):
        return (f"The bind data of '{obj.name}' is missing from its mesh (removed through an object "
                "sharing it?): the mesh is not deformed; Bind again or Unbind")
    cage = found.cage
    if cage is None and found.deleted_cage is not None:
        return (f"The cage '{found.deleted_cage}' was deleted: the mesh is not deformed; "
                "pick another cage and Bind, or Unbind")
    if cage is None:
        return ("The cage was deleted or cleared: the mesh is not deformed; pick a cage "
                "and Bind again, or Unbind")
    change = len(obj.data.vertices) - data.mesh_vertex_count
    if change and obj.mode != 'EDIT':
        verb = "added" if change > 0 else "deleted"
        until = ("bound again (Auto Rebind binds it on leaving Edit Mode, or Bind)" if obj.gencoords.auto_rebind
                 else "you Bind again (or turn on Auto Rebind)")
        return f"Mesh edited since Bind: {abs(change)} vertices {verb}; it is not deformed until {until}"
    if not mesh_io.invertible(obj.matrix_world):  # the deformer's guard: no cage in its space
        return messages.zero_scale("mesh", obj.name, mesh_io.zero_scale_axes(obj.matrix_world),
                                   "it deforms again", effect="the mesh is not deformed")
    depsgraph = depsgraph or bpy.context.view_layer.depsgraph
    with mesh_io.evaluated_mesh(cage, depsgraph) as cage_mesh:
        count = len(cage_mesh.vertices)
        faces_hash = mesh_io.faces_hash(cage_mesh)
        finite = bool(np.isfinite(mesh_io.read_positions(cage_mesh)).all())
    if count != data.cage_vertex_count:
        return (f"The cage '{cage.name}' now has {count} vertices (bound with "
                f"{data.cage_vertex_count}): the mesh is not deformed; Bind again or Unbind")
    if faces_hash != data.cage_faces_hash:
        return (f"The faces of cage '{cage.name}' changed since Bind: the deformation no "
                "longer matches it; Bind again or Unbind")
    if not finite:
        return (f"The cage '{cage.name}' has undefined (NaN or infinite) positions: the "
                "mesh is not deformed until they are fixed")
    return None
