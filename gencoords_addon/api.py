"""What Bind found, for scripts: ``binding_result(obj)``, read-only.

Reached as ``bl_ext.user_default.gencoords.binding_result`` (the extension's package
re-exports it). Nothing is computed here: every figure is the one Bind measured and
stored with the binding (the metadata of its node group, ``bind_layout.METADATA``), the same
the panel shows (``status.py``), so a script and an artist read the same numbers.
"""

from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Mapping

from . import bind_layout as _layout
from .bind import bindings as _bindings

# Stored as the core's names ('mean_value'); given as the ``obj.gencoords`` enum
# identifiers ('MEAN_VALUE') a script sets.
_ENUM_FIELDS = ("kind", "outside")


@dataclass(frozen=True)
class BindingResult:
    """One binding of a mesh object, as Bind measured and stored it (immutable).

    ``modifier`` and ``cage`` are names; every other attribute but ``metadata`` is the
    stored field of the same name, None where a binding of another ``format`` (see
    ``is_current``) lacks it. ``metadata`` holds every stored field as stored, fields
    added by later versions included.
    """

    modifier: str  # the binding's Geometry Nodes modifier on the object
    cage: str | None  # the cage object it follows; None once the cage was deleted
    format: int  # bind data layout (``is_current``: this extension's)
    kind: str  # 'MEAN_VALUE', 'WACHSPRESS', 'DISCRETE_HARMONIC', 'VORONOI', 'POWER', 'GREEN', 'HARMONIC'
    gamma: float | None  # the power family's exponent; None for the other kinds
    outside: str  # 'RAISE', 'PROJECT', 'EXTRAPOLATE'
    storage: str  # the storage chosen: 'EXACT', 'COMPACT' or 'SPARSE' (Automatic decided)
    # Numbers stored per mesh vertex (exact: the cage's vertex count; sparse: pairs, in two
    # levels the 8 grid nodes each vertex is interpolated from).
    slot_count: int
    cage_vertex_count: int
    mesh_vertex_count: int
    min_coordinate: float  # smallest coordinate of any mesh vertex
    negative_points: int  # mesh vertices with a negative coordinate
    max_affine_error: float  # largest |sum of a vertex's coordinates - 1|, as stored (float32)
    # Compact and sparse storage's deviation from exact, of the cage size, for a standard
    # smooth cage motion and for one dragged cage vertex (float32 rounding for exact).
    deviation_smooth: float
    deviation_drag: float
    points_outside: int  # mesh vertices outside the cage (projected or extrapolated)
    points_on_boundary: int
    report: str | None  # core.reports.coordinate_report's headline for this kind in this cage
    nbytes: int  # bytes of bind data stored on the mesh
    bind_seconds: float
    negative_entries: int | None = None  # coordinates below 0 (of mesh x cage vertices)
    resolution: int | None = None  # harmonic coordinates' grid: cells along the longest side
    node_count: int | None = None  # sparse storage in two levels: grid nodes (else 0)
    node_slot_count: int | None = None  # ... and pairs per grid node
    # How far the mesh as written follows a turned, scaled and moved cage, of its size
    # (None for Green, similarity invariant, and for binds before it was measured).
    similarity_deviation: float | None = None
    metadata: Mapping = field(default_factory=dict, compare=False, repr=False)

    @property
    def is_current(self):
        """Whether the bind data is this extension's format (else: Bind again)."""
        return self.format == _layout.FORMAT


# The BindData fields a script reads here (the rest: ``metadata``).
_STORED_FIELDS = tuple(f.name for f in fields(BindingResult)
                       if f.name not in ("modifier", "cage", "metadata"))


def _frozen(value):
    """``value`` with its lists and dicts made immutable (ID properties come as both)."""
    if isinstance(value, dict):
        return MappingProxyType({key: _frozen(item) for key, item in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(item) for item in value)
    return value


def _result(found):
    data = found.data
    stored = {name: getattr(data, name) for name in _STORED_FIELDS}
    for name in _ENUM_FIELDS:
        if isinstance(stored[name], str):
            stored[name] = stored[name].upper()
    cage = found.cage
    return BindingResult(modifier=found.modifier.name, cage=cage.name if cage is not None else None,
                         metadata=_frozen(data.to_properties()), **stored)


def binding_results(obj):
    """Every binding of ``obj`` in modifier stack order: a tuple of ``BindingResult``,
    empty when ``obj`` is not bound (or is not a mesh object)."""
    return tuple(_result(found) for found in _bindings.bindings(obj))


def binding_result(obj, cage=None):
    """The binding of ``obj`` to the object ``cage`` (by default its first binding) as a
    ``BindingResult``, or None when there is none."""
    found = _bindings.binding(obj, cage)
    return None if found is None else _result(found)
