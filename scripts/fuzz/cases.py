"""The fuzz's cases: a seed gives a scene (a cage, a mesh, how both are placed) and a list
of steps, as plain JSON-able dicts, with no Blender involved.

The same seed gives the same case on any machine (``random.Random(seed)`` only), so a
failing case is replayed from its seed alone and its steps are printed without Blender.
Bad input is the point: cages open, non-manifold, self-intersecting, with duplicate
vertices, zero-area faces, flipped faces or NaN, at scales 1e-6 to 1e6, far from the
origin, with zero and negative object scales and modifiers; meshes with loose vertices,
shape keys, modifiers, linked duplicates, outside the cage or the cage itself.
"""

import json
import random

import gencoords
from gencoords.construction.green import GREEN
from gencoords.surfaces.named import MEAN_VALUE, POWER
from gencoords.surfaces.named import HARMONIC

# The core's kinds, Green coordinates and harmonic coordinates (the add-on's enum order).
KINDS = tuple(kind.name.upper() for kind in gencoords.KIND_TABLE) + (GREEN.upper(), HARMONIC.upper())
# Harmonic coordinates' grid: coarse, so a case binds in a second (the setting's minimum
# is 4, and 5 leaves a cell straddling the middle), now and then fine. Finer grids do not
# fit a case's 120 s on a busy machine: the field of a 162-vertex icosphere took 63 s at
# Bind's default 48 and 177 s at 64 on two shared cores (seeds 81 and 343 drawn at 128).
HARMONIC_RESOLUTIONS = (4, 4, 5, 8, 16)
HARMONIC_FINE = 32
OUTSIDE = ("RAISE", "PROJECT", "EXTRAPOLATE")
STORAGE = ("AUTO", "EXACT", "COMPACT", "SPARSE")
BAKE_MODES = ("CAGE_VERTICES", "CAGE_VERTICES", "FITTED")

CAGE_SHAPES = ("cube", "icosphere", "cylinder", "uv_sphere", "dented", "character")
CAGE_DEFECTS = ("open", "non_manifold", "self_intersecting", "duplicate_vertices", "zero_area_face",
                "flipped", "flipped_face", "nan", "loose_vertex", "flat")
CAGE_MODIFIERS = ("SUBSURF", "TRIANGULATE", "DISPLACE", "SOLIDIFY")
MESH_SHAPES = ("sphere", "monkey", "grid", "icosphere", "points", "cage_itself", "single_vertex")
MESH_MODIFIERS = ("SUBSURF", "SMOOTH", "DISPLACE")
# What Make Cage's mesh may be made first (its data): all its vertices at one point, a
# thousandth of a micrometre across, or flat.
MESH_ODDITIES = ("one_point", "tiny", "flat")
# Make Cage Tight's offsets (the setting's share of the mesh's size; soft maximum 0.1).
TIGHT_OFFSETS = (0.0, 0.001, 0.01, 0.1, 0.5, 1.25)
# Object scales: a zero or a negative axis, or a mirror on every axis.
ODD_SCALES = ("zero_x", "negative_x", "negative_all")
# The roles objects play; steps name roles, the scene maps them to objects.
ROLES = ("mesh", "cage", "twin", "copy", "made")

# Steps and how often each is drawn.
STEP_WEIGHTS = {
    "bind": 8, "rebind": 2, "unbind": 3, "translate_cage": 8, "edit_cage": 2, "cage_topology": 1,
    "mesh_topology": 1, "delete": 1, "apply": 2, "duplicate": 1, "save_reload": 2, "bake": 2,
    "show_field": 2, "clear_field": 1, "make_cage": 2, "frame": 3, "object_scale": 1,
    "edit_mode": 2, "rename": 1, "parent_cage": 1, "move_mesh": 2,
}


def _pick(rng, choices, probability=1.0):
    """One of ``choices``, or None with probability ``1 - probability``."""
    return rng.choice(choices) if rng.random() < probability else None


