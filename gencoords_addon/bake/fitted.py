"""Bake to Bones, Fitted (game engines): a few rotating bones and at most 4 (or 8) weights a
vertex, fitted to what the binding shows over a frame range.

Truncating coordinates to the 4 largest per vertex (what a game engine reads of a bone
per cage vertex) cannot follow the cage; fitting can (``core.skinning.skin_fit``, SSDR as in
Dem Bones). The bake samples the mesh as Blender evaluates it with the binding's
modifier alone (its deformation, world space; other modifiers stay where they are and
apply to the rig's result as they did to the binding's) at every frame of the range, fits a skin, and writes an
armature whose bones are keyframed (location and rotation, LINEAR between keys, as
engines play samples) at those frames, so that exporters write the animation with their
default options (``bones.first_in_exports``); the vertex groups hold the
fitted weights; an Armature modifier takes the GenCoords modifier's place. The figures
reported are measured on what was written: the armature-deformed mesh, evaluated by
Blender at every sampled frame, against the samples.

The rig replays the sampled frames; the cage no longer drives it (a fitted bone is not
tied to a cage vertex). Any kind of binding can be baked so, Green and negative
coordinates included: the fit's weights are never negative.
"""

import contextlib
import itertools
import threading
import time

import bpy
import numpy as np
from mathutils import Matrix

from ...core.skinning import skin_fit
from ..bind import bindings as bindings_module
from ..blender_io import compat, mesh_arrays, mesh_io
from .. import steps
from ..errors import BakeError
from . import bones

BONE_PREFIX = "GenCoords Fitted "
DEFAULT_BONES = 64
DEFAULT_INFLUENCES = 4


def frame_range(scene, start=None, end=None):
    """The frames to sample: the scene's range, or ``start`` to ``end`` where given."""
    first = scene.frame_start if start is None else int(start)
    last = scene.frame_end if end is None else int(end)
    if last < first:
        raise BakeError(f"The frame range {first} to {last} is empty: End must "
                                        "be at least Start")
    return np.arange(first, last + 1)


@contextlib.contextmanager
def alone(obj, modifier):
    """The block sees ``obj`` deformed by ``modifier`` alone: the others are hidden from
    the viewport (what is sampled and measured), and shown again afterwards."""
    hidden = [m for m in obj.modifiers if m != modifier and m.show_viewport]
    shown = modifier.show_viewport
    for other in hidden:
        other.show_viewport = False
    modifier.show_viewport = True
    try:
        yield
    finally:
        modifier.show_viewport = shown
        for other in hidden:
            other.show_viewport = True


def sampling_steps(obj, context, frames, modifier):
    """The mesh's vertices in world space at each of ``frames``, deformed by ``modifier``
    alone (the binding's: its deformation is what is baked, and the Armature modifier
    that replaces it sees what it saw): (F, n, 3) float64, in steps (``steps``): a frame
    a step, the scene's frame and the modifiers put back when it ends or is closed (Esc)."""
    scene = context.scene
    current = scene.frame_current, scene.frame_subframe
    count = len(obj.data.vertices)
    positions = []
    try:
        with alone(obj, modifier):
            for frame in frames:
                scene.frame_set(int(frame))
                positions.append(bones.evaluated_world_positions(obj, context.evaluated_depsgraph_get()))
                yield len(positions) / len(frames)
    finally:
        scene.frame_set(current[0], subframe=current[1])
    if any(len(sampled) != count for sampled in positions):
        raise BakeError(f"Cannot bake '{obj.name}' to fitted bones: its binding "
                                        "changes its vertex count: Bind again")
    broken = [int(frame) for frame, sampled in zip(frames, positions) if not np.isfinite(sampled).all()]
    if broken:
        raise BakeError(
            f"Cannot bake '{obj.name}' to fitted bones: its deformed vertices are not finite "
            f"at frame {broken[0]} ({len(broken)} of the {len(frames)} frames sampled): check the cage's positions and "
            "keyframes there, or bake another frame range")
    return np.array(positions)


class Cancelled(Exception):
    """The fit was cancelled (Esc): nothing was changed."""


