"""An artist's character and its cage, numpy only: the fixture that local coordinates,
Bake to Bones and the benchmarks are tried on.

The cage is box-modelled the way an artist models one: a T-posed figure (legs apart, arms
out, neck and head) built from boxes on a rectilinear grid, in quads, closed, outward
oriented and strongly non-convex (the gap between the legs, the armpits, the neck). The
body is a set of capsules (legs, torso, arms, neck, a head), each well inside its part
of the cage, so every body point is inside the cage with a margin.

Units are metres: about 1.75 tall, 1.9 across the arms, the +z axis up, facing -y.

``character_cage()`` and ``body_mesh()`` give the arrays; ``limb_labels`` and
``cage_limb_vertices`` name which part a point or a cage vertex belongs to, for locality
figures (how far the other limbs move when one limb's cage vertices move).
"""

import numpy as np

__all__ = ["ELBOW", "LIMBS", "bent_forearm", "body_mesh", "body_points", "boundary_quads", "cage_limb_vertices",
           "capsule_surface", "capsules_mesh", "character_cage", "character_capsules", "limb_labels"]

# The cage's grid planes. x: hands at +-0.95, the torso and hips within +-0.2, a gap
# between the legs within +-0.07 (below the hips), the neck within +-0.07.
X_PLANES = np.array([-0.95, -0.8, -0.65, -0.5, -0.35, -0.2, -0.07, 0.07, 0.2, 0.35, 0.5, 0.65, 0.8, 0.95])
Y_PLANES = np.array([-0.13, 0.0, 0.13])
Z_PLANES = np.array([0.0, 0.2, 0.4, 0.6, 0.8, 0.95, 1.1, 1.25, 1.4, 1.5, 1.6, 1.75])

# The parts of the figure as boxes of the grid (x range, z range; every box spans y).
_BOXES = {
    "left_leg": ((-0.2, -0.07), (0.0, 0.8)),
    "right_leg": ((0.07, 0.2), (0.0, 0.8)),
    "torso": ((-0.2, 0.2), (0.8, 1.4)),
    "left_arm": ((-0.95, -0.2), (1.25, 1.4)),
    "right_arm": ((0.2, 0.95), (1.25, 1.4)),
    "neck": ((-0.07, 0.07), (1.4, 1.5)),
    "head": ((-0.2, 0.2), (1.5, 1.75)),
}
LIMBS = tuple(_BOXES)
# The left elbow: the middle of the left arm, on its axis (the forearm bends about y here).
ELBOW = np.array([-0.575, 0.0, 1.325])

# The body: (part, end a, end b, radius), each capsule inside its box with a margin of at
# least 0.015.
_CAPSULES = (
    ("left_leg", (-0.135, 0.0, 0.08), (-0.135, 0.0, 0.85), 0.05),
    ("right_leg", (0.135, 0.0, 0.08), (0.135, 0.0, 0.85), 0.05),
    ("torso", (-0.07, 0.0, 0.93), (-0.07, 0.0, 1.27), 0.1),
    ("torso", (0.07, 0.0, 0.93), (0.07, 0.0, 1.27), 0.1),
    ("left_arm", (-0.2, 0.0, 1.325), (-0.88, 0.0, 1.325), 0.055),
    ("right_arm", (0.2, 0.0, 1.325), (0.88, 0.0, 1.325), 0.055),
    ("neck", (0.0, 0.0, 1.35), (0.0, 0.0, 1.55), 0.045),
    ("head", (0.0, 0.0, 1.615), (0.0, 0.0, 1.625), 0.1),
)


def _occupied_cells():
    """(cx, cy, cz) bool: which cells of the grid the figure fills."""
    centres = [(planes[:-1] + planes[1:]) / 2 for planes in (X_PLANES, Y_PLANES, Z_PLANES)]
    x, _, z = np.meshgrid(*centres, indexing="ij")
    filled = np.zeros(x.shape, dtype=bool)
    for (x0, x1), (z0, z1) in _BOXES.values():
        filled |= (x > x0) & (x < x1) & (z > z0) & (z < z1)
    return filled


