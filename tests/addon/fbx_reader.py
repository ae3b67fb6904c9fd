"""A reader of binary FBX files of our own (numpy and the standard library only): the
node tree, and what a game engine's loader takes of the animation (the takes, in the
file's order, and which objects each one animates). Issue 37 item 10: ufbx and three.js
play the first take of a file Blender's FBX exporter writes."""

import struct
import zlib

import numpy as np

_SCALARS = {b"Y": "<h", b"C": "<?", b"I": "<i", b"F": "<f", b"D": "<d", b"L": "<q"}
_ARRAYS = {b"f": "<f4", b"d": "<f8", b"l": "<i8", b"i": "<i4", b"b": "<?"}


def _property(data, at):
    """One property at ``at``: (value, next offset)."""
    kind = data[at:at + 1]
    at += 1
    if kind in _SCALARS:
        size = struct.calcsize(_SCALARS[kind])
        return struct.unpack_from(_SCALARS[kind], data, at)[0], at + size
    if kind in _ARRAYS:
        count, encoding, length = struct.unpack_from("<III", data, at)
        raw = data[at + 12:at + 12 + length]
        return np.frombuffer(zlib.decompress(raw) if encoding else raw, dtype=_ARRAYS[kind], count=count), \
            at + 12 + length
    if kind in (b"S", b"R"):
        (length,) = struct.unpack_from("<I", data, at)
        return bytes(data[at + 4:at + 4 + length]), at + 4 + length
    raise ValueError(f"unknown FBX property type {kind!r} at {at - 1}")


def _node(data, at, wide):
    """The node record at ``at``: ((name, properties, children) or None at a list's end, next offset)."""
    head = "<QQQB" if wide else "<IIIB"
    end, count, _, name_length = struct.unpack_from(head, data, at)
    at += struct.calcsize(head)
    if end == 0:
        return None, at
    name = data[at:at + name_length].decode()
    at += name_length
    properties = []
    for _ in range(count):
        value, at = _property(data, at)
        properties.append(value)
    children = []
    while at < end:
        child, at = _node(data, at, wide)
        if child is None:
            break
        children.append(child)
    return (name, properties, children), end


def read_fbx(path):
    """The top-level nodes of a binary FBX file: a list of (name, properties, children)."""
    data = memoryview(open(path, "rb").read()).tobytes()
    assert data[:21] == b"Kaydara FBX Binary  \x00", "not a binary FBX file"
    (version,) = struct.unpack_from("<I", data, 23)
    nodes, at = [], 27
    while True:
        node, at = _node(data, at, version >= 7500)
        if node is None:
            return nodes
        nodes.append(node)


def _child(node, name):
    return next(child for child in node[2] if child[0] == name)


def animation_takes(path):
    """The file's animation stacks in the order a loader lists them, each as (name,
    {model name: how far its keyed values range}): the models (objects and bones) whose
    curves the stack holds, and the largest spread (max - min) of any of their curves'
    values (0: keyed but still)."""
    nodes = read_fbx(path)
    objects = next(node for node in nodes if node[0] == "Objects")[2]
    named = {node[1][0]: (node[0], node[1][1].split(b"\x00\x01")[0].decode(), node) for node in objects}
    links = [(node[1][1], node[1][2]) for node in next(n for n in nodes if n[0] == "Connections")[2]
             if node[1][0] in (b"OO", b"OP")]

    def linked(parent, kind):
        return [child for child, to in links if to == parent and named.get(child, ("",))[0] == kind]

    def spread(curve_node):
        values = [_child(named[curve][2], "KeyValueFloat")[1][0] for curve in linked(curve_node, "AnimationCurve")]
        return max((float(np.ptp(v)) for v in values if len(v)), default=0.0)

    takes = []
    for stack in (node[1][0] for node in objects if node[0] == "AnimationStack"):
        models = {}
        for layer in linked(stack, "AnimationLayer"):
            for curve_node in linked(layer, "AnimationCurveNode"):
                for model in (to for child, to in links if child == curve_node and named.get(to, ("",))[0] == "Model"):
                    name = named[model][1]
                    models[name] = max(models.get(name, 0.0), spread(curve_node))
        takes.append((named[stack][1], models))
    return takes
