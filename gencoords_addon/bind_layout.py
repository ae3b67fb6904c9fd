"""The bind data's layout in a .blend file: its format number, the names of its mesh
attributes and its metadata's keys. Files bound by this layout's number open and deform;
data of another number reads as "Bind again".

A binding is a Geometry Nodes modifier whose node group carries the ID property
``METADATA`` (a dict: the fields of ``BindData``, the figures measured at Bind among
them), and vector
point attributes on the mesh holding its slots three to an attribute
(``slot_attribute_names``), plus, for compact storage, its basis of cage motions on the
mesh's first n points (``basis_attribute_names``; n + m rows for Green coordinates, whose
slots are ``[phi, psi]``). Green bindings made before their node group kept the cage's
triangles also have those (three vertex indices) on the mesh's first m points
(``triangle_attribute_name``): their groups read them there. Sparse storage keeps instead
per vertex K INT and K FLOAT attributes (its pairs), and in two levels the grid nodes'
pairs three to a vector attribute (``storage.sparse``, ``storage.two_level``:
``BindData.attribute_names``). Each storage's module (``gencoords_addon.storage``) writes
and reads the attributes named here; the names stay here, beside the format number, as
the file's layout (a leaf: anything reads them).

Format 3 added sparse storage and harmonic coordinates; format 2 bindings are the same
bind data without them and read as format 3 (``BindData.from_properties``).
"""

from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Mapping, Optional

from ..core.storage import Storage

FORMAT = 3  # bind data layout; data of another number read as "Bind again"
READABLE_FORMATS = (2,)  # earlier layouts read as this one (they are a part of it)
METADATA = "gencoords"  # ID property of the binding's node group
BAKE_INFO = "gencoords_bake"  # ID property of a baked rig's armature: the bake's figures
ATTRIBUTE_PREFIX = ".gencoords_"  # a leading dot keeps them out of the attribute lists
# Slot attributes an Unbind in progress has taken away (hidden: the leading dot).
PARKED_PREFIX = ".unbinding"
STORAGES = (Storage.EXACT, Storage.COMPACT, Storage.SPARSE)  # the storages a binding is written in


@dataclass(frozen=True)
class BindData:
    """A binding's ``METADATA``: what Bind chose and measured, one field per stored key
    (the key is the field's name). Read with :meth:`from_properties`, written with
    :meth:`to_properties`; a field that a binding lacks (one of another ``format``, or an
    earlier version's bind without a later figure) reads as None.
    """

    format: Optional[int] = None  # bind data layout (``is_current``: this extension's)
    key: Optional[str] = None  # unique per binding: names its attributes
    kind: Optional[str] = None  # the core's name of the coordinates, e.g. 'mean_value'
    gamma: Optional[float] = None  # the kind's parameter, for the kinds that have one
    outside: Optional[str] = None  # the core's name, e.g. 'raise'
    storage: Optional[str] = None  # one of STORAGES (as its value: equal to it)
    slot_count: Optional[int] = None  # numbers stored per mesh vertex
    cage_vertex_count: Optional[int] = None  # n
    mesh_vertex_count: Optional[int] = None  # k
    cage_face_count: Optional[int] = None  # Green coordinates: the cage's triangles, m
    cage_faces_hash: Optional[str] = None  # mesh_io.faces_hash of the cage at Bind
    cage_non_triangles: Optional[int] = None  # quads and n-gons Bind triangulated
    cage_name: Optional[str] = None  # the cage's name, kept up to date while it exists
    deleted_cage: Optional[str] = None  # the name of the cage, once it is gone
    # Figures measured at Bind, on what was written (core.reports.coordinate_summary,
    # core.storage.compact's deviations, the core's point locations).
    storage_choice: Optional[str] = None  # why this storage, in the panel's words
    report: Optional[str] = None  # core.reports.coordinate_report's headline
    min_coordinate: Optional[float] = None
    negative_points: Optional[int] = None
    max_affine_error: Optional[float] = None
    linear_precision: Optional[float] = None  # how far the stored coordinates place the mesh
    deviation_smooth: Optional[float] = None  # of the cage's diagonal
    deviation_drag: Optional[float] = None
    deviation_drag_vertex: Optional[int] = None  # the cage vertex whose drag deviates most
    points_outside: Optional[int] = None
    points_on_boundary: Optional[int] = None
    nbytes: Optional[int] = None  # bytes of the bind data's attributes
    bind_seconds: Optional[float] = None
    negative_entries: Optional[int] = None  # coordinates below 0, of k x n
    resolution: Optional[int] = None  # harmonic coordinates: grid cells along the longest side
    node_count: Optional[int] = None  # sparse storage in two levels: grid nodes N (else 0)
    node_slot_count: Optional[int] = None  # ... and pairs per node K'
    similarity_deviation: Optional[float] = None  # the mesh as written under a similarity of the cage
    # Stored keys this version does not know (a later version's), kept as they are.
    unknown: Mapping = field(default_factory=lambda: MappingProxyType({}), compare=False, repr=False)

    @property
    def is_current(self):
        """Whether the bind data is this extension's format (else: Bind again)."""
        return self.format == FORMAT

    @property
    def rows(self):
        """Coordinates per mesh vertex: n, or n + m for Green coordinates ([phi, psi])."""
        return self.cage_vertex_count + (self.cage_face_count or 0)

    @property
    def slot_names(self):
        return slot_attribute_names(self.key, self.slot_count)

    @property
    def attribute_names(self):
        """The attributes the binding's group reads from the mesh (Green bindings made
        before their group kept the cage's triangles have those too)."""
        if self.storage == Storage.SPARSE:
            return sparse_attribute_names(self.key, self.slot_count, self.mesh_vertex_count,
                                          self.node_count or 0, self.node_slot_count or 0)
        return self.slot_names + (self.basis_names or [])

    @property
    def basis_names(self):
        """Compact storage's basis attributes; None for exact storage."""
        return basis_attribute_names(self.key, self.slot_count) if self.storage == Storage.COMPACT else None

    @property
    def triangle_name(self):
        """Green coordinates' triangle attribute; None for the other kinds."""
        return None if self.cage_face_count is None else triangle_attribute_name(self.key)

    def to_properties(self):
        """The ID property dict stored as ``METADATA`` (ID properties hold no None: a
        field that is None is not stored)."""
        stored = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "unknown"}
        return {**self.unknown, **{name: value for name, value in stored.items() if value is not None}}

    @classmethod
    def from_properties(cls, properties):
        """The record of a stored ``METADATA`` (a dict of plain values, as
        ``IDPropertyGroup.to_dict()`` gives it), in this version's terms.

        Format 2 binds of earlier versions lack later figures (``deviation_drag_vertex``):
        those read as None. Data of another format number are read field by field as far
        as they go and are not current (``is_current``: the panel says "Bind again"); a
        later format that can be read from an earlier one converts it here, before the
        fields are read.
        """
        names = {f.name for f in fields(cls)} - {"unknown"}
        if properties.get("format") in READABLE_FORMATS:
            properties = dict(properties, format=FORMAT)
        known = {name: value for name, value in properties.items() if name in names}
        unknown = {name: value for name, value in properties.items() if name not in names}
        return cls(**known, unknown=MappingProxyType(unknown))


