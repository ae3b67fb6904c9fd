"""The bind data's layout in a .blend file: its format number, the names of its mesh
attributes and its metadata's keys. Files bound by this layout's number open and deform;
data of another number reads as "Bind again".

A binding is a Geometry Nodes modifier whose node group carries the ID property
``METADATA`` (a dict: ``METADATA_KEYS`` and the figures measured at Bind), and vector
point attributes on the mesh holding its slots three to an attribute
(``slot_attribute_names``), plus, for compact storage, its basis of cage motions on the
mesh's first n points (``basis_attribute_names``; n + m rows for Green coordinates, whose
slots are ``[phi, psi]``), and for Green coordinates the cage's triangles (three vertex
indices) on the mesh's first m points (``triangle_attribute_name``).
"""

FORMAT = 2  # bind data layout; data of another number read as "Bind again"
METADATA = "gencoords"  # ID property of the binding's node group
ATTRIBUTE_PREFIX = ".gencoords_"  # a leading dot keeps them out of the attribute lists
# Slot attributes an Unbind in progress has taken away (hidden: the leading dot).
PARKED_PREFIX = ".unbinding"

# METADATA keys every binding has (Bind adds its measured figures beside them).
FORMAT_KEY = "format"
KEY = "key"  # unique per binding: names its attributes
KIND = "kind"  # the core's name of the coordinates, e.g. 'mean_value'
GAMMA = "gamma"  # the kind's parameter, for the kinds that have one
OUTSIDE = "outside"
STORAGE = "storage"  # 'EXACT' or 'COMPACT'
SLOT_COUNT = "slot_count"
CAGE_VERTEX_COUNT = "cage_vertex_count"
MESH_VERTEX_COUNT = "mesh_vertex_count"
CAGE_FACE_COUNT = "cage_face_count"  # Green coordinates: the cage's triangles, m
CAGE_NAME = "cage_name"  # the cage's name, kept up to date while it exists
DELETED_CAGE = "deleted_cage"  # the name of the cage, once it is gone
METADATA_KEYS = (FORMAT_KEY, KEY, KIND, OUTSIDE, STORAGE, SLOT_COUNT, CAGE_VERTEX_COUNT,
                 MESH_VERTEX_COUNT, CAGE_NAME)


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
