"""The core's errors phrased in Blender's terms, with the way out."""

from ..core import CageError, OutsideCageError
from ..core.surfaces.named import MEAN_VALUE
from .enums import HARMONIC_LABEL

RECALCULATE_NORMALS = "in Edit Mode use Mesh > Normals > Recalculate Outside"
SELECT_DENTED = "Select > Select Dented Faces"
CAGE_PROBLEMS = {
    "non_finite": "has vertices at infinite or undefined (NaN) positions",
    "too_few_vertices": "needs at least 4 vertices enclosing a volume",
    "bad_faces": "has faces with invalid vertex indices",
    "loose_vertices": "has vertices that belong to no face: use Mesh > Clean Up > Delete Loose",
    "flat": "is flat (all its vertices lie in one plane) and encloses no volume: give it "
            "depth, e.g. Extrude the faces or use Mesh > Convex Hull on a solid",
    "duplicate_vertices": "has vertices at the same position: use Mesh > Clean Up > "
                          "Merge by Distance",
    "degenerate_facet": "has faces of zero area: use Mesh > Clean Up > Degenerate Dissolve",
    "open": "is not closed (it has holes): fill them so the cage encloses a volume",
    "non_manifold": "is non-manifold (edges not shared by exactly two faces): see Select > "
                    "Select All by Trait > Non Manifold",
    "inconsistent_orientation": "has faces pointing different ways: " + RECALCULATE_NORMALS,
    "inward": "is inside out (normals point inward): " + RECALCULATE_NORMALS,
    "folded_quad": "has a quad folded over itself (a bow-tie, or a corner pushed across the opposite "
                   "diagonal): move the corner back, or split that quad (Face > Triangulate Faces)",
    "non_convex": "is not convex, which {kind} coordinates need: choose Mean Value or "
                  f"{HARMONIC_LABEL} (they work on any closed cage) or make the cage convex",
}


def cage_error(cage_name, error, kind_label, triangle_faces, dented=None):
    """Message for a ``core.CageError`` raised on the cage called ``cage_name``.

    The core numbers triangles; ``triangle_faces`` maps them to the cage's own faces,
    which the artist can select. ``dented``: for a non-convex cage, its faces that dent
    inward (``core.advanced.concave_facets``, as cage faces).
    """
    problem = CAGE_PROBLEMS.get(error.problem, str(error)).format(kind=kind_label)
    where = ""
    if dented is not None and len(dented):
        where = (f" ({len(dented)} faces dent inward: {_first_indices([int(f) for f in dented])}; "
                 f"with the cage in Edit Mode, {SELECT_DENTED} selects them)")
    elif error.faces:
        faces = list(dict.fromkeys(int(triangle_faces[t]) for t in error.faces))
        where = f" (faces {_first_indices(faces)})"
    elif error.vertices:
        where = f" (vertices {_first_indices(error.vertices)})"
    return f"Cage '{cage_name}' {problem}{where}"


def no_extrapolation(kind_label):
    """Refusal of Outside: Extrapolate for a kind that has no formula outside the cage."""
    return (f"{kind_label} coordinates do not extrapolate outside the cage: set Outside to Report Error or "
            "Project, then Bind")


def outside_error(cage_name, outside_count, total):
    """Message for mesh vertices outside the cage when Outside is Report Error."""
    return (f"{outside_count} of {total} mesh vertices lie outside the cage '{cage_name}': "
            "enlarge the cage, or set Outside to Project or Extrapolate")


def core_error(cage_name, error, kind_label, total, triangle_faces, dented=None):
    """Message for any error the core raised while binding (``triangle_faces``, ``dented``:
    see ``cage_error``)."""
    if isinstance(error, CageError):
        return cage_error(cage_name, error, kind_label, triangle_faces, dented)
    if isinstance(error, OutsideCageError):
        return outside_error(cage_name, len(error.indices), total)
    return f"Cannot bind to cage '{cage_name}': {error}"


def _first_indices(indices, shown=5):
    text = ", ".join(str(i) for i in indices[:shown])
    return text + ", ..." if len(indices) > shown else text


def worker_fallback():
    """What to say when worker processes failed (their error goes to the system console)
    and Blender computed instead."""
    return ("worker processes failed, so GenCoords computed in Blender instead (the same "
            "result, slower; the cause is in the system console). If this repeats, set "
            "Preferences > Add-ons > GenCoords > Worker Processes to '1: Compute in Blender'")


def follows_twice(mesh, cage, modifier, rig):
    """What to say when a bound mesh also follows its cage through an armature whose
    bones follow the cage's vertices (a rig baked from it)."""
    return (f"'{mesh}' also follows '{cage}' through the armature '{rig}' baked from it "
            f"(modifier '{modifier}'), so it now moves twice: remove that modifier, or Unbind")


def gamma_words(gamma):
    """`` (gamma -8)`` for messages about a kind with that parameter; empty for None."""
    return "" if gamma is None else f" (gamma {gamma:g})"


def zero_scale(what, name, axes, then, effect=None):
    """Message for an object (``what``: "cage", "mesh") scaled to zero on ``axes`` (none
    named where only a parent's axis turned against the object's is) and what that does,
    ``effect``, if anything."""
    plural = "axes" if len(axes) > 1 else "axis"
    where = f" on its {' and '.join(axes)} {plural}" if axes else ""  # none: a parent's turned axis
    effect = ": " if effect is None else f": {effect}; "
    return (f"The {what} object '{name}' is scaled to zero{where} (or its parent is){effect}give it a "
            f"non-zero Scale (Object Properties > Transform), then {then}")


# What keeps weights positive, for the panel's note on negative ones.
POSITIVE_WEIGHTS = (f"Type {HARMONIC_LABEL} (local, positive) keeps weights positive and each part of the mesh to its own "
                    "part of the cage, in any closed cage; so does a convex cage (Make Cage)")


def percent(share):
    """A share in percent as the panel writes it: three significant digits, never an
    exponent down to 1e-4 (``100``, ``2.5``, ``0.0312``; ``< 0.0001`` below)."""
    return f"{share:.3g}" if share >= 1e-4 or share == 0.0 else "< 0.0001"


def negative_weights(data, kind_label):
    """Panel lines (text, icon) explaining a binding's negative coordinates, from its
    ``BindData``: how many (vertices, and of all its coordinates), why, what keeps them
    positive."""
    share = 100.0 * data.negative_points / max(data.mesh_vertex_count, 1)
    if data.points_outside and data.outside == "extrapolate":
        why = "Vertices outside the cage are extrapolated"
    elif data.kind == MEAN_VALUE:
        why = "The cage is not convex"
    else:
        why = f"{kind_label} coordinates can be negative in this cage"
    # Earlier binds lack the count of negative coordinates.
    entries = "" if data.negative_entries is None else (
        f", {percent(100.0 * data.negative_entries / max(data.mesh_vertex_count * data.cage_vertex_count, 1))} % "
        "of all coordinates")
    return [(f"{percent(share)} % of vertices have negative weights{entries} (smallest {data.min_coordinate:.3g})",
             'INFO'),
            (f"{why}: parts of the mesh may move against the cage", 'BLANK1'),
            (POSITIVE_WEIGHTS, 'BLANK1')]