def scene_of(rng):
    """How the cage and the mesh are built and placed."""
    cage = {"shape": rng.choice(CAGE_SHAPES), "defect": _pick(rng, CAGE_DEFECTS, 0.3),
            "modifier": _pick(rng, CAGE_MODIFIERS, 0.2), "odd_scale": _pick(rng, ODD_SCALES, 0.07),
            "rotation": [rng.uniform(-3.2, 3.2) for _ in range(3)] if rng.random() < 0.3 else None}
    mesh = {"shape": rng.choice(MESH_SHAPES), "size": rng.choice((0.3, 0.5, 0.6, 1.5)),
            "loose_vertices": rng.random() < 0.2, "shape_keys": rng.random() < 0.2,
            "modifier": _pick(rng, MESH_MODIFIERS, 0.2), "twin": rng.random() < 0.2,
            "odd_scale": _pick(rng, ODD_SCALES[:1], 0.08), "nan": rng.random() < 0.04}
    # The whole scene at one scale and place: in the objects' transforms or in their data.
    placement = {"scale": 10.0 ** rng.choice((-6, -6, -3, 3, 6, rng.uniform(-6, 6))) if rng.random() < 0.3 else 1.0,
                 "offset": (10.0 ** rng.uniform(2, 6)) * rng.choice((-1, 1)) if rng.random() < 0.2 else 0.0,
                 "in_data": rng.random() < 0.5}
    return {"cage": cage, "mesh": mesh, "placement": placement}


def role(rng, available, choices):
    """One of ``choices`` (roles, repeated for weight), mostly one that exists by then."""
    present = [c for c in choices if c in available]
    return rng.choice(present if present and rng.random() < 0.9 else choices)


def bind_step(rng, available, op="bind"):
    kind = rng.choice(KINDS)
    step = {"op": op, "target": role(rng, available, ("mesh", "mesh", "mesh", "twin", "copy")),
            "cage": role(rng, available, ("cage",) * 4 + ("made", "made", "mesh")), "kind": kind,
            "outside": rng.choice(OUTSIDE), "storage": rng.choice(STORAGE),
            "compact_size": rng.choice((4, 6, 12, 36))}
    if step["storage"] == "SPARSE":  # pairs per vertex, or per grid node in two levels
        step["sparse_size"] = rng.choice((1, 3, 8, 32))
    if kind == POWER.upper():
        step["gamma"] = rng.choice((-16.0, -8.0, -2.0, -1.0, -0.5, 0.0, 1.0, 2.0, 16.0))
    if kind == HARMONIC.upper():
        step["resolution"] = HARMONIC_FINE if rng.random() < 0.1 else rng.choice(HARMONIC_RESOLUTIONS)
    return step


def bake_step(rng, target, mode=None):
    """Bake to Bones; Fitted with 1 to 8 influences (0: its default 4), a few bones, and
    a short frame range anywhere: before frame 0, one frame, or ending before it starts."""
    step = {"op": "bake", "target": target, "max_influences": rng.choice((0, 0, 1, 4, 8)),
            "keyframes": rng.random() < 0.5, "mode": mode or rng.choice(BAKE_MODES)}
    if step["mode"] == "FITTED":  # a few bones over a few frames: seconds, not minutes
        start = rng.choice((-3, 0, 1, 1, 7))
        step.update(max_influences=rng.randint(0, 8), bones=rng.choice((1, 2, 4, 8, 16)), frame_start=start,
                    frame_end=start + rng.choice((-1, 0, 1, 2, 2)))
    return step


def make_cage_step(rng, target):
    """Make Cage, convex or tight, now and then of an odd mesh (``MESH_ODDITIES``)."""
    step = {"op": "make_cage", "target": target, "vertices": rng.choice((8, 20, 100, 300)),
            "margin": rng.choice((0.0, 0.01, 0.05, 0.5)), "shape": rng.choice(("CONVEX", "CONVEX", "TIGHT")),
            "oddity": _pick(rng, MESH_ODDITIES, 0.2)}
    if step["shape"] == "TIGHT":
        step["offset"] = rng.choice(TIGHT_OFFSETS)
    return step


