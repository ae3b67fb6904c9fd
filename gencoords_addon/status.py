"""The panel's status block as (text, icon) lines; every figure comes from the bind data,
which holds what the core computed."""

from . import live, storage
from .properties import KIND_ITEMS, enum_label

OUTSIDE_VERBS = {"project": "projected onto the cage", "extrapolate": "extrapolated"}


def status_lines(obj):
    """Lines describing the bind of ``obj`` and any live fault, for the panel and scripts."""
    lines = []
    fault = live.faults.get(obj.session_uid)
    if fault:
        lines.append((fault, 'ERROR'))
    bind = storage.load(obj)
    if bind is None:
        lines.append(("Not bound", 'UNLINKED'))
        return lines
    cage = obj.gencoords.bound_cage
    kind_label = enum_label(KIND_ITEMS, bind.kind.upper())
    cage_name = cage.name if cage is not None else "(missing)"
    lines.append((f"Bound to '{cage_name}' ({kind_label})", 'LINKED'))
    picked = obj.gencoords.cage
    if cage is not None and picked != cage:
        lines.append((f"Cage is now '{picked.name if picked else 'none'}': Bind again to use it "
                      f"(following '{cage_name}' until then)", 'INFO'))
    lines.append((f"Cage {bind.cage_vertex_count} vertices, mesh {bind.mesh_vertex_count} "
                  "vertices", 'MESH_DATA'))
    if bind.cage_non_triangles:
        lines.append((f"Cage triangulated ({bind.cage_non_triangles} quads/n-gons)",
                      'MOD_TRIANGULATE'))
    lines.append((f"Bind time {bind.bind_seconds:.2f} s, data {_megabytes(bind.nbytes)}", 'TIME'))
    if bind.negative_points:
        lines.append((f"Smallest coordinate {bind.min_coordinate:.4g}: negative at "
                      f"{bind.negative_points} vertices", 'ERROR'))
    else:
        lines.append((f"Smallest coordinate {bind.min_coordinate:.4g}", 'CHECKMARK'))
    if bind.points_outside:
        verb = OUTSIDE_VERBS.get(bind.outside, bind.outside)
        lines.append((f"{bind.points_outside} vertices outside the cage ({verb})", 'INFO'))
    if bind.points_on_boundary:
        lines.append((f"{bind.points_on_boundary} vertices on the cage boundary", 'INFO'))
    if not obj.gencoords.live:
        lines.append(("Live off: showing the rest shape", 'PAUSE'))
    return lines


def _megabytes(nbytes):
    return f"{nbytes / 2**20:.2f} MB"
