"""Scenes the scripts build with bpy: Suzanne inside icosphere cages, fitted cages, mesh
objects from arrays, and the cage edits the demo and the benchmarks apply.

One piece of code per idea: ``demo/demo.py`` and ``benchmarks/bench_*.py`` build the same subdivided
Suzanne inside the same cages and read positions back the same way (the add-on's own
``gencoords_addon/blender_io/mesh_arrays.py``, loaded by path), so the demo's pictures and the
benchmarks' numbers describe the same thing. Import after ``session.prepare()``.
"""

import bpy
import numpy as np

import gencoords
from gencoords.construction.general import prepare_cage
from gencoords.construction.green import GREEN_LABEL
from gencoords.surfaces.named import HARMONIC
from .blender_objects import add_mesh_object, arrays, bind, make_active  # noqa: F401 (scripts use them from here)
from mathutils import Euler



# Suzanne's subdivision level -> vertex count (primitive_monkey_add, size 2, applied
# Catmull-Clark): the benchmark's three mesh sizes.
SUZANNE_VERTICES = {2: 7958, 3: 31658, 4: 126_218}
# Icosphere subdivisions -> cage vertex count.
ICOSPHERE_VERTICES = {2: 42, 3: 162, 4: 642}
# Suzanne (size 2) reaches 1.45 from the origin; an icosphere of radius 2 has an
# inscribed radius above 1.85 from 42 vertices on, so it contains every vertex.
CAGE_RADIUS = 2.0

# The parameter-free kinds (the power family has its own pictures: docs/POWER.md).
KINDS = tuple(kind.name for kind in gencoords.KIND_TABLE if kind.parameter is None)
# The core's spellings of kinds scripts name (the deformer's Green beside the paper's kinds).
from gencoords.construction.green import GREEN  # noqa: E402
from gencoords.surfaces.named import DISCRETE_HARMONIC, MEAN_VALUE, POWER, WACHSPRESS  # noqa: E402, F401
KIND_LABELS = {kind.name: kind.label for kind in gencoords.KIND_TABLE} | {GREEN: GREEN_LABEL, HARMONIC: "Harmonic"}


# ------------------------------------------------------------------------------ scenes


def reset_scene():
    """An empty scene, keeping enabled add-ons (``read_factory_settings`` would not)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    if scene.world is None:  # Workbench takes its background from the world colour
        scene.world = bpy.data.worlds.new("World")
    return scene


def add_suzanne(level=2, name="Suzanne"):
    """Suzanne with ``level`` Catmull-Clark subdivisions applied (7958 vertices at 2)."""
    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    if level:
        modifier = obj.modifiers.new("Subdivision", "SUBSURF")
        modifier.levels = modifier.render_levels = level
        bpy.ops.object.modifier_apply(modifier=modifier.name)
    bpy.ops.object.shade_smooth()
    return obj


MILLION_VERTICES = 999_547  # the large-mesh scene: a 1000 x 1000 UV sphere


def add_benchmark_mesh(level):
    """Suzanne subdivided ``level`` times, or (``None``) the million-vertex UV sphere,
    which a radius-2 icosphere cage contains like Suzanne."""
    if level is None:
        bpy.ops.mesh.primitive_uv_sphere_add(segments=1000, ring_count=1000, radius=1.4)
        return bpy.context.active_object
    return add_suzanne(level)


def add_icosphere_cage(subdivisions=2, radius=CAGE_RADIUS, name="Cage"):
    """A convex icosphere cage (42, 162, 642 vertices at 2, 3, 4), drawn as a wireframe."""
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=subdivisions, radius=radius)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    obj.display_type = "WIRE"  # the bound mesh stays visible inside it in the viewport
    return obj


def add_fitted_cage(mesh, subdivisions=2, margin=1.08, name="Cage"):
    """A snug convex cage: an icosphere stretched into an ellipsoid around ``mesh``.

    The axis radii follow the mesh's bounding box; then the whole cage is scaled until
    every mesh vertex is inside every face plane, times ``margin``. Scaling keeps it
    convex. A snug cage makes the mesh follow cage edits visibly (a loose one smooths
    them out), which is what the demo wants to show.

    Not Make Cage (``gencoords_addon/bind/cage_maker.py``, a hull of supporting planes with a
    vertex budget), which the demo shows beside it: this cage keeps the icosphere's
    topology, so the demo's edits (``nonaffine_edit``) and pictures stay the same.
    """
    points = arrays.read_positions(mesh.data) @ np.array(mesh.matrix_world)[:3, :3].T + np.array(
        mesh.matrix_world.translation)
    centre = 0.5 * (points.max(axis=0) + points.min(axis=0))
    radii = 0.5 * (points.max(axis=0) - points.min(axis=0))
    cage = add_icosphere_cage(subdivisions, radius=1.0, name=name)
    unit = arrays.read_positions(cage.data)
    # For the unit icosphere P: x is inside diag(radii) * P iff x / radii is inside P, i.e.
    # below every facet plane: facet_normal . y < facet_offset. The core's planes are in
    # P's frame (centred, divided by a power-of-two scale), so y is mapped into that frame
    # too; the offsets are positive there, and the ratio is then the scale P needs.
    planes = prepare_cage(unit, arrays.read_loop_triangles(cage.data))
    scaled = planes.local((points - centre) / radii)
    needed = (scaled @ planes.facet_normals.T / planes.facet_offsets).max()
    arrays.write_positions(cage.data, centre + unit * radii * needed * margin)
    return cage


def add_demo_mesh_and_cage():
    """The demo's deformation scene: Suzanne subdivided twice (7958 vertices) in a snug
    42-vertex fitted cage. Returns (mesh, cage)."""
    mesh = add_suzanne(level=2)
    return mesh, add_fitted_cage(mesh, subdivisions=2)


def add_character(detail=1.0):
    """The artist's character (``tests.fixtures.character``): a ~45k-vertex body of capsules
    in its box-modelled, non-convex quad cage (196 vertices). Returns (mesh, cage)."""
    from tests.fixtures import character
    body_vertices, body_triangles, _ = character.body_mesh(detail)
    cage_vertices, cage_quads = character.character_cage()
    return (add_mesh_object("Character", body_vertices, body_triangles),
            add_mesh_object("CharacterCage", cage_vertices, cage_quads))


def cage_size(points):
    """Length of the cage's bounding-box diagonal: the scale errors are reported against."""
    points = np.asarray(points)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


