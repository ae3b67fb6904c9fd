"""One Bind: ``BindJob(obj, context)`` reads everything it needs from the scene and checks
it (``bind.scene``); ``job.steps()`` runs the core's planning step
(``core.planning.bind_steps.plan_steps`` over ``core.planning.bind_plan``: a generator
yielding the fraction done, so the UI can show progress and cancel between chunks), the
job being the Blender side it asks (a ``PlanTool``); ``job.commit_steps()`` (or
``job.commit()``, to the end) then writes the plan (``bind.commit``), in steps too.
Nothing in the file changes before the writing, and the writing undoes its own partial work if it fails or is cancelled, so a failed or
cancelled Bind leaves the mesh, its modifier stack and any earlier binding as they were.
"""

import secrets
import time
from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from ... import core
from ...core.planning import bind_plan, bind_steps
from .. import messages, preferences, storage
from ..bind_layout import FORMAT, BindData
from ..enums import is_green, reads_quads
from ..errors import BindError
from ..steps import run_to_end
from . import commit
from .scene import FLOAT32_TOLERANCE, BindSettings, check_inputs, read_bind_input


@dataclass
class BindResult:
    """Everything ``commit`` writes: arrays for the mesh and the node group, and figures."""

    slots: np.ndarray  # (k, s) float32
    basis: np.ndarray  # (n, s) float64 ((n + m, s) for Green), or None for exact storage
    triangles: np.ndarray  # (m, 3) int: Green coordinates' cage triangles, else None
    rest_cage: np.ndarray  # (n, 3) float32, mesh-local, as Object Info gives it
    data: BindData  # METADATA
    # Sparse storage: each vertex's pairs' columns ((k, K) int32, their weights are the
    # slots); in two levels grid nodes, whose own pairs are ``nodes`` ((N, K') each).
    indices: Optional[np.ndarray] = None
    nodes: Optional[tuple] = None