def boundary_quads(filled):
    """Outward quads of the cells' union (of a rectilinear grid's cells), as grid-corner index triples: (f, 4, 3) int."""
    padded = np.pad(filled, 1)
    quads = []
    for axis in range(3):
        # A face between cell c (below, along axis) and c + e: boundary where they differ.
        below = np.take(padded, range(padded.shape[axis] - 1), axis=axis)
        above = np.take(padded, range(1, padded.shape[axis]), axis=axis)
        u, v = [a for a in range(3) if a != axis]
        for sign, where in ((+1, below & ~above), (-1, above & ~below)):
            for cell in np.argwhere(where):
                corner = cell - 1  # back to unpadded cell indices; the face is at corner[axis] + 1
                corner[axis] += 1
                du, dv = np.eye(3, dtype=int)[u], np.eye(3, dtype=int)[v]
                ring = [corner, corner + du, corner + du + dv, corner + dv]
                # (u, v, axis) is right-handed for axis 0 and 2 and left-handed for 1.
                right_handed = (u, v) in ((1, 2), (0, 1), (2, 0))
                quads.append(ring if (sign > 0) == right_handed else ring[::-1])
    return np.array(quads)


def character_cage():
    """The box-modelled quad cage around the character.

    Returns
    -------
    vertices : (n, 3) float64
        About two hundred vertices.
    quads : (f, 4) int64
        Outward oriented (counter-clockwise seen from outside), closed, manifold.
    """
    corners = boundary_quads(_occupied_cells())
    unique, inverse = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    vertices = np.stack([X_PLANES[unique[:, 0]], Y_PLANES[unique[:, 1]], Z_PLANES[unique[:, 2]]], axis=1)
    return vertices.astype(np.float64), inverse.reshape(-1, 4).astype(np.int64)


def character_capsules():
    """The body as capsules: a list of (part, a (3,), b (3,), radius), parts from LIMBS."""
    return [(part, np.array(a), np.array(b), radius) for part, a, b, radius in _CAPSULES]


def _capsule_distances(points):
    """(k, c) float: each point's distance to each capsule's surface (negative inside)."""
    distances = []
    for _, a, b, radius in character_capsules():
        axis = b - a
        t = np.clip((points - a) @ axis / (axis @ axis), 0.0, 1.0)
        distances.append(np.linalg.norm(points - (a + t[:, None] * axis), axis=1) - radius)
    return np.stack(distances, axis=1)


def limb_labels(points):
    """The part of the figure each point is nearest to: (k,) str, names from LIMBS."""
    names = np.array([part for part, *_ in _CAPSULES])
    return names[np.argmin(_capsule_distances(np.asarray(points, dtype=float)), axis=1)]


def body_points(count, seed=0):
    """``count`` points inside the body, uniformly by rejection: (count, 3) float64."""
    rng = np.random.default_rng(seed)
    low, high = np.array([-0.95, -0.1, 0.0]), np.array([0.95, 0.1, 1.75])
    found = np.empty((0, 3))
    while len(found) < count:
        trial = rng.uniform(low, high, (4 * count, 3))
        found = np.concatenate([found, trial[_capsule_distances(trial).min(axis=1) < 0]])
    return found[:count]


def capsule_surface(a, b, radius, cap_rings, length_rings, segments):
    """A closed capsule surface along a -> b: (vertices (p, 3), triangles (t, 3)), outward."""
    axis = (b - a) / np.linalg.norm(b - a)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    azimuth = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    around = np.cos(azimuth)[:, None] * u + np.sin(azimuth)[:, None] * v  # (segments, 3)
    # Rings from a's pole to b's: a's hemisphere, the cylinder, b's hemisphere (poles apart).
    cap = np.linspace(0, np.pi / 2, cap_rings + 1)[1:]  # angle from the pole
    rows = [a + radius * (-np.cos(t) * axis + np.sin(t) * around) for t in cap]
    rows += [a + s * (b - a) + radius * around for s in np.linspace(0, 1, length_rings + 2)[1:-1]]
    rows += [b + radius * (np.cos(t) * axis + np.sin(t) * around) for t in cap[::-1]]
    vertices = np.concatenate([(a - radius * axis)[None], *rows, (b + radius * axis)[None]])
    ring = [1 + i * segments + np.arange(segments) for i in range(len(rows))]
    triangles = [np.stack([np.zeros(segments, int), np.roll(ring[0], -1), ring[0]], axis=1)]
    for r0, r1 in zip(ring, ring[1:]):
        triangles += [np.stack([r0, np.roll(r0, -1), np.roll(r1, -1)], axis=1),
                      np.stack([r0, np.roll(r1, -1), r1], axis=1)]
    last = np.full(segments, len(vertices) - 1)
    triangles.append(np.stack([last, ring[-1], np.roll(ring[-1], -1)], axis=1))
    return vertices, np.concatenate(triangles)


