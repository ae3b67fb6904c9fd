"""Shape measures the benchmarks and the demo share (numpy only)."""

import numpy as np


def triangle_angles(points, triangles):
    """(t, 3) corner angles in degrees of ``triangles`` ((t, 3) int) over ``points`` ((p, 3))."""
    corners = np.asarray(points, dtype=np.float64)[triangles]
    angles = []
    for c in range(3):
        a = corners[:, (c + 1) % 3] - corners[:, c]
        b = corners[:, (c + 2) % 3] - corners[:, c]
        cosine = (a * b).sum(1) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-30)
        angles.append(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))
    return np.stack(angles, axis=1)


def angle_changes(rest, moved, triangles):
    """How much each corner angle of ``triangles`` changed from ``rest`` to ``moved``
    points: (t * 3,) degrees, non-negative (a bend's figures: mean, 99th percentile)."""
    return np.abs(triangle_angles(moved, triangles) - triangle_angles(rest, triangles)).ravel()
