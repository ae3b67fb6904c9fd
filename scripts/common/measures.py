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


def joint_creases(rest, moved, triangles, joint, radius, threshold):
    """The angle changes of the triangles whose rest centroid lies within ``radius`` of
    ``joint`` ((3,)): (creased: triangles with a corner changing by more than
    ``threshold`` degrees, 99th percentile, mean (degrees), triangles counted)."""
    centroids = np.asarray(rest, dtype=np.float64)[triangles].mean(axis=1)
    near = triangles[np.linalg.norm(centroids - joint, axis=1) < radius]
    change = angle_changes(rest, moved, near)
    creased = int((change.reshape(-1, 3) > threshold).any(axis=1).sum())
    return creased, float(np.percentile(change, 99)), float(change.mean()), len(near)
