"""A Bind's steps without Blender (gencoords.planning.bind_steps), the Blender side a stand-in
tool as the add-on's ``BindJob`` is one: planning on what it read, computing before writing
with the progress split and the cancel, the workers' fallback, the report."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

import gencoords
from gencoords.planning import bind_steps
from gencoords.planning.request import BindRequest
from gencoords.cages.shapes import icosphere


class StandIn:
    """The Blender side (a ``PlanTool`` and a ``BindTool``): what a Bind read, its
    settings, and a log of what it was asked."""

    def __init__(self, points, vertices, faces, storage='EXACT', compute=None, write=None):
        self.scene = SimpleNamespace(points=points, cage_vertices=vertices, triangles=faces)
        self.storage, self.compute, self.write = storage, compute, write
        self.calls, self.plan, self.progress = [], None, []

    def read_input(self):
        self.calls.append("read")
        return self.scene

    def plan_request(self, run):
        self.calls.append("request")
        return BindRequest("mean_value", storage=self.storage, workers=1, run=run)

    def record(self, plan):
        self.calls.append("record")
        self.plan = plan

    def compute_steps(self):
        self.calls.append("compute")
        return self.compute()

    def write_binding(self):
        self.calls.append("write")
        return self.write()

    def report_progress(self, fraction):
        self.progress.append(fraction)


def steps_of(fractions, result, log):
    """Steps yielding ``fractions`` and returning ``result``; ``log`` gets 'closed' when
    they are closed before their end and 'ended' at it."""
    try:
        yield from fractions
    except GeneratorExit:
        log.append("closed")
        raise
    log.append("ended")
    return result


@pytest.fixture
def cage():
    vertices, faces = icosphere(1)
    return vertices, faces, np.random.default_rng(3).uniform(-0.3, 0.3, (60, 3))


def test_planning_reads_the_tool_plans_in_its_request_and_records_the_plan(cage):
    vertices, faces, points = cage
    tool, runs = StandIn(points, vertices, faces), []
    fallback = bind_steps.WorkerFallback(lambda compute, workers: (runs.append(workers) or compute(workers), None))
    fractions, plan = [], None
    steps = bind_steps.plan_steps(tool, fallback)
    plan = bind_steps.run_to_end(steps, fractions.append)
    assert tool.calls == ["read", "request", "record"] and tool.plan is plan
    assert runs and fractions == sorted(fractions) and fractions[-1] == 1.0
    assert plan.storage == 'EXACT' and plan.slots.shape == (len(points), len(vertices))
    np.testing.assert_allclose(plan.slots.astype(np.float64) @ vertices, points, atol=1e-6)


def test_a_bad_cage_raises_the_cores_error_and_records_nothing(cage):
    vertices, faces, points = cage
    tool = StandIn(points + 5.0, vertices, faces)  # all outside
    with pytest.raises(gencoords.OutsideCageError):
        bind_steps.run_to_end(bind_steps.plan_steps(tool, bind_steps.WorkerFallback()))
    assert tool.plan is None and "record" not in tool.calls


def test_the_writing_starts_after_the_computing_and_shares_the_progress(cage):
    log = []
    tool = StandIn(*cage, compute=lambda: steps_of([0.0, 0.5, 1.0], None, log),
                   write=lambda: steps_of([0.0, 0.5], "binding", log))
    assert bind_steps.bind(tool) == "binding"
    assert tool.calls == ["compute", "write"] and log == ["ended", "ended"]
    computing = bind_steps.COMPUTING
    np.testing.assert_allclose(tool.progress, [0.0, 0.5 * computing, computing, computing,
                                               computing + 0.5 * (1.0 - computing)])


def test_a_cancel_while_computing_closes_the_computing_and_never_writes(cage):
    log = []
    tool = StandIn(*cage, compute=lambda: steps_of([0.0, 0.5, 1.0], None, log),
                   write=lambda: steps_of([0.0], "binding", log))
    steps = bind_steps.bind_steps(tool)
    next(steps), next(steps)
    steps.close()  # Esc
    assert log == ["closed"] and "write" not in tool.calls


def test_a_cancel_while_writing_closes_the_writing(cage):
    log = []
    tool = StandIn(*cage, compute=lambda: steps_of([1.0], None, log), write=lambda: steps_of([0.0, 0.5], "b", log))
    steps = bind_steps.bind_steps(tool)
    assert [next(steps) for _ in range(2)] == [bind_steps.COMPUTING] * 2
    steps.close()
    assert log == ["ended", "closed"]


def test_failed_workers_fall_back_to_one_process_for_the_rest_of_the_bind():
    calls = []

    def compute(workers):
        calls.append(workers)
        if workers > 1:
            raise gencoords.WorkerError("no shared memory")
        return workers * 10

    fallback = bind_steps.WorkerFallback(bind_steps.in_workers_or_here)
    assert fallback(compute, 4) == 10 and calls == [4, 1]
    assert isinstance(fallback.failure, gencoords.WorkerError)
    assert fallback(compute, 4) == 10 and calls == [4, 1, 1]  # straight to one process
    assert bind_steps.WorkerFallback()(compute, 1) == 10  # no fallback asked: as it is


def test_an_automatic_count_that_fell_back_by_itself_is_a_failure_and_other_warnings_pass():
    def compute(workers):
        warnings.warn("fell back", gencoords.WorkerWarning)
        warnings.warn("something else", UserWarning)
        return workers

    with pytest.warns(UserWarning, match="something else"):
        result, failure = bind_steps.in_workers_or_here(compute, None)
    assert result is None and str(failure) == "fell back"
    assert bind_steps.in_workers_or_here(lambda workers: workers, 2) == (2, None)


def test_a_report_warns_only_with_notes():
    assert bind_steps.bind_report("Bound 'Mesh'") == ('INFO', "Bound 'Mesh'")
    assert bind_steps.bind_report("Bound", ["a", "b"]) == ('WARNING', "Bound; a; b")


def rotation_scale(angle, scale, mirror=False):
    """An object matrix (4, 4): a rotation about z, a uniform scale, a translation, and
    with ``mirror`` a flip of x."""
    c, s = np.cos(angle), np.sin(angle)
    world = np.eye(4)
    world[:3, :3] = scale * np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag(
        [-1.0 if mirror else 1.0, 1.0, 1.0])
    world[:3, 3] = [3.0, -1.0, 0.5]
    return world


def signed_volume(vertices, faces):
    return np.einsum("ij,ij->i", vertices[faces[:, 0]], np.cross(vertices[faces[:, 1]], vertices[faces[:, 2]])).sum()


@pytest.mark.parametrize("mirror", [False, True])
def test_the_computing_frame_is_world_space_or_the_mesh_local_one_with_the_cage_outward(cage, mirror):
    vertices, faces, points = cage  # local space; the faces outward in world space
    world = rotation_scale(0.7, 2.0, mirror)
    faces_world = faces[:, ::-1] if mirror else faces
    cage_origin = np.array([1.0, 2.0, 3.0])
    placed, cage_placed, triangles, origins = bind_steps.computing_frame(points, vertices, faces_world, world,
                                                                         cage_origin)
    np.testing.assert_allclose(placed, points @ world[:3, :3].T + world[:3, 3])
    assert triangles is faces_world and signed_volume(cage_placed, triangles) > 0.0
    np.testing.assert_array_equal(origins, [world[:3, 3], cage_origin])
    local, cage_local, triangles, origins = bind_steps.computing_frame(points, vertices, faces_world, world,
                                                                       cage_origin, local=True)
    assert local is points and cage_local is vertices and signed_volume(cage_local, triangles) > 0.0
    np.testing.assert_allclose(origins @ world[:3, :3].T + world[:3, 3], [world[:3, 3], cage_origin], atol=1e-12)


def test_zero_scale_axes_are_those_far_below_the_longest():
    assert bind_steps.zero_scale_axes(rotation_scale(0.3, 1e-3), 1e-6) == []  # small, not flat
    assert bind_steps.zero_scale_axes(np.diag([1.0, 1.0, 1e-8, 1.0]), 1e-6) == ['Z']
    assert bind_steps.zero_scale_axes(np.zeros((4, 4)), 1e-6) == ['X', 'Y', 'Z']