# --------------------------------------------------------------------------- cage edits


def nonaffine_edit(rest):
    """The demo's cage edit: pull the upper vertices up and twist them about the z axis.

    Height-dependent stretch and twist, so no affine map reproduces it and the mesh
    actually has to interpolate.
    """
    rest = np.asarray(rest, dtype=float)
    z = rest[:, 2]
    t = np.clip((z - z.min()) / max(z.max() - z.min(), 1e-12), 0.0, 1.0)  # 0 bottom, 1 top
    lift = np.maximum(t - 0.45, 0.0) ** 2 * 1.6 * (z.max() - z.min()) / 2.0
    angle = np.radians(75.0) * np.maximum(t - 0.3, 0.0)
    cos, sin = np.cos(angle), np.sin(angle)
    edited = rest.copy()
    edited[:, 0] = cos * rest[:, 0] - sin * rest[:, 1]
    edited[:, 1] = sin * rest[:, 0] + cos * rest[:, 1]
    edited[:, 2] = z + lift
    return edited


def similarity_map(points):
    """A fixed similarity (rotation, uniform scale 1.2, translation): Green coordinates,
    similarity invariant but not affine invariant, reproduce it exactly."""
    matrix = 1.2 * np.array(Euler((0.3, -0.2, 0.5)).to_matrix())
    return np.asarray(points, dtype=float) @ matrix.T + np.array([0.3, -0.2, 0.15])


def affine_map(points):
    """A fixed general affine map (rotation, anisotropic scale, shear, translation).

    Exact coordinates reproduce it exactly on the bound mesh: the accuracy check.
    """
    matrix = (np.array(Euler((0.3, -0.2, 0.5)).to_matrix())
              @ np.array([[1.2, 0.25, 0.0], [0.0, 0.8, 0.1], [0.0, 0.0, 1.1]]))
    return np.asarray(points, dtype=float) @ matrix.T + np.array([0.3, -0.2, 0.15])


def box_mesh(low, high):
    """The 8 corners (8, 3) and 6 outward quads (6, 4) of the axis-aligned box from ``low``
    to ``high``."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    return np.asarray(low, dtype=float) + corners * (np.asarray(high, dtype=float) - low), quads


# The hand's fingers: 4 across the palm's top and a thumb at its side, each a box (width,
# length) turned about its base by an angle (radians, about y), in the palm's units (the
# palm is 1 wide, 1 tall, 0.24 thick). Neighbouring fingers part by 3 degrees, so a gap
# widens from the base (``HAND_GAPS[0]`` of the hand's diagonal) to the tip (``[1]``).
HAND_FINGERS = 4
HAND_FINGER_LENGTH = 0.75
HAND_SPREAD = 0.053
HAND_GAPS = (1.0 / 60.0, 1.0 / 30.0)


def hand_parts():
    """The hand fixture's parts: a list of (corners (8, 3), quads (6, 4)), a palm box and five
    finger boxes (thumb last) sunk a little into it, spread slightly apart: between
    neighbouring fingers, gaps from 1/60 to about 1/30 of the hand's bounding-box diagonal
    (a mesh whose parts are closer than twice Make Cage Tight's usual offset)."""
    diagonal = 2.40  # of the hand below, to 1 %: the finger gaps are shares of it
    base_gap = HAND_GAPS[0] * diagonal
    width = (1.0 - (HAND_FINGERS - 1) * base_gap) / HAND_FINGERS
    parts = [box_mesh((0.0, -0.12, 0.0), (1.0, 0.12, 1.0))]
    for finger in range(HAND_FINGERS):
        angle = HAND_SPREAD * (finger - (HAND_FINGERS - 1) / 2.0)
        base = np.array([finger * (width + base_gap) + width / 2.0, 0.0, 0.97])
        parts.append(_finger(base, width, HAND_FINGER_LENGTH, angle, thickness=0.2))
    parts.append(_finger(np.array([-0.02, 0.0, 0.35]), 0.24, 0.6, -1.0, thickness=0.2))  # the thumb
    return parts


def _finger(base, width, length, angle, thickness):
    """A finger box from the middle of its base ``base`` (3,), turned by ``angle`` about y."""
    corners, quads = box_mesh((-width / 2.0, -thickness / 2.0, 0.0), (width / 2.0, thickness / 2.0, length))
    cos, sin = np.cos(angle), np.sin(angle)
    turn = np.array([[cos, 0.0, sin], [0.0, 1.0, 0.0], [-sin, 0.0, cos]])
    return corners @ turn.T + base, quads


def add_hand(name="Hand"):
    """The hand fixture (:func:`hand_parts`) as one mesh object of 6 closed boxes (48
    vertices, quads), its parts overlapping as a modeller's blocked-out hand does."""
    vertices, faces = [], []
    for corners, quads in hand_parts():
        faces.extend((quads + 8 * len(vertices)).tolist())
        vertices.append(corners)
    return add_mesh_object(name, np.concatenate(vertices), faces)
