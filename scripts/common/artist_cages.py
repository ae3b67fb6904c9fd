"""The reference set of scenes an artist builds, numpy only: meshes in box-modelled cages,
with the edits the benchmarks and tests make (issue 35).

Each fixture is a :class:`Fixture`: a mesh (triangles, each vertex labelled with its part),
a closed, outward-oriented cage around it (quads, or triangles where a pole closes a
revolved cage) and named edits (the cage's vertices after the edit, and the mesh vertices
of the other parts, which should not move):

- :func:`hand`: five slightly spread fingers, gaps 1/60 of the diagonal at the knuckles to
  1/30 at the tips, one chain of three boxes per finger; bend the middle finger 60 degrees.
- :func:`quadruped`: a body on four legs, the front legs 1/40 of the diagonal apart, a
  neck and head, a tail 1/80 thick; bend the front left leg, swing the tail.
- :func:`cup`: a thin-walled cup (walls 1/60 of the diagonal), revolved.
- :func:`cape`: an open sheet (no inside) in a thin box cage; swing its lower half.
- :func:`character`: ``scripts/common/character.py``'s figure; bend its left forearm.
- :func:`needle` and :func:`letter_h`: a needle-shaped box and an H, for the tests of
  harmonic coordinates' linear precision.

Box-modelled cages are the boundary of a union of boxes on a rectilinear grid (as the
character's); the hand's fingers are then fanned out by a shear that is the identity at
the palm, applied to the cage and the mesh alike, so the mesh stays inside.
"""

from dataclasses import dataclass, field

import numpy as np

from . import character as figure
from .character import boundary_quads, capsules_mesh

__all__ = ["Edit", "Fixture", "FIXTURES", "grid_cage", "revolved", "hand", "quadruped", "cup", "cape", "character",
           "needle", "letter_h", "fixture"]

_EPS = 1e-9


@dataclass(frozen=True, eq=False)
class Edit:
    """An artist's edit of a cage.

    Attributes
    ----------
    cage_vertices : (n, 3) float64
        The cage after the edit.
    still : (k,) bool
        The mesh vertices of the other parts: their largest move is the edit's leak.
    """

    cage_vertices: np.ndarray
    still: np.ndarray


@dataclass(frozen=True, eq=False)
class Fixture:
    """A mesh in its cage, and the edits made to the cage.

    Attributes
    ----------
    name : str
    mesh_vertices : (k, 3) float64
    mesh_faces : (t, 3) int64
        Triangles.
    mesh_parts : (k,) str
        The part each mesh vertex belongs to.
    cage_vertices : (n, 3) float64
    cage_faces : (f, 4) or (f, 3) int64
        Quads or triangles, counter-clockwise seen from outside.
    edits : dict of str to Edit
    """

    name: str
    mesh_vertices: np.ndarray
    mesh_faces: np.ndarray
    mesh_parts: np.ndarray
    cage_vertices: np.ndarray
    cage_faces: np.ndarray
    edits: dict = field(default_factory=dict)

    @property
    def cage_triangles(self):
        """The cage's faces as triangles: (m, 3) int64."""
        if self.cage_faces.shape[1] == 3:
            return self.cage_faces
        from gencoords.cages import triangulate_quads
        return np.asarray(triangulate_quads(self.cage_vertices, self.cage_faces), dtype=np.int64)

    @property
    def diagonal(self):
        """The cage's bounding-box diagonal: float."""
        return float(np.linalg.norm(np.ptp(self.cage_vertices, axis=0)))


def grid_cage(planes, boxes):
    """The boundary of a union of boxes on a rectilinear grid, in quads.

    Parameters
    ----------
    planes : 3 increasing sequences of float
        The grid's planes along x, y and z; every box's sides are among them.
    boxes : iterable of 3 (low, high) pairs
        Each box's range along x, y and z.

    Returns
    -------
    vertices : (n, 3) float64
    quads : (f, 4) int64
        Outward oriented, closed (manifold where no two boxes touch along an edge only).
    """
    planes = [np.asarray(values, dtype=np.float64) for values in planes]
    centres = np.meshgrid(*[(values[:-1] + values[1:]) / 2 for values in planes], indexing="ij")
    filled = np.zeros(centres[0].shape, dtype=bool)
    for box in boxes:
        inside = np.ones_like(filled)
        for axis, (low, high) in enumerate(box):
            inside &= (centres[axis] > low) & (centres[axis] < high)
        filled |= inside
    corners = boundary_quads(filled)
    unique, inverse = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    vertices = np.stack([planes[axis][unique[:, axis]] for axis in range(3)], axis=1)
    return vertices, inverse.reshape(-1, 4).astype(np.int64)