def translation(rng, cage):
    return {"op": "translate_cage", "cage": cage, "how": rng.choice(("object", "vertices")),
            "back": rng.random() < 0.5, "amount": 10.0 ** rng.uniform(-4, 0),
            "direction": [rng.gauss(0, 1) for _ in range(3)]}


def step_of(rng, available):
    """One random step, mostly on objects that exist by then (``available``: roles)."""
    op = rng.choices(list(STEP_WEIGHTS), weights=list(STEP_WEIGHTS.values()))[0]
    target = role(rng, available, ("mesh", "mesh", "twin", "copy"))
    cage = role(rng, available, ("cage", "cage", "made"))
    if op == "bind":
        return bind_step(rng, available)
    if op in ("rebind", "unbind", "show_field", "clear_field", "mesh_topology", "duplicate"):
        step = {"op": op, "target": target}
        if op == "show_field":
            step["vertex"] = rng.choice((0, 1, 5, 30, 500))
        if op == "mesh_topology":
            step["change"] = rng.choice(("delete_vertex", "add_vertex", "subdivide"))
        if op == "duplicate":
            step["linked"] = rng.random() < 0.5
        return step
    if op == "translate_cage":
        return translation(rng, cage)
    if op == "edit_cage":
        return {"op": op, "cage": cage, "amount": rng.choice((0.01, 0.1, 0.5)),
                "seed": rng.randrange(2**31), "nan": rng.random() < 0.1}
    if op == "cage_topology":
        return {"op": op, "cage": cage,
                "change": rng.choice(("subdivide", "delete_vertex", "triangulate"))}
    if op == "delete":
        return {"op": op, "target": role(rng, available, ("cage", "cage", "mesh", "twin", "made", "copy"))}
    if op == "apply":
        return {"op": op, "target": role(rng, available, ("mesh", "mesh", "twin", "cage")), "which": rng.choice(("first", "last"))}
    if op == "bake":
        return bake_step(rng, target)
    if op == "make_cage":
        return make_cage_step(rng, target)
    if op == "frame":
        return {"op": op, "cage": cage, "amount": 10.0 ** rng.uniform(-3, 0),
                "direction": [rng.gauss(0, 1) for _ in range(3)]}
    if op == "edit_mode":
        return {"op": op, "target": target, "auto_rebind": rng.random() < 0.6,
                "change": rng.choice(("delete", "subdivide", "none"))}
    if op == "rename":
        return {"op": op, "target": role(rng, available, ("cage", "mesh", "made"))}
    if op == "parent_cage":
        return {"op": op, "cage": cage, "target": target}
    if op == "move_mesh":
        return {"op": op, "target": target, "amount": 10.0 ** rng.uniform(-3, 0),
                "direction": [rng.gauss(0, 1) for _ in range(3)]}
    if op == "object_scale":
        return {"op": op, "target": rng.choice(("cage", "mesh")), "scale": rng.choice(ODD_SCALES + ("one",))}
    return {"op": op}  # save_reload


