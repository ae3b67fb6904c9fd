"""Bind data: where the coordinates, rest shape and cage fingerprint live.

The arrays can be tens of megabytes, and ID properties on an object or mesh would be
copied on every depsgraph evaluation. They are therefore kept as ID properties of a
hidden Text datablock (Texts are not part of the depsgraph) that the bound object points
to through ``obj.gencoords.bind_data``. The datablock is written once per bind and never
modified afterwards, so decoded arrays can be cached per datablock ``session_uid``, an
identity never reused within a session. The cache is dropped after file loads, undo and
redo (datablocks may be gone or restored) and refilled on demand.
"""

from dataclasses import dataclass

import bpy
import numpy as np

ARRAY_KEYS = ("coordinates", "rest_positions")
# Bind data live in users' .blend files: a later layout gets a new number, and data of
# another number read as missing ("Bind again") instead of being misread.
FORMAT_KEY, FORMAT = "gencoords_format", 1
TEXT_PREFIX = ".GenCoords bind data: "  # a leading dot hides it from most ID lists
TEXT_BODY = (
    "GenCoords bind data for the object '{}' (coordinates, rest shape, cage fingerprint).\n"
    "Stored as custom properties of this text; unbind the object to remove it.\n"
)

_cache = {}  # Text.session_uid -> BindData


@dataclass
class BindData:
    """Everything a bind produced; read-only once stored."""

    coordinates: np.ndarray  # (k, n) float32, C-contiguous: one row per mesh vertex
    rest_positions: np.ndarray  # (k, 3) float32, the mesh exactly as it was before binding
    cage_vertex_count: int
    cage_faces_hash: str  # ``mesh_io.faces_hash`` of the evaluated cage
    cage_non_triangles: int  # quads and n-gons triangulated for the computation
    kind: str  # core coordinate kind, e.g. "mean_value"
    outside: str  # core outside behaviour used, e.g. "raise"
    bind_seconds: float
    points_outside: int
    points_on_boundary: int
    min_coordinate: float
    negative_points: int
    max_affine_error: float
    nbytes: int

    @property
    def mesh_vertex_count(self):
        return self.coordinates.shape[0]

    def vertex_count_change(self, obj):
        """How the vertex count of ``obj`` changed since binding, or None when it fits."""
        count = len(obj.data.vertices)
        if count == self.mesh_vertex_count:
            return None
        return f"'{obj.name}' now has {count} vertices but was bound with {self.mesh_vertex_count}"


def save(obj, bind):
    """Store ``bind`` for ``obj`` in a new datablock, replacing any previous bind data."""
    remove(obj)
    text = bpy.data.texts.new(TEXT_PREFIX + obj.name)
    text.write(TEXT_BODY.format(obj.name))
    for key in ARRAY_KEYS:
        # np arrays go in through the buffer protocol as float32 ID property arrays.
        text[key] = np.ascontiguousarray(getattr(bind, key), dtype=np.float32).reshape(-1)
    for key, value in vars(bind).items():
        if key not in ARRAY_KEYS:
            text[key] = value
    text[FORMAT_KEY] = FORMAT
    obj.gencoords.bind_data = text
    _cache[text.session_uid] = bind


def load(obj):
    """The ``BindData`` of ``obj``, or None when it has none (or it is unreadable)."""
    text = obj.gencoords.bind_data
    if text is None:
        return None
    bind = _cache.get(text.session_uid)
    if bind is None:
        bind = _decode(text)
        if bind is not None:
            _cache[text.session_uid] = bind
    return bind


def _decode(text):
    if text.get(FORMAT_KEY) != FORMAT:
        return None
    scalars = {key: text[key] for key in BindData.__dataclass_fields__
               if key not in ARRAY_KEYS and key in text}
    if len(scalars) + len(ARRAY_KEYS) != len(BindData.__dataclass_fields__):
        return None
    if any(key not in text for key in ARRAY_KEYS):
        return None
    rest = np.array(text["rest_positions"], dtype=np.float32).reshape(-1, 3)
    coordinates = np.array(text["coordinates"], dtype=np.float32)
    if len(rest) == 0 or coordinates.size % len(rest):
        return None
    return BindData(coordinates=coordinates.reshape(len(rest), -1), rest_positions=rest,
                    **scalars)


def remove(obj):
    """Forget the bind data of ``obj``; delete the datablock once nothing uses it."""
    text = obj.gencoords.bind_data
    if text is None:
        return
    obj.gencoords.bind_data = None
    _cache.pop(text.session_uid, None)
    # Duplicated objects share the datablock; Texts keep a user of their own, so ask.
    if not any(other.gencoords.bind_data == text for other in bpy.data.objects):
        bpy.data.texts.remove(text)


def remove_orphans():
    """Delete bind data that no object points to (left behind by deleted objects).

    Texts keep a user of their own, so orphan purge and saving would keep them forever.
    """
    texts = [text for text in bpy.data.texts if text.name.startswith(TEXT_PREFIX)]
    if not texts:
        return
    used = {obj.gencoords.bind_data.session_uid for obj in bpy.data.objects
            if obj.gencoords.bind_data is not None}
    for text in texts:
        if text.session_uid not in used:
            _cache.pop(text.session_uid, None)
            bpy.data.texts.remove(text)


def any_bind_data():
    """Whether the open file holds any bind data (cheap: files have few texts)."""
    return any(text.name.startswith(TEXT_PREFIX) for text in bpy.data.texts)


def clear_cache():
    """Drop decoded arrays (after loading a file, when datablocks are all new)."""
    _cache.clear()