def revolved(profile, segments, angle_offset=0.0):
    """A closed surface of revolution about z from a profile that starts and ends on the axis.

    Parameters
    ----------
    profile : (p, 2) float
        (radius, height) points; the first and the last have radius 0 (poles), the
        others a positive radius.
    segments : int
        Points around each ring.
    angle_offset : float
        The rings' first angle (radians).

    Returns
    -------
    vertices : (2 + (p - 2) segments, 3) float64
    triangles : (t, 3) int64
        Outward oriented.
    """
    profile = np.asarray(profile, dtype=np.float64)
    angles = angle_offset + 2 * np.pi * np.arange(segments) / segments
    rings = profile[1:-1]
    around = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    ring_vertices = np.concatenate([np.column_stack([radius * around, np.full(segments, height)])
                                    for radius, height in rings])
    vertices = np.concatenate([[[0.0, 0.0, profile[0, 1]]], ring_vertices, [[0.0, 0.0, profile[-1, 1]]]])
    ring = [1 + i * segments + np.arange(segments) for i in range(len(rings))]
    last = len(vertices) - 1
    triangles = [np.stack([np.zeros(segments, np.int64), np.roll(ring[0], -1), ring[0]], axis=1)]
    for r0, r1 in zip(ring, ring[1:]):
        triangles += [np.stack([r0, np.roll(r0, -1), np.roll(r1, -1)], axis=1),
                      np.stack([r0, np.roll(r1, -1), r1], axis=1)]
    triangles.append(np.stack([np.full(segments, last), ring[-1], np.roll(ring[-1], -1)], axis=1))
    triangles = np.concatenate(triangles).astype(np.int64)
    a, b, c = (vertices[triangles[:, corner]] for corner in range(3))
    if np.einsum("ij,ij->i", a, np.cross(b, c)).sum() < 0.0:  # the profile ran clockwise
        triangles = triangles[:, ::-1].copy()
    return vertices, triangles


def _turned(points, selected, pivot, axis, degrees):
    """``points`` with the ``selected`` ones turned ``degrees`` about the line through
    ``pivot`` along the unit ``axis`` (Rodrigues): (n, 3) float64."""
    points = np.array(points, dtype=np.float64)
    axis = np.asarray(axis, dtype=np.float64)
    angle = np.radians(degrees)
    cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * cross @ cross
    points[selected] = (points[selected] - pivot) @ rotation.T + pivot
    return points


def _labelled(parts, name):
    """Mesh vertices of ``parts`` ((k,) str) whose part name starts with any of ``name``."""
    return np.char.startswith(parts.astype(str), name)


# ------------------------------------------------------------------------------ the hand

_FINGER_WIDTH, _FINGER_GAP, _FINGERS = 0.17, 0.0385, 5
_PALM_TOP, _KNUCKLES, _FINGER_TIP = 1.0, (1.35, 1.7), 2.0
_HAND_THICKNESS = 0.24


def _finger_of(x):
    """The finger whose column holds each x: (k,) int (clipped to the five)."""
    pitch = _FINGER_WIDTH + _FINGER_GAP
    return np.clip(np.floor(np.asarray(x) / pitch), 0, _FINGERS - 1).astype(np.int64)


def _spread(points):
    """The fingers fanned out: above the palm each finger's column shears away from the
    middle one, so its gap to the next doubles at the tips (the identity on the palm)."""
    pitch = _FINGER_WIDTH + _FINGER_GAP
    points = np.array(points, dtype=np.float64)
    height = np.clip(points[:, 2] - _PALM_TOP, 0.0, None)
    rate = _FINGER_GAP / (pitch * (_FINGER_TIP - _PALM_TOP))
    points[:, 0] += rate * (_finger_of(points[:, 0]) - (_FINGERS - 1) / 2) * pitch * height
    return points


