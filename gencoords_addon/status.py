"""The panel's status block as (text, icon) lines, and why a bound mesh is not deforming.

Every figure comes from the binding's metadata, which holds what the core computed.
"""

import bpy
import numpy as np

from . import binding, mesh_io, messages
from .bind_layout import FORMAT
from .enums import STORAGE_ITEMS, enum_label, kind_label

OUTSIDE_VERBS = {"project": "projected onto the cage", "extrapolate": "extrapolated"}


def deformation_problem(obj, found, depsgraph=None):
    """Why the deformer passes the mesh of ``obj`` through unchanged, or None.

    The node group checks the same conditions it can see (vertex counts, finite cage);
    this says them in words, and also notices cage face changes it cannot see.
    """
    info = found.info
    if info.get("format") != FORMAT:
        return (f"The bind data of '{obj.name}' is from another version of GenCoords: "
                "Bind again or Unbind")
    mesh_attributes = obj.data.attributes
    if any(name not in mesh_attributes for name in found.slot_names + (found.basis_names or [])):
        return (f"The bind data of '{obj.name}' is missing from its mesh (removed through an object "
                "sharing it?): the mesh is not deformed; Bind again or Unbind")
    cage = found.cage
    if cage is None and found.deleted_cage is not None:
        return (f"The cage '{found.deleted_cage}' was deleted: the mesh is not deformed; "
                "pick another cage and Bind, or Unbind")
    if cage is None:
        return ("The cage was deleted or cleared: the mesh is not deformed; pick a cage "
                "and Bind again, or Unbind")
    change = len(obj.data.vertices) - info["mesh_vertex_count"]
    if change and obj.mode != 'EDIT':
        verb = "added" if change > 0 else "deleted"
        return (f"Mesh edited since Bind: {abs(change)} vertices {verb}; it is not deformed "
                "until you Bind again (or turn on Auto Rebind)")
    depsgraph = depsgraph or bpy.context.view_layer.depsgraph
    with mesh_io.evaluated_mesh(cage, depsgraph) as cage_mesh:
        count = len(cage_mesh.vertices)
        faces_hash = mesh_io.faces_hash(cage_mesh)
        finite = bool(np.isfinite(mesh_io.read_positions(cage_mesh)).all())
    if count != info["cage_vertex_count"]:
        return (f"The cage '{cage.name}' now has {count} vertices (bound with "
                f"{info['cage_vertex_count']}): the mesh is not deformed; Bind again or Unbind")
    if faces_hash != info["cage_faces_hash"]:
        return (f"The faces of cage '{cage.name}' changed since Bind: the deformation no "
                "longer matches it; Bind again or Unbind")
    if not finite:
        return (f"The cage '{cage.name}' has undefined (NaN or infinite) positions: the "
                "mesh is not deformed until they are fixed")
    return None


def status_lines(obj, depsgraph=None):
    """Lines describing the bindings of ``obj``, for the panel and scripts."""
    found_all = binding.bindings(obj)
    if not found_all:
        return [("Not bound", 'UNLINKED')]
    lines = []
    for found in found_all:
        lines.extend(binding_lines(obj, found, depsgraph))
    picked = obj.gencoords.cage
    if picked is not None and all(found.cage != picked for found in found_all):
        lines.append((f"Cage is now '{picked.name}': Bind adds a binding to it", 'INFO'))
    return lines


def binding_lines(obj, found, depsgraph=None):
    """Lines describing one binding of ``obj``."""
    lines = []
    problem = deformation_problem(obj, found, depsgraph)
    if problem:
        lines.append((problem, 'ERROR'))
    info = found.info
    if info.get("format") != FORMAT:
        return lines
    cage = found.cage
    if cage is not None:
        bound_to = f"Bound to '{cage.name}'"
    elif found.deleted_cage is not None:
        bound_to = f"Was bound to '{found.deleted_cage}' (deleted)"
    else:
        bound_to = "Bound to a missing cage"
    lines.append((f"{bound_to} (modifier '{found.modifier.name}')", 'LINKED'))
    kind_name = kind_label(info['kind'])
    if "gamma" in info:
        kind_name += f" (gamma {info['gamma']:g})"
    lines.append((f"Coordinates: {kind_name}", 'MOD_LATTICE'))
    lines.append((f"Cage: {info['cage_vertex_count']} vertices", 'MESH_ICOSPHERE'))
    lines.append((f"Mesh: {info['mesh_vertex_count']} vertices", 'MESH_DATA'))
    if info["cage_non_triangles"]:
        lines.append((f"Cage triangulated: {info['cage_non_triangles']} quads/n-gons",
                      'MOD_TRIANGULATE'))
    storage = enum_label(STORAGE_ITEMS, info["storage"])
    lines.append((f"Storage: {storage}, {info['slot_count']} per vertex, "
                  f"{info['nbytes'] / 2**20:.1f} MB", 'DISK_DRIVE'))
    if "storage_choice" in info:  # what Automatic chose and why
        lines.append((info["storage_choice"], 'INFO'))
    if info["storage"] == 'COMPACT':  # measured on every vertex, as written
        worst = info.get("deviation_drag_vertex")  # absent from earlier versions' binds
        drag = "vertex drag" if worst is None else f"drag of cage vertex {worst}"
        lines.append((f"Deviation: {info['deviation_smooth']:.1e} (smooth), "
                      f"{info['deviation_drag']:.1e} ({drag}) of the cage diagonal", 'INFO'))
    lines.append((f"Bind time: {info['bind_seconds']:.2f} s", 'TIME'))
    if info["negative_points"]:
        lines.extend(messages.negative_weights(info, kind_label(info["kind"])))
    else:
        lines.append((f"Smallest coordinate: {info['min_coordinate']:.4g}", 'CHECKMARK'))
    if "report" in info:  # inside the whole cage, not only at the mesh's vertices
        lines.append((f"In this cage: {info['report'].split(': ', 1)[-1]}", 'INFO'))
    if info["points_outside"]:
        verb = OUTSIDE_VERBS.get(info["outside"], info["outside"])
        lines.append((f"{info['points_outside']} vertices outside the cage ({verb})", 'INFO'))
    if info["points_on_boundary"]:
        lines.append((f"{info['points_on_boundary']} vertices on the cage boundary", 'INFO'))
    return lines
