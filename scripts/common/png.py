"""Writing PNG files with numpy and zlib only: Blender's Python and the core's
environment have no image library."""

import struct
import zlib

import numpy as np


def write_png(path, rgb):
    """Write an (h, w, 3) RGB or (h, w, 4) RGBA array, rows top-down, as an 8-bit PNG.

    ``rgb`` is uint8, or float in [0, 1] (rounded and clipped to 8 bits). Returns the path.
    """
    rgb = np.asarray(rgb)
    if rgb.dtype != np.uint8:
        rgb = np.clip(np.round(rgb * 255.0), 0, 255).astype(np.uint8)

    def chunk(kind, payload):
        body = kind + payload
        return struct.pack(">I", len(payload)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    height, width = rgb.shape[:2]
    rows = b"".join(b"\0" + np.ascontiguousarray(row).tobytes() for row in rgb)
    colour_type = {3: 2, 4: 6}[rgb.shape[2]]  # PNG's truecolour, truecolour with alpha
    header = struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0)
    with open(path, "wb") as file:
        file.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows, 9))
                   + chunk(b"IEND", b""))
    return path