def hand(detail=1.0):
    """A hand: a palm box and five fingers of three boxes each, slightly spread.

    The gaps between the fingers are 1/60 of the cage's diagonal at the knuckles and
    1/30 at the tips. Edit ``bend finger``: the middle finger's two outer boxes turned 60
    degrees toward the palm about its first knuckle.

    Parameters
    ----------
    detail : float
        The mesh's density (:func:`character.capsules_mesh`): about 14,000 vertices at 1.

    Returns
    -------
    Fixture
    """
    pitch = _FINGER_WIDTH + _FINGER_GAP
    sides = sorted({value for i in range(_FINGERS) for value in (i * pitch, i * pitch + _FINGER_WIDTH)})
    half = _HAND_THICKNESS / 2
    planes = (sides, (-half, half), (0.0, 0.5, _PALM_TOP) + _KNUCKLES + (_FINGER_TIP,))
    boxes = [((0.0, sides[-1]), (-half, half), (0.0, _PALM_TOP))]
    boxes += [((i * pitch, i * pitch + _FINGER_WIDTH), (-half, half), (_PALM_TOP, _FINGER_TIP))
              for i in range(_FINGERS)]
    cage, quads = grid_cage(planes, boxes)
    capsules = []
    for i in range(_FINGERS):
        centre = i * pitch + _FINGER_WIDTH / 2
        capsules.append(("palm", (centre, 0.0, 0.1), (centre, 0.0, 0.9), 0.075))
        capsules.append((f"finger{i}", (centre, 0.0, 0.95), (centre, 0.0, _FINGER_TIP - 0.08), 0.06))
    mesh, triangles, parts = capsules_mesh(capsules, detail)
    middle = _FINGERS // 2
    bent = (_finger_of(cage[:, 0]) == middle) & (cage[:, 2] > _KNUCKLES[0] + _EPS)
    pivot = np.array([middle * pitch + _FINGER_WIDTH / 2, 0.0, _KNUCKLES[0]])
    cage, mesh = _spread(cage), _spread(mesh)
    still = _labelled(parts, "finger") & (parts != f"finger{middle}")
    edits = {"bend finger": Edit(_turned(cage, bent, pivot, (1.0, 0.0, 0.0), 60.0), still)}
    return Fixture("hand", mesh, triangles, parts, cage, quads, edits)


# ------------------------------------------------------------------------------ the quadruped

_LEG_GAP = 0.034  # half the gap between left and right legs
_TAIL_HALF = 0.017  # half the tail's thickness
_TAIL_HEIGHT = 0.94