def attribute_prefix(key):
    """Prefix of the slot attributes of the binding ``key`` (unique per binding)."""
    return f"{ATTRIBUTE_PREFIX}{key}_"


def slot_attribute_names(key, slot_count):
    """Names of the vector attributes holding three slots each, in slot order."""
    return [f"{attribute_prefix(key)}{t}" for t in range(-(-slot_count // 3))]


def basis_attribute_names(key, slot_count):
    """Names of the vector attributes holding compact storage's basis, three columns each."""
    return [f"{attribute_prefix(key)}basis{t}" for t in range(-(-slot_count // 3))]


def triangle_attribute_name(key):
    """Name of the vector attribute holding a Green binding's cage triangles."""
    return f"{attribute_prefix(key)}triangles"


# Sparse storage (storage/sparse.py, storage/two_level.py): per vertex K index and K weight attributes, in two
# levels the grid nodes' pairs three to a vector, stacked.
NODE_DISPLACEMENT_SUFFIX = "node_displacement"
SLOT_MARK = "#"  # stands for the slot number in a name template


def name_template(key, level, what):
    """An attribute name with ``SLOT_MARK`` where the slot number goes (the deformer's
    Repeat Zone fills it in)."""
    return f"{attribute_prefix(key)}{level}_{what}{SLOT_MARK}"


def index_attribute_names(key, slot_count, level="vertex"):
    """Names of the K INT attributes holding each point's gathered indices: ``level``
    'vertex' for the mesh vertices' slots, 'node' for the grid nodes' (two-level)."""
    template = name_template(key, level, "index")
    return [template.replace(SLOT_MARK, str(k)) for k in range(slot_count)]


def weight_attribute_names(key, slot_count, level="vertex"):
    """Names of the K FLOAT attributes holding the weights matching
    ``index_attribute_names``."""
    template = name_template(key, level, "weight")
    return [template.replace(SLOT_MARK, str(k)) for k in range(slot_count)]


def node_displacement_name(key):
    """The attribute the two-level group stores its grid nodes' displacements in (on the
    mesh's first N points, inside the group only: stripped from the output)."""
    return attribute_prefix(key) + NODE_DISPLACEMENT_SUFFIX


def node_column_count(mesh_vertex_count, node_count, node_slot_count):
    """Stacked vector columns the grid nodes' pairs take, three to a vector
    (``core.storage.sparse.stacked_columns``)."""
    if not node_count:
        return 0
    triples, per_column = -(-node_slot_count // 3), mesh_vertex_count // node_count
    return -(-triples // per_column)


def sparse_attribute_names(key, slot_count, mesh_vertex_count, node_count=0, node_slot_count=0):
    """Every attribute a sparse binding keeps on the mesh."""
    columns = node_column_count(mesh_vertex_count, node_count, node_slot_count)
    return (index_attribute_names(key, slot_count) + weight_attribute_names(key, slot_count)
            + index_attribute_names(key, columns, "node") + weight_attribute_names(key, columns, "node"))