def body_mesh(detail=1.0):
    """The character's body as overlapping closed capsule surfaces (:func:`capsules_mesh`
    of :func:`character_capsules`): about 45,000 vertices at ``detail`` 1.0."""
    return capsules_mesh(character_capsules(), detail)


def capsules_mesh(capsules, detail=1.0):
    """Overlapping closed capsule surfaces, triangles, with square-ish quads.

    Parameters
    ----------
    capsules : list of (part str, a (3,), b (3,), radius float)
    detail : float
        Scales the rings and segments: 860 x radius segments around each capsule at 1.0.

    Returns
    -------
    vertices : (p, 3) float64
    triangles : (t, 3) int64
        Outward oriented.
    labels : (p,) str
        The part each vertex belongs to.
    """
    parts, offset = [], 0
    for part, a, b, radius in capsules:
        a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        # Square-ish quads: a ring every 2 pi r / segments along the capsule.
        segments = max(8, int(round(detail * 860 * radius)))
        spacing = 2 * np.pi * radius / segments
        cap_rings = max(2, int(round(np.pi / 2 * radius / spacing)))
        length_rings = max(1, int(round(np.linalg.norm(b - a) / spacing)))
        vertices, triangles = capsule_surface(a, b, radius, cap_rings, length_rings, segments)
        parts.append((vertices, triangles + offset, np.full(len(vertices), part)))
        offset += len(vertices)
    vertices, triangles, labels = (np.concatenate(column) for column in zip(*parts))
    return vertices, triangles, labels


def cage_limb_vertices(vertices, part, beyond=0.5):
    """Indices of the cage vertices that move with a limb: the outer ``beyond`` share of
    an arm's or leg's length (a hand and forearm, a foot and shin), or the head's.

    Parameters
    ----------
    vertices : (n, 3) float
        The cage's vertices (``character_cage()[0]``).
    part : str
        One of "left_arm", "right_arm", "left_leg", "right_leg", "head".
    """
    (x0, x1), (z0, z1) = _BOXES[part]
    x, z = vertices[:, 0], vertices[:, 2]
    if part.endswith("arm"):
        reach = abs(X_PLANES[0]) - 0.2
        inside = np.abs(x) >= abs(X_PLANES[0]) - beyond * reach - 1e-9
        side = np.sign(x) == np.sign(x0 + x1)
        return np.flatnonzero(inside & side & (z >= z0 - 1e-9) & (z <= z1 + 1e-9))
    if part.endswith("leg"):
        low = z <= beyond * 0.8 + 1e-9
        return np.flatnonzero(low & (x >= x0 - 1e-9) & (x <= x1 + 1e-9))
    return np.flatnonzero(z >= 1.5 - 1e-9)


def bent_forearm(vertices, degrees=60.0):
    """The cage with its left forearm (``cage_limb_vertices(vertices, "left_arm")``) turned
    ``degrees`` about the y axis through ``ELBOW`` (positive: the hand goes up).

    Parameters
    ----------
    vertices : (n, 3) float
        The cage's vertices at rest.

    Returns
    -------
    bent : (n, 3) float64
    rotation : (3, 3) float64
        The forearm's rotation.
    """
    angle = np.radians(degrees)
    cos, sin = np.cos(angle), np.sin(angle)
    rotation = np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]])
    bent = np.array(vertices, dtype=np.float64)
    forearm = cage_limb_vertices(bent, "left_arm")
    bent[forearm] = (bent[forearm] - ELBOW) @ rotation.T + ELBOW
    return bent, rotation