class FittedBakeJob:
    """A fitted bake in four steps: check and read the mesh (``preparing``), sample the
    deformation (``sampling``; both at creation, in Blender, unless made with
    ``sample=False``), fit (``run``, or ``start`` in a thread so that the window stays
    live; numpy only), write (``committing``, in Blender: write, measure, replace the
    binding). Those in Blender are steps (``steps``) a modal operator takes a timer event
    each; closed early (Esc), they leave the file as it was."""

    def __init__(self, obj, context, bone_count=DEFAULT_BONES, max_influences=DEFAULT_INFLUENCES,
                 frames=None, iterations=12, seed=0, sample=True):
        self.obj, self.found, self.rest, self.sampled = obj, bindings_module.binding(obj), None, None
        self.frames = frame_range(context.scene) if frames is None else np.asarray(frames)
        self.options = {"bones": bone_count, "max_influences": max_influences,
                        "iterations": iterations, "seed": seed}
        self.bone_count, self.fraction, self.fit, self.error = int(bone_count), 0.0, None, None
        self.fit_seconds, self._cancel, self._thread = 0.0, threading.Event(), None
        if sample:
            steps.run_to_end(self.preparing())
            steps.run_to_end(self.sampling(context))

    def preparing(self):
        """Refuse a binding that does not deform, then read the mesh at rest: steps."""
        obj = self.obj
        # A binding that does not deform (its cage deleted, its mesh edited since Bind)
        # would be fitted as a still mesh: refused, as Follow is.
        problem = bindings_module.deformation_problem(obj, self.found)
        if problem is not None:
            raise BakeError(f"Cannot bake '{obj.name}' to fitted bones: {problem}")
        yield 0.5
        world = np.array(obj.matrix_world, dtype=np.float64)
        self.rest = mesh_io.read_positions(obj.data).astype(np.float64) @ world[:3, :3].T + world[:3, 3]
        self.options["bones"] = min(self.bone_count, len(self.rest))
        yield 1.0

    def sampling(self, context):
        """Sample the deformation in steps (``steps``: a frame a step); sets ``sampled``."""
        self.sampled = yield from sampling_steps(self.obj, context, self.frames, self.found.modifier)
        return self.sampled

    def run(self, progress=None):
        """Fit here; ``progress(fraction)`` as it goes (an exception it raises cancels)."""
        def report(fraction):
            if self._cancel.is_set():
                raise Cancelled
            self.fraction = fraction
            if progress is not None:
                progress(fraction)
        start = time.perf_counter()
        self.fit = skin_fit.fit_skin(self.rest, self.sampled, progress=report, **self.options)
        self.fit_seconds = time.perf_counter() - start

    def start(self):
        """Fit in a thread; ``done`` says when it has ended, ``error`` how, if it failed."""
        def target():
            try:
                self.run()
            except BaseException as error:  # handed to the operator, in Blender's thread
                self.error = error
        self._thread = threading.Thread(target=target, name="GenCoords fitted bake", daemon=True)
        self._thread.start()

    @property
    def done(self):
        return self._thread is not None and not self._thread.is_alive()

    def cancel(self):
        """Stop the fit at its next round and wait for it."""
        self._cancel.set()
        if self._thread is not None:
            self._thread.join()

    def committing(self, context):
        """Write the rig (see ``bake``), in steps: returns (rig, figures); closed early,
        nothing written stays."""
        rig, figures = yield from _writing(self.obj, context, self.found, self.fit, self.rest,
                                           self.sampled, self.frames)
        figures.update({"fit_seconds": self.fit_seconds, "seeded_bones": self.bone_count})
        rig.data[bones.BAKE_INFO] = figures
        return rig, figures

    def commit(self, context):
        """:meth:`committing` to the end."""
        return steps.run_to_end(self.committing(context))


def baking_steps(job, context):
    """The whole bake of ``job`` (made with ``sample=False``) in steps, for a modal
    operator: preparing and sampling (a tenth of the progress), the fit in a thread (a
    step while it runs), the writing (the last tenth); returns (rig, figures). Closed
    early (Esc), the fit is stopped and nothing is changed."""
    yield from steps.scaled(job.preparing(), 0.0, 0.02)
    yield from steps.scaled(job.sampling(context), 0.02, 0.08)
    job.start()
    try:
        while not job.done:
            yield 0.1 + 0.8 * job.fraction
    finally:
        job.cancel()
    if job.error is not None:
        raise job.error
    return (yield from steps.scaled(job.committing(context), 0.9, 0.1))


def bake(obj, context, bone_count=DEFAULT_BONES, max_influences=DEFAULT_INFLUENCES,
         frames=None, iterations=12, seed=0, progress=None):
    """Replace the (first) binding of ``obj`` by a fitted, keyframed armature.

    Returns (rig, figures): figures holds "worst" and "rms", the deviation of the written
    rig from the sampled deformation as fractions of the mesh's diagonal (measured on
    Blender's evaluation of the rig), with the frames, bones and timings; the same
    figures are stored on the armature (``rig.data["gencoords_bake"]``). ``progress``
    (fraction) is called during the fit; an exception it raises cancels the bake with
    nothing changed.
    """
    job = FittedBakeJob(obj, context, bone_count, max_influences, frames, iterations, seed)
    job.run(progress)
    return job.commit(context)


def bone_names(obj, count):
    """The bones' (and their vertex groups') names, none of them a vertex group of ``obj``
    already: "GenCoords Fitted j" for a mesh's first bake, "GenCoords Fitted 2:j" for its
    second (the Armature modifier reads the groups named as its bones: an earlier bake's
    rig keeps reading its own weights), and so on."""
    taken = set(obj.vertex_groups.keys())
    for number in itertools.count(1):
        prefix = BONE_PREFIX if number == 1 else f"{BONE_PREFIX}{number}:"
        names = [f"{prefix}{j}" for j in range(count)]
        if taken.isdisjoint(names):
            return names