class BindJob:
    """One Bind of ``obj`` to its chosen cage: read and checked on creation (BindError),
    computed by ``steps()``, written by ``commit()``. It reads the object's settings once,
    on creation (``self.settings``, a ``BindSettings``)."""

    def __init__(self, obj, context, in_workers=None, started=None):
        # When the artist asked for it: the Bind time reported is the wait since then.
        started = time.perf_counter() if started is None else started
        check_inputs(obj)
        self.obj = obj
        self.settings = settings = BindSettings.of(obj)
        self.cage, self.kind_label = settings.cage, settings.kind_label
        self.green = is_green(settings.kind)
        # The workers' fallback to Blender's process (``bind.service``; None: no fallback).
        self.fallback = bind_steps.WorkerFallback(in_workers)
        self.workers = preferences.worker_count(context)
        self.input = scene = read_bind_input(obj, settings, context)
        # Bind data as far as the scene tells; the plan adds the storage and the figures.
        self.data = BindData(
            format=FORMAT, kind=settings.kind, gamma=settings.gamma, outside=settings.outside,
            cage_vertex_count=len(scene.cage_vertices), mesh_vertex_count=len(scene.points),
            cage_faces_hash=scene.faces_hash, cage_non_triangles=scene.non_triangles,
            cage_name=self.cage.name, cage_face_count=len(scene.triangles) if self.green else None)
        self.started = started
        self.result = None
        self.writing = False  # set while the plan is being written (commit_steps)

    @property
    def worker_failure(self):
        """Where the workers failed and Blender computed instead, what to tell the artist."""
        return self.fallback.failure

    def read_input(self):
        """The mesh and the cage as read and checked (``BindInput``)."""
        return self.input

    def plan_request(self, run):
        """What the core plans: the settings in its terms, the workers the preferences ask
        for, ``run(compute, workers)`` computing (the fallback)."""
        settings = self.settings
        return bind_plan.BindRequest(
            kind=settings.kind, outside=settings.outside, gamma=settings.gamma, storage=settings.storage,
            compact_size=settings.compact_size, sparse_size=settings.sparse_size,
            resolution=settings.resolution, workers=self.workers,
            tolerance=FLOAT32_TOLERANCE, origins=self.input.origins, run=run,
            polygons=self.input.polygons if reads_quads(settings.kind) else None)

    def record(self, plan):
        """What the plan writes (``self.result``): the arrays and the bind data."""
        scene = self.input
        data = replace(self.data, storage=plan.storage, slot_count=plan.slot_count, key=secrets.token_hex(3),
                       bind_seconds=time.perf_counter() - self.started, **plan.figures())
        data = replace(data, nbytes=storage.of(data).nbytes(data))  # of the attributes it writes
        nodes = None if plan.node_indices is None else (plan.node_indices, plan.node_weights)
        self.result = BindResult(plan.slots, plan.basis, scene.triangles if self.green else None,
                                 scene.rest_cage, data, plan.indices, nodes)

    def steps(self):
        """Compute the bind data chunk by chunk, yielding the fraction done (0 to 1).

        Raises BindError for a bad cage or vertices outside it. Closing the generator
        early (a cancel) stops the core's worker processes and leaves nothing behind.
        """
        try:
            yield from bind_steps.plan_steps(self, self.fallback)
        except core.OutsideCageError:
            raise BindError(self._outside_message()) from None
        except bind_plan.ImpreciseCoordinatesError as error:
            raise BindError(self._imprecise_message(error)) from None
        except bind_plan.UndefinedCoordinatesError:
            raise BindError(f"Binding to '{self.cage.name}' gave undefined coordinates: "
                            "check the cage for tiny or overlapping faces") from None
        except ValueError as error:  # every other core error is a ValueError
            raise BindError(self._core_message(error)) from None

    def _core_message(self, error):
        """The core's ``error`` in Blender's terms; for a cage that is not convex, with the
        cage's faces that dent inward."""
        scene, dented = self.input, None
        if isinstance(error, core.CageError) and error.problem == "non_convex":
            dented = np.unique(scene.triangle_faces[core.advanced.concave_facets(
                scene.cage_vertices, scene.triangles, FLOAT32_TOLERANCE)])
        faces = scene.polygon_faces if reads_quads(self.settings.kind) else scene.triangle_faces
        return messages.core_error(self.cage.name, error, self.kind_label, len(scene.points), faces, dented)

    def _imprecise_message(self, error):
        settings, error_size = self.settings, bind_plan.short_number(error.error)
        if error.problem == "sums":
            size = f"up to {error.largest:.3g} in size"
            stray = (f"they sum to 1 only to {error_size}, and '{self.obj.name}' would fall behind a moving cage "
                     "by that share of its move")
        elif error.problem == "rounding":
            size = f"their sizes add up to {error.largest:.3g} at a vertex"
            stray = (f"they multiply the float32 rounding of the cage's positions, and '{self.obj.name}' would "
                     f"jitter by up to {error_size} of the cage's size as the cage moves")
        else:
            size = f"smallest {error.min_coordinate:.3g}"
            stray = (f"they place the vertices of '{self.obj.name}' only to {error_size} of the cage's size, and "
                     "the mesh would stray as the cage moves")
        choice = "a Gamma between -1 and -0.5, or another Type" if settings.gamma is not None else "another Type"
        # Origins far from the cage (more than its size) round its positions more: moving
        # them to the geometry is the cure that keeps the coordinates.
        if error.problem == "rounding" and error.distance > 1.0:
            advice = (f"Set the origins of '{self.obj.name}' and '{self.cage.name}' near the cage (Object > Set "
                      f"Origin > Origin to Geometry), or choose {choice}")
        else:
            advice = f"Choose {choice}"
        return (f"{self.kind_label} coordinates{messages.gamma_words(settings.gamma)} in the cage "
                f"'{self.cage.name}' are too large to store ({size}): as stored {stray}. {advice}")

    def _outside_message(self):
        scene = self.input
        where = core.point_locations(scene.points, scene.cage_vertices, scene.triangles,
                                     tolerance=FLOAT32_TOLERANCE)
        return messages.outside_error(self.cage.name, int(np.count_nonzero(where == core.OUTSIDE)),
                                      len(scene.points))

    def run(self, report=None):
        """Compute to the end (scripts, background mode); ``report(fraction)`` on the way."""
        for fraction in self.steps():
            if report is not None:
                report(fraction)
        return self.result

    def commit_steps(self):
        """Write the computed binding into the file (``bind.commit.steps``): a generator
        yielding the fraction written and returning the new ``Binding``; closed early, it
        leaves the file as it was. The bind time stored is the wait until its end."""
        self.writing = True
        return (yield from commit.steps(self.obj, self.cage, self.result, self.started))

    def commit(self):
        """:meth:`commit_steps` to the end; returns the new ``Binding``."""
        return run_to_end(self.commit_steps())