def story(rng, available, scene):
    """A sequence where cage deformers tend to break, its parameters random: a good
    binding first, then copies sharing its data, a bake, two Fitted bakes of one mesh (a
    rebind or a second cage between them), the cage deleted, a tiny cage object moved, or
    the mesh object flat; random steps follow."""
    # A cage and a mesh that bind (the defects come later), but for a flat mesh object.
    scene["cage"].update(defect=None, odd_scale=None)
    scene["mesh"].update(nan=False, odd_scale=None, shape=rng.choice(("sphere", "monkey", "icosphere", "grid")))
    steps = [dict(bind_step(rng, available), target="mesh", cage="cage",
                  kind=MEAN_VALUE.upper(), outside="PROJECT")]  # any closed cage
    theme = rng.choice(("copies", "bake", "two bakes", "deleted cage", "small", "flat mesh"))
    if theme == "copies":
        steps.append({"op": "duplicate", "target": "mesh", "linked": rng.random() < 0.8})
        available.add("copy")
        steps.append({"op": rng.choice(("unbind", "rebind", "bake")), "target": rng.choice(("mesh", "copy")),
                      "max_influences": 0, "keyframes": False})
    elif theme == "bake":
        if rng.random() < 0.4:
            steps.append({"op": "edit_cage", "cage": "cage", "amount": 0.01, "seed": rng.randrange(2**31),
                          "nan": True})
        steps.append({"op": "bake", "target": "mesh", "max_influences": rng.choice((0, 4)),
                      "keyframes": rng.random() < 0.5})
    elif theme == "two bakes":
        steps.append(bake_step(rng, "mesh", "FITTED"))
        if rng.random() < 0.5:
            steps.append({"op": "rebind", "target": "mesh"})
        else:  # a second cage around the mesh, bound beside the first
            steps.append(dict(make_cage_step(rng, "mesh"), shape="CONVEX", oddity=None))
            steps.append(dict(bind_step(rng, available), target="mesh", cage="made", kind=MEAN_VALUE.upper(),
                              outside="PROJECT"))
            available.add("made")
        steps.append(bake_step(rng, "mesh", "FITTED"))
    elif theme == "deleted cage":
        steps.append({"op": "delete", "target": "cage"})
        steps.append({"op": "show_field", "target": "mesh", "vertex": rng.choice((0, 1, 5))})
        steps.append({"op": "show_field", "target": "mesh", "vertex": rng.choice((0, 2))})
    elif theme == "small":  # a micro-scale cage (its data) whose object moves by less than 1e-6
        scene["placement"].update(scale=10.0 ** rng.uniform(-7, -5), in_data=True, offset=0.0)
    else:  # a mesh object scaled to zero on an axis
        scene["mesh"]["odd_scale"] = "zero_x"
    steps.append(dict(translation(rng, "cage"), how="object"))
    return theme, steps


def case_of(seed):
    """The case of ``seed``: {"seed", "scene", "steps"}: a story (``story``) or a first Bind
    more often than not, then random steps."""
    rng = random.Random(seed)
    scene = scene_of(rng)
    available = {"mesh", "cage"} | ({"twin"} if scene["mesh"]["twin"] else set())
    theme = None
    if rng.random() < 0.35:
        theme, steps = story(rng, available, scene)
    else:
        steps = [bind_step(rng, available)] if rng.random() < 0.8 else []
        if steps and rng.random() < 0.7:
            steps[0]["target"], steps[0]["cage"] = "mesh", "cage"
    for _ in range(rng.randint(2, 9)):
        steps.append(step_of(rng, available))
        available.add({"duplicate": "copy", "make_cage": "made"}.get(steps[-1]["op"], "mesh"))
        if steps[-1]["op"] == "make_cage" and rng.random() < 0.6:  # a made cage always binds
            steps.append(dict(bind_step(rng, available), target=steps[-1]["target"], cage="made",
                              kind=MEAN_VALUE.upper(), outside="RAISE"))
        if steps[-1]["op"] in ("bind", "rebind", "duplicate", "unbind", "bake") and rng.random() < 0.5:
            steps.append(translation(rng, role(rng, available, ("cage", "cage", "made"))))
    return {"seed": seed, "story": theme, "scene": scene, "steps": steps}


def describe(case):
    """The case as lines of text: its scene, then one numbered line per step."""
    lines = [f"story: {case['story']}", f"scene: {json.dumps(case['scene'], sort_keys=True)}"]
    for number, step in enumerate(case["steps"]):
        arguments = ", ".join(f"{key}={value!r}" for key, value in step.items() if key != "op")
        lines.append(f"  {number}: {step['op']}({arguments})")
    return lines