def quadruped(detail=1.0):
    """A quadruped: a body box on four legs, a head, a thin tail.

    The front legs are 1/40 of the cage's diagonal apart, the tail 1/80 thick. Edits:
    ``bend leg`` (the front left leg's lower half turned 45 degrees about its knee) and
    ``swing tail`` (the tail turned 45 degrees sideways about its root).

    Parameters
    ----------
    detail : float
        The mesh's density: about 20,000 vertices at 1.

    Returns
    -------
    Fixture
    """
    tail = (_TAIL_HEIGHT, _TAIL_HEIGHT + 2 * _TAIL_HALF)
    planes = ((-1.3, -1.0, -0.7, -0.65, -0.45, 0.45, 0.65, 0.7, 1.0),
              (-0.25, -0.12, -_LEG_GAP, -_TAIL_HALF, _TAIL_HALF, _LEG_GAP, 0.12, 0.25),
              (0.0, 0.3, 0.6, 0.9) + tail + (1.1, 1.3))
    legs = {"front_left": ((0.45, 0.65), (-0.25, -_LEG_GAP)), "front_right": ((0.45, 0.65), (_LEG_GAP, 0.25)),
            "back_left": ((-0.65, -0.45), (-0.25, -_LEG_GAP)), "back_right": ((-0.65, -0.45), (_LEG_GAP, 0.25))}
    boxes = [((-0.7, 0.7), (-0.25, 0.25), (0.6, 1.1)), ((0.7, 1.0), (-0.12, 0.12), (0.9, 1.3)),
             ((-1.3, -0.7), (-_TAIL_HALF, _TAIL_HALF), tail)]
    boxes += [(x, y, (0.0, 0.6)) for x, y in legs.values()]
    cage, quads = grid_cage(planes, boxes)
    capsules = [("body", (-0.5, -0.1, 0.85), (0.5, -0.1, 0.85), 0.13),
                ("body", (-0.5, 0.1, 0.85), (0.5, 0.1, 0.85), 0.13),
                ("head", (0.55, 0.0, 1.0), (0.9, 0.0, 1.0), 0.08),
                ("tail", (-0.68, 0.0, _TAIL_HEIGHT + _TAIL_HALF), (-1.28, 0.0, _TAIL_HEIGHT + _TAIL_HALF), 0.01)]
    for name, (x, y) in legs.items():
        centre = (sum(x) / 2, sum(y) / 2)
        capsules.append((f"leg_{name}", (*centre, 0.08), (*centre, 0.75), 0.07))
    mesh, triangles, parts = capsules_mesh(capsules, detail)
    (x0, x1), (y0, y1) = legs["front_left"]
    shin = (cage[:, 0] > x0 - _EPS) & (cage[:, 0] < x1 + _EPS) & (cage[:, 1] < y1 + _EPS) & (cage[:, 2] < 0.3 - _EPS)
    tail_cage = cage[:, 0] < -0.7 - _EPS
    others = ~_labelled(parts, "body")
    edits = {"bend leg": Edit(_turned(cage, shin, ((x0 + x1) / 2, 0.0, 0.3), (0.0, 1.0, 0.0), 45.0),
                              others & (parts != "leg_front_left")),
             "swing tail": Edit(_turned(cage, tail_cage, (-0.7, 0.0, 0.0), (0.0, 0.0, 1.0), 45.0),
                                others & (parts != "tail"))}
    return Fixture("quadruped", mesh, triangles, parts, cage, quads, edits)


# ------------------------------------------------------------------------------ the cup

_CUP_RADIUS, _CUP_HEIGHT, _CUP_WALL, _CUP_SEGMENTS = 0.5, 1.0, 0.025, 32


