"""The settings' enum items and their labels: a leaf module (it imports nothing of the
add-on), so the settings, the binding code and the panel all read the same tables.

Kind identifiers are the core's names in upper case (``core_name``); the core's table of
kinds (``core.KIND_TABLE``) is the one list of them, with Green coordinates after it.
"""

from .. import core
from ..core.construction.green import GREEN, GREEN_DESCRIPTION, GREEN_LABEL
from ..core.construction.quad_cage import MEAN_VALUE_QUADS
from ..core.storage import Storage
from ..core.surfaces.named import HARMONIC

HARMONIC_LABEL = "Harmonic"  # short: the Properties editor's default width shows it whole
HARMONIC_DESCRIPTION = ("Local, positive: never negative in any closed cage, and, as Mesh Deform, moving one "
                        "limb's cage moves that limb alone. Solved on a grid (Resolution); stored "
                        "sparse by default. Quads are taken whole, as curved patches")
MEAN_VALUE_QUADS_LABEL = "Quad Mean Value"
MEAN_VALUE_QUADS_DESCRIPTION = ("For quad cages: mean value with each quad as its own curved patch, not split in "
                                "two, so a bent quad moves the mesh the same whichever corner it starts from. "
                                "Quads and triangles; larger faces are split")
# The paper's kinds, then Green coordinates (not a generating surface: the core keeps
# them out of its table, and the deformer adds the cage's face terms for them) and
# harmonic coordinates (solved on a grid: gencoords.harmonic_field), then mean value on quads
# (gencoords.mean_value_quad_coordinates: the cage's faces, not its triangles). Last: a
# saved file stores a kind by its position.
KIND_ITEMS = tuple((kind.name.upper(), kind.label, kind.description) for kind in core.KIND_TABLE) + (
    (GREEN.upper(), GREEN_LABEL, GREEN_DESCRIPTION), (HARMONIC.upper(), HARMONIC_LABEL, HARMONIC_DESCRIPTION),
    (MEAN_VALUE_QUADS.upper(), MEAN_VALUE_QUADS_LABEL, MEAN_VALUE_QUADS_DESCRIPTION))
DEFAULT_KIND = "MEAN_VALUE"
OUTSIDE_ITEMS = (
    ("RAISE", "Report Error", "Refuse to bind when mesh vertices lie outside the cage"),
    ("PROJECT", "Project",
     "Vertices outside the cage take the coordinates of the nearest point on its surface"),
    ("EXTRAPOLATE", "Extrapolate",
     "Evaluate the coordinate formula outside the cage too (may be unstable far away)"),
)
STORAGE_ITEMS = (
    (Storage.AUTO.value, "Automatic",
     "Exact while its cost is moderate (mesh vertices x cage vertices up to 8 million, "
     "cages up to 400 vertices); beyond, Sparse or else Compact with the fewest pairs or "
     "slots that keep the deviation under 1e-3 of the cage diagonal, measured at Bind, else "
     "Exact. Harmonic: Sparse in two levels"),
    (Storage.EXACT.value, "Exact",
     "Every coordinate of every vertex: the deformation is exact to float32 rounding"),
    (Storage.COMPACT.value, "Compact",
     "A few numbers per vertex: exact for affine and smooth cage motions, close for "
     "others (the panel shows the deviation); for dense meshes and large cages"),
    (Storage.SPARSE.value, "Sparse",
     "Each vertex's largest coordinates as (cage vertex, weight) pairs summing to 1: "
     "translations exact, fast for local coordinates (Harmonic: pairs per grid node, each "
     "vertex interpolated from 8 grid nodes); the panel shows the deviation"),
)


def core_name(identifier):
    """The core's string for an enum identifier: 'MEAN_VALUE' -> 'mean_value'."""
    return identifier.lower()


def enum_label(items, identifier):
    """The user-facing name of ``identifier`` in an ``*_ITEMS`` table."""
    return next(name for key, name, _ in items if key == identifier)


def kind_label(name):
    """The user-facing name of a kind given by its core name ('mean_value') or its enum
    identifier ('MEAN_VALUE')."""
    return enum_label(KIND_ITEMS, name.upper())


def kind_parameter(identifier):
    """The name of the kind's parameter ('gamma' for the power family), or None."""
    if is_green(identifier) or is_harmonic(identifier) or reads_quads(identifier):
        return None
    return core.KIND_TABLE[core.advanced.KINDS.index(core_name(identifier))].parameter


def is_green(identifier):
    """Whether a kind (enum identifier or core name) is Green coordinates."""
    return core_name(identifier) == GREEN


def is_harmonic(identifier):
    """Whether a kind (enum identifier or core name) is harmonic coordinates."""
    return core_name(identifier) == HARMONIC


def reads_quads(identifier):
    """Whether a kind (enum identifier or core name) reads the cage's quads, unsplit: Quad
    Mean Value, and Harmonic (each quad's boundary values its bilinear patch's)."""
    return core_name(identifier) in (MEAN_VALUE_QUADS, HARMONIC)
