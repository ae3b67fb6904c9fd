"""The panel's status block as (text, icon) lines, with why a bound mesh is not deforming
(``bind.bindings.deformation_problem``).

Every figure comes from the binding's metadata, which holds what the core computed.
"""


from ...core.storage import Storage
from .. import messages
from ..bind import bindings
from ..bind.bindings import deformation_problem
from ..enums import STORAGE_ITEMS, enum_label, kind_label

OUTSIDE_VERBS = {"project": "projected onto the cage", "extrapolate": "extrapolated"}


def status_lines(obj, depsgraph=None):
    """Lines describing the bindings of ``obj``, for the panel and scripts."""
    found_all = bindings.bindings(obj)
    if not found_all:
        return [("Not bound", 'UNLINKED')]
    lines = []
    for found in found_all:
        lines.extend(binding_lines(obj, found, depsgraph))
    picked = obj.gencoords.cage
    if picked is not None and all(found.cage != picked for found in found_all):
        lines.append((f"Cage is now '{picked.name}': Bind adds a binding to it", 'INFO'))
    return lines


def _storage_words(data):
    """``Exact, 196 per vertex`` / ``Sparse, 16 pairs per vertex`` / the two levels."""
    storage = enum_label(STORAGE_ITEMS, data.storage)
    if data.storage != Storage.SPARSE:
        return f"{storage}, {data.slot_count} per vertex"
    if not data.node_count:
        return f"{storage}, {data.slot_count} pairs per vertex"
    # The nodes stored: the grid nodes the mesh's cells use (of those solved, which the
    # "In this cage" line counts) and vertices at the cage, each a node of its own.
    return (f"{storage} in two levels, {data.slot_count} nodes a vertex; {data.node_count} nodes stored, "
            f"{data.node_slot_count} pairs each")


def binding_lines(obj, found, depsgraph=None):
    """Lines describing one binding of ``obj``."""
    lines = []
    problem = deformation_problem(obj, found, depsgraph)
    if problem:
        lines.append((problem, 'ERROR'))
    data = found.data
    if not data.is_current:
        return lines
    cage = found.cage
    if cage is not None:
        bound_to = f"Bound to '{cage.name}'"
    elif found.deleted_cage is not None:
        bound_to = f"Was bound to '{found.deleted_cage}' (deleted)"
    else:
        bound_to = "Bound to a missing cage"
    lines.append((f"{bound_to} (modifier '{found.modifier.name}')", 'LINKED'))
    kind_name = kind_label(data.kind)
    if data.gamma is not None:
        kind_name += f" (gamma {data.gamma:g})"
    if data.resolution is not None:
        kind_name += f", resolution {data.resolution}"
    lines.append((f"Coordinates: {kind_name}", 'MOD_LATTICE'))
    lines.append((f"Cage: {data.cage_vertex_count} vertices", 'MESH_ICOSPHERE'))
    lines.append((f"Mesh: {data.mesh_vertex_count} vertices", 'MESH_DATA'))
    if data.cage_non_triangles:
        lines.append((f"Cage triangulated: {data.cage_non_triangles} quads/n-gons",
                      'MOD_TRIANGULATE'))
    lines.append((f"Storage: {_storage_words(data)}, {data.nbytes / 2**20:.1f} MB", 'DISK_DRIVE'))
    if data.storage_choice is not None:  # what Automatic chose and why
        lines.append((data.storage_choice, 'INFO'))
    if data.storage in (Storage.COMPACT, Storage.SPARSE):  # measured on every vertex, as written
        worst = data.deviation_drag_vertex  # absent from earlier versions' binds
        drag = "vertex drag" if worst is None else f"drag of cage vertex {worst}"
        lines.append((f"Deviation: {data.deviation_smooth:.1e} (smooth), "
                      f"{data.deviation_drag:.1e} ({drag}) of the cage diagonal", 'INFO'))
    if data.similarity_deviation is not None:  # measured on what was written
        lines.append((f"Similarity: the mesh follows a turned, scaled cage to {data.similarity_deviation:.1e} "
                      "of its size", 'INFO'))
    lines.append((f"Bind time: {data.bind_seconds:.2f} s", 'TIME'))
    if data.negative_points:
        lines.extend(messages.negative_weights(data, kind_label(data.kind)))
    else:
        lines.append((f"Smallest coordinate: {data.min_coordinate:.4g}", 'CHECKMARK'))
    if data.report is not None:  # inside the whole cage, not only at the mesh's vertices
        lines.append((f"In this cage: {data.report.split(': ', 1)[-1]}", 'INFO'))
    if data.points_outside:
        verb = OUTSIDE_VERBS.get(data.outside, data.outside)
        lines.append((f"{data.points_outside} vertices outside the cage ({verb})", 'INFO'))
    if data.points_on_boundary:
        lines.append((f"{data.points_on_boundary} vertices on the cage boundary", 'INFO'))
    return lines