def cup(detail=1.0):
    """A thin-walled cup (walls and bottom 1/60 of the cage's diagonal), its cage the
    cup's own shape revolved in 32 segments; the mesh the walls' shell inset in it, 4x as
    fine around. No edit (the similarity is its test).

    Parameters
    ----------
    detail : float
        The mesh's density: about 16,000 vertices at 1.

    Returns
    -------
    Fixture
    """
    outer, inner, wall = _CUP_RADIUS, _CUP_RADIUS - _CUP_WALL, _CUP_WALL
    levels = np.linspace(0.0, _CUP_HEIGHT, 5)
    profile = ([(0.0, 0.0)] + [(outer, z) for z in levels] +
               [(inner, z) for z in levels[::-1][:-1]] + [(inner, wall), (0.0, wall)])
    cage, triangles = revolved(profile, _CUP_SEGMENTS)
    # Inside the cage's polygon: between the inner polygon's corners and the outer one's sides.
    margin = 0.2 * wall
    low, high = inner + margin, outer * np.cos(np.pi / _CUP_SEGMENTS) - 0.5 * margin
    steps = max(4, int(round(40 * detail)))
    heights = np.linspace(margin, _CUP_HEIGHT - margin, steps)
    radii = np.linspace(margin, high, max(2, steps // 2))
    mesh_profile = ([(0.0, margin)] + [(r, margin) for r in radii[1:]] + [(high, z) for z in heights[1:]] +
                    [(low, z) for z in heights[::-1][:-1]] + [(r, wall - margin) for r in radii[::-1] if r < low]
                    + [(0.0, wall - margin)])
    mesh, mesh_triangles = revolved(mesh_profile, 4 * _CUP_SEGMENTS * max(1, int(round(detail))))
    parts = np.full(len(mesh), "cup")
    return Fixture("cup", mesh, mesh_triangles, parts, cage, triangles)


# ------------------------------------------------------------------------------ the cape

def cape(detail=1.0):
    """An open sheet (a cape, no inside) in a thin box cage 1/28 of its diagonal thick.
    Edit ``swing cape``: the cage's lower half turned 45 degrees about the line across its
    middle; the sheet's top sixth should stay.

    Parameters
    ----------
    detail : float
        The sheet's density: about 12,000 vertices at 1.

    Returns
    -------
    Fixture
    """
    cage, quads = grid_cage(((-0.55, -0.275, 0.0, 0.275, 0.55), (-0.03, 0.03), (-0.05, 0.2, 0.4, 0.6, 0.8, 1.0, 1.25)),
                            [((-0.55, 0.55), (-0.03, 0.03), (-0.05, 1.25))])
    across, down = max(2, int(round(100 * detail))), max(2, int(round(120 * detail)))
    x, z = np.meshgrid(np.linspace(-0.5, 0.5, across), np.linspace(0.0, 1.2, down), indexing="ij")
    mesh = np.column_stack([x.ravel(), 0.01 * np.sin(np.pi * x.ravel()), z.ravel()])
    index = np.arange(across * down).reshape(across, down)
    a, b, c, d = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]
    triangles = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    parts = np.where(mesh[:, 2] >= 1.0, "top", "cape")
    lower = cage[:, 2] < 0.6 - _EPS
    edits = {"swing cape": Edit(_turned(cage, lower, (0.0, 0.0, 0.6), (1.0, 0.0, 0.0), 45.0), parts == "top")}
    return Fixture("cape", mesh, triangles.astype(np.int64), parts, cage, quads, edits)


# ------------------------------------------------------------------------------ the others

def character(detail=1.0):
    """``scripts/common/character.py``'s figure (about 45,000 vertices at 1). Edit
    ``bend forearm``: the left forearm turned 60 degrees about the elbow; the legs, the
    right arm and the head should stay."""
    cage, quads = figure.character_cage()
    mesh, triangles, parts = figure.body_mesh(detail)
    still = np.isin(parts, ["left_leg", "right_leg", "right_arm", "head"])
    return Fixture("character", mesh, triangles, parts, cage, quads,
                   {"bend forearm": Edit(figure.bent_forearm(cage, 60.0)[0], still)})


def needle(detail=1.0):
    """A needle-shaped cage: a box 70 times as long as it is thick, in eight segments,
    around a thin capsule."""
    half = 1.0 / 70
    cage, quads = grid_cage((np.linspace(-1.0, 1.0, 9), (-half, half), (-half, half)),
                            [((-1.0, 1.0), (-half, half), (-half, half))])
    mesh, triangles, parts = capsules_mesh([("needle", (-0.97, 0.0, 0.0), (0.97, 0.0, 0.0), 0.6 * half)],
                                           detail)
    return Fixture("needle", mesh, triangles, parts, cage, quads)


def letter_h(detail=1.0):
    """An H: two posts and a crossbar of boxes, with a capsule in each."""
    cage, quads = grid_cage(((0.0, 0.3, 0.7, 1.0), (0.0, 0.3), (0.0, 0.4, 0.6, 1.0)),
                            [((0.0, 0.3), (0.0, 0.3), (0.0, 1.0)), ((0.7, 1.0), (0.0, 0.3), (0.0, 1.0)),
                             ((0.3, 0.7), (0.0, 0.3), (0.4, 0.6))])
    capsules = [("left", (0.15, 0.15, 0.12), (0.15, 0.15, 0.88), 0.09),
                ("right", (0.85, 0.15, 0.12), (0.85, 0.15, 0.88), 0.09),
                ("bar", (0.1, 0.15, 0.5), (0.9, 0.15, 0.5), 0.07)]
    mesh, triangles, parts = capsules_mesh(capsules, detail)
    return Fixture("letter_h", mesh, triangles, parts, cage, quads)


# The reference set, in the order of the benchmarks' table.
FIXTURES = {"hand": hand, "quadruped": quadruped, "cup": cup, "cape": cape, "character": character,
            "needle": needle, "letter_h": letter_h}


def fixture(name, detail=1.0):
    """The fixture called ``name`` (a key of FIXTURES) at ``detail``: :class:`Fixture`."""
    return FIXTURES[name](detail)