def _writing(obj, context, found, fit, rest, sampled, frames):
    """Write the rig, the vertex groups and the Armature modifier, measure, then remove
    the binding, in steps; on any failure, or closed early, everything written is removed
    and the binding stays."""
    names = bone_names(obj, fit.transforms.shape[1])
    had_groups = {g.name for g in obj.vertex_groups}
    parent, shown = obj.parent, found.modifier.show_viewport
    rig = skin = None
    try:
        rig = bpy.data.objects.new(f"{obj.name} fitted rig",
                                   bpy.data.armatures.new(f"{obj.name} fitted rig"))
        for collection in obj.users_collection:
            collection.objects.link(rig)
        diagonal = float(np.linalg.norm(np.ptp(rest, axis=0)))
        bones.add_bones(rig, names, fit.rest_matrices[:, :3, 3], diagonal)
        yield 0.05
        yield from steps.scaled(_keyframing(rig, names, frames, fit), 0.05, 0.15)
        dense = np.zeros((len(rest), len(names)))
        np.add.at(dense, (np.arange(len(rest))[:, None], fit.indices), fit.weights)
        mesh_arrays.write_weights(obj, names, dense)
        skin = obj.modifiers.new("Armature", 'ARMATURE')
        skin.object = rig
        compat.move_modifier(obj, skin, list(obj.modifiers).index(found.modifier))
        if obj.parent is None:  # exporters (glTF) expect a skinned mesh under its armature
            obj.parent = rig  # the rig sits at the world origin: the mesh does not move
        found.modifier.show_viewport = False  # measure the rig alone
        yield 0.3
        played = yield from steps.scaled(sampling_steps(obj, context, frames, skin), 0.3, 0.65)
        gaps = np.linalg.norm(played - sampled, axis=2) / max(diagonal, 1e-300)
        figures = {"mode": "FITTED", "cage": found.cage.name, "worst": float(gaps.max()),
                   "rms": float(np.sqrt(np.mean(gaps ** 2))), "frames": [int(frames[0]), int(frames[-1])],
                   "bones": len(names), "max_influences": int(fit.indices.shape[1])}
        bindings_module.remove(obj, [found])
    except BaseException:  # GeneratorExit (closed: Esc) among them
        found.modifier.show_viewport = shown
        obj.parent = parent
        if skin is not None:
            obj.modifiers.remove(skin)
        bones._remove_rig(rig)
        for group in [g for g in obj.vertex_groups if g.name in names and g.name not in had_groups]:
            obj.vertex_groups.remove(group)
        raise
    yield 1.0
    return rig, figures


KEYED_BONES_A_STEP = 16


def _keyframing(rig, names, frames, fit):
    """Key each bone's location and rotation (quaternion) at ``frames`` so that its
    skinning matrix is the fit's: pose basis = rest^-1 @ transform @ rest, in the bone's
    own rest frame (Blender's bones point along their Y axis); in steps of
    ``KEYED_BONES_A_STEP`` bones."""
    for name in names:  # creates the action and its curves, in all versions
        pose = rig.pose.bones[name]
        pose.rotation_mode = 'QUATERNION'
        for path in ("location", "rotation_quaternion"):
            pose.keyframe_insert(path, frame=float(frames[0]), group=name)
    rig.animation_data.action.name = f"{rig.name} fitted motion"
    curves = {(curve.data_path, curve.array_index): curve for curve in compat.action_fcurves(rig)}
    for j, name in enumerate(names):
        rest = rig.data.bones[name].matrix_local
        inverse = rest.inverted()
        locations, rotations = [], []
        for transform in fit.transforms[:, j]:
            location, rotation, _ = (inverse @ Matrix(transform.tolist()) @ rest).decompose()
            if rotations and np.dot(rotations[-1], rotation) < 0.0:
                rotation.negate()  # the same turn, without a flip between keyframes
            locations.append(location[:])
            rotations.append(rotation[:])
        for path, values in (("location", locations), ("rotation_quaternion", rotations)):
            for axis, column in enumerate(np.array(values).T):
                bones.key_linearly(curves[(f'pose.bones["{name}"].{path}', axis)], frames, column)
        if (j + 1) % KEYED_BONES_A_STEP == 0:
            yield (j + 1) / len(names)
    bones.first_in_exports(rig)
    yield 1.0


def summary(obj, rig, figures):
    """The operator's report of a fitted bake."""
    return (f"Baked '{obj.name}' to '{rig.name}' ({figures['bones']} fitted bones, at most "
            f"{figures['max_influences']} per vertex, keyframed over frames {figures['frames'][0]} "
            f"to {figures['frames'][1]}; fitted in {figures['fit_seconds']:.1f} s): deviation from "
            f"GenCoords worst {100 * figures['worst']:.2f} %, RMS {100 * figures['rms']:.3f} % of "
            "the mesh's size over those frames, measured on the rig written")
