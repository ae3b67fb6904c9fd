"""Where a Harmonic Bind's time goes, in the core alone (issue 35): the add-on's call
(``plan_bind`` with the add-on's request: Harmonic, Automatic storage, the cage's quads,
float32 tolerance, default Resolution and workers) on ``tests/fixtures/artist_cages.py``'s
fixtures, each part's own time (a part called inside another counts for itself only).

    .venv/bin/python scripts/benchmarks/bind_split.py [--fixtures hand cup] [--detail 0.6] [--repeat 1] [--cpu]

With ``--cpu`` the seconds are this process's CPU time, steadier than wall time on a shared
machine (with ``OPENBLAS_NUM_THREADS=1``, one core's).

The field is solved in the caller's thread here (the Bind solves a long one in a thread
beside it, for its progress: the same work).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository: tests.fixtures
from tests.fixtures import artist_cages  # noqa: E402
from gencoords.base.tolerances import FLOAT32  # noqa: E402
from gencoords.evaluation.cage import Cage  # noqa: E402
from gencoords.harmonic import field, grid_field  # noqa: E402
from gencoords.planning import bind_plan, figures  # noqa: E402
from gencoords.surfaces.named import HARMONIC  # noqa: E402
from gencoords.planning.request import BindRequest  # noqa: E402
from gencoords.storage import two_level  # noqa: E402

# (label, owner, attribute): the parts timed, each where the Bind looks it up.
PARTS = (
    ("outside test (refusal)", Cage, "outside_points"),
    ("grid + inside nodes", grid_field, "_grid_nodes"),
    ("boundary values", grid_field, "_boundary_nodes"),
    ("boundary values", grid_field, "boundary_rhs"),
    ("solve", grid_field, "solved_rows"),
    ("nodes placed exactly", grid_field, "_placing_exactly"),
    ("points located", field.HarmonicField, "_located"),
    ("points placed (cut cells)", field.HarmonicField, "cut_pairs"),
    ("two levels: layout", two_level, "two_level_layout"),
    ("two levels: rows and figures", bind_plan, "_two_level_rows"),
    ("two levels: rows and figures", bind_plan, "_plan_two_level"),
    ("storage choice (sampled deviations)", bind_plan, "first_choice"),
    ("storage choice (sampled deviations)", bind_plan, "choose_by_estimate"),
    ("storage choice (sampled deviations)", bind_plan, "choose_by_measuring"),
    ("written slots and their deviations", figures, "written_slots"),
    ("similarity probe", bind_plan, "similarity_deviation"),
    ("similarity probe", figures, "similarity_deviation"),
    ("report", figures, "kind_report"),
)


class Timers:
    """Each part's own seconds: a part's time less the parts called inside it."""

    clock = staticmethod(time.perf_counter)

    def __init__(self):
        self.own, self.stack = {}, []

    def enter(self):
        self.stack.append([self.clock(), 0.0])

    def leave(self, label):
        start, inner = self.stack.pop()
        spent = self.clock() - start
        self.own[label] = self.own.get(label, 0.0) + spent - inner
        if self.stack:
            self.stack[-1][1] += spent

    def wrap(self, label, function):
        def timed(*args, **kwargs):
            self.enter()
            try:
                result = function(*args, **kwargs)
            finally:
                self.leave(label)
            if hasattr(result, "send"):  # a generator: its steps timed as they run
                return self._steps(label, result)
            return result
        return timed

    def _steps(self, label, steps):
        while True:
            self.enter()
            try:
                fraction = next(steps)
            except StopIteration as stop:
                self.leave(label)
                return stop.value
            self.leave(label)
            yield fraction


def install(timers):
    for label, owner, name in PARTS:
        setattr(owner, name, timers.wrap(label, getattr(owner, name)))
    bind_plan.INLINE_FIELD_NODES = bind_plan.INLINE_FIELD_PAIRS = 1 << 62  # solved in this thread


def bind(scene):
    faces = scene.cage_faces
    polygons = faces if faces.shape[1] == 4 else np.column_stack([faces, np.full(len(faces), -1)])
    request = BindRequest(HARMONIC, tolerance=FLOAT32, polygons=polygons)
    steps = bind_plan.plan_bind(scene.mesh_vertices, scene.cage_vertices, scene.cage_triangles, request)
    try:
        while True:
            next(steps)
    except StopIteration as stop:
        return stop.value


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fixtures", nargs="+", default=["hand", "quadruped", "cup", "cape", "character"])
    parser.add_argument("--detail", type=float, default=0.6)
    parser.add_argument("--repeat", type=int, default=1, help="binds per fixture: the fastest is shown")
    parser.add_argument("--cpu", action="store_true", help="CPU seconds of this process, not wall seconds")
    arguments = parser.parse_args()
    clock = time.process_time if arguments.cpu else time.perf_counter
    Timers.clock = staticmethod(clock)
    timers = Timers()
    install(timers)
    for name in arguments.fixtures:
        scene = artist_cages.fixture(name, arguments.detail)
        best = None
        for _ in range(arguments.repeat):
            timers.own = {}
            start = clock()
            plan = bind(scene)
            total = clock() - start
            if best is None or total < best[0]:
                best = (total, dict(timers.own), plan.storage)
        total, own, storage = best
        own["other"] = total - sum(own.values())
        print(f"{name}: {len(scene.mesh_vertices)} vertices, {len(scene.cage_vertices)} cage vertices, "
              f"{storage}, {total:.2f} s{' CPU' if arguments.cpu else ''}")
        for label, seconds in sorted(own.items(), key=lambda item: -item[1]):
            if seconds >= 0.005:
                print(f"    {seconds:6.2f} s  {label}")


if __name__ == "__main__":
    main()
