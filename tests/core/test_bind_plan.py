"""Bind planning without Blender (gencoords.planning.bind_plan): the storage chosen and why,
the deviations measured on what will be written, progress and cancel."""

from dataclasses import replace

import numpy as np
import pytest

import gencoords
from gencoords.harmonic.interpolation import CORNER_COUNT
from gencoords.planning import bind_plan, figures, storage_choice
from gencoords.storage import compact, deviations, pair_deviations, sparse, two_level
from gencoords.planning.bind_plan import plan_bind
from gencoords.planning.request import BindRequest
from gencoords.planning.storage_choice import choose_storage
from gencoords.cages.shapes import icosphere
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


def run(generator):
    """Drive a plan to its end: (fractions yielded, the plan returned)."""
    fractions = []
    try:
        while True:
            fractions.append(next(generator))
    except StopIteration as stop:
        return fractions, stop.value


@pytest.fixture(scope="module")
def irregular():
    """An irregular 60-vertex cage and 900 points inside it."""
    rng = np.random.default_rng(28)
    vertices, faces = random_convex_polytope(rng, 3, 60)
    return vertices, faces, random_interior_points(rng, vertices, 900)


def test_storage_is_exact_for_moderate_sizes_and_measured_beyond():
    assert choose_storage('AUTO', 31_658, 162, 36) == 'EXACT'
    assert choose_storage('AUTO', 1_000_000, 642, 36) == 'AUTO'  # measured at Bind
    assert choose_storage('COMPACT', 1_000_000, 642, 36) == 'COMPACT'
    assert choose_storage('COMPACT', 20, 42, 36) == 'EXACT'  # fewer mesh than cage vertices
    assert choose_storage('COMPACT', 5000, 12, 36) == 'EXACT'  # nothing to save


def test_exact_plan_writes_the_coordinates_as_float32_and_says_why(irregular):
    vertices, faces, points = irregular
    fractions, plan = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    exact = gencoords.coordinates(points, vertices, faces)
    assert plan.storage == 'EXACT' and plan.basis is None and plan.slot_count == len(vertices)
    np.testing.assert_array_equal(plan.slots, exact.astype(np.float32))
    assert plan.storage_choice == f"Automatic: exact ({len(points)} x {len(vertices)} coordinates: cheap " \
                                  "enough to store them all)"
    # Figures on what is written: float32 rounding alone, and the summary of the coordinates.
    assert 0.0 <= plan.deviation_smooth < 1e-6 and 0.0 <= plan.deviation_drag < 1e-6
    assert plan.min_coordinate == pytest.approx(exact.min()) and plan.negative_points == 0  # convex cage
    assert plan.points_outside == 0 and fractions[-1] == 1.0


def test_compact_plan_measures_the_deviation_of_what_it_writes(irregular):
    vertices, faces, points = irregular
    request = BindRequest("mean_value", storage='COMPACT', compact_size=12, workers=1)
    _, plan = run(plan_bind(points, vertices, faces, request))
    assert plan.storage == 'COMPACT' and plan.slots.shape == (len(points), 12) and plan.storage_choice is None
    exact = gencoords.coordinates(points, vertices, faces)
    basis = plan.basis.astype(np.float32).astype(np.float64)  # as the deformer reads it
    reproduced = plan.slots @ basis.T
    smooth = deviations.deviation(exact, plan.slots, basis, vertices, deviations.smooth_test_motion(vertices))
    assert plan.deviation_smooth == pytest.approx(smooth, rel=1e-6)
    drags = [deviations.deviation(exact, plan.slots, basis, vertices, deviations.vertex_drag_motion(vertices, j))
             for j in range(len(vertices))]
    assert plan.deviation_drag == pytest.approx(max(drags), rel=1e-6)
    assert plan.deviation_drag_vertex == int(np.argmax(drags))
    assert 0.0 < plan.deviation_smooth < plan.deviation_drag  # 12 of 60 slots: a real deviation
    assert np.abs(reproduced - exact).max() > 1e-4


def test_automatic_beyond_the_cheap_sizes_picks_the_fewest_slots_under_the_target(monkeypatch):
    monkeypatch.setattr(storage_choice, "EXACT_MAX_PRODUCT", 0)
    vertices, faces = icosphere(3)  # smooth: few slots reproduce the coordinates
    rng = np.random.default_rng(3)
    points = 0.6 * rng.uniform(-1.0, 1.0, (3000, 3)) / np.sqrt(3.0)
    _, plan = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    assert plan.storage == 'COMPACT' and plan.slot_count % 3 == 0 and plan.slot_count <= len(vertices) // 2
    worst = max(plan.deviation_smooth, plan.deviation_drag)
    assert worst < bind_plan.AUTO_DEVIATION
    assert plan.storage_choice == (f"Automatic: compact, {plan.slot_count} slots (deviation "
                                   f"{bind_plan.short_number(worst)} < 1e-3)")


def test_automatic_goes_exact_when_the_whole_mesh_misses_the_target(monkeypatch, irregular):
    vertices, faces, points = irregular
    monkeypatch.setattr(storage_choice, "EXACT_MAX_PRODUCT", 0)
    monkeypatch.setattr(storage_choice, "AUTO_SAMPLE_MARGIN", 1e4)  # the sample accepts too few slots
    _, plan = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    assert plan.storage == 'EXACT' and plan.slot_count == len(vertices)
    # Sparse storage is tried first: its sample accepted 4 pairs.
    assert plan.storage_choice.startswith("Automatic: exact (sparse, 4 pairs deviated ")
    assert plan.storage_choice.endswith(" on the whole mesh)")


def test_progress_rises_to_one_and_a_cancel_stops_the_plan(monkeypatch, irregular):
    vertices, faces, points = irregular
    monkeypatch.setattr(figures, "CHUNK_ENTRIES", 6000)  # 100 points a chunk
    calls = []
    steps = plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1,
                                                           run=lambda compute, workers: calls.append(1)
                                                           or compute(workers)))
    fractions = [next(steps) for _ in range(3)]
    assert fractions == pytest.approx([100 / 900, 200 / 900, 300 / 900])
    steps.close()
    assert len(calls) == 3  # nothing computed after the cancel
    fractions, _ = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    assert len(fractions) == 9 and fractions == sorted(fractions) and fractions[-1] == 1.0


def test_points_outside_raise_the_cores_error_and_project_counts_them(irregular):
    vertices, faces, points = irregular
    outside = np.vstack([points, 3.0 * vertices[:2]])
    with pytest.raises(gencoords.OutsideCageError):
        run(plan_bind(outside, vertices, faces, BindRequest("mean_value", workers=1)))
    _, plan = run(plan_bind(outside, vertices, faces, BindRequest("mean_value", outside="project", workers=1)))
    assert plan.points_outside == 2


def test_linear_precision_is_measured_on_the_stored_coordinates_and_refused_beyond(monkeypatch, irregular):
    vertices, faces, points = irregular
    request = BindRequest("power", gamma=-4.0, workers=1)
    _, plan = run(plan_bind(points, vertices, faces, request))
    assert plan.linear_precision == pytest.approx(
        gencoords.reports.linear_precision(plan.slots, vertices, points), rel=1e-12)
    assert 0.0 < plan.linear_precision < 1e-5  # float32 rounding alone
    monkeypatch.setattr(bind_plan, "LINEAR_PRECISION", plan.linear_precision / 2)
    with pytest.raises(bind_plan.ImpreciseCoordinatesError) as refused:
        run(plan_bind(points, vertices, faces, request))
    assert refused.value.problem == "placing"
    assert refused.value.error == plan.linear_precision and refused.value.min_coordinate == plan.min_coordinate


def test_sums_are_measured_as_stored_and_sparse_pairs_that_miss_1_are_refused():
    """Power coordinates with gamma -16 weigh this point of a 4-unit cube by up to 7,900
    (|w| summing to 31,000): in float32 they sum to 1 only to 1.5e-4, over
    TRANSLATION_PRECISION. Exact storage refuses them for their placing; sparse storage
    keeping all 8 pairs checks no placing, but a translated cage would leave the point
    behind: refused too. Gamma -8 stores fine, its figure the float32 sums' own."""
    vertices, quads = gencoords.cages.shapes.block_cage(np.ones((1, 1, 1), dtype=bool), size=4.0)
    vertices = vertices - vertices.mean(axis=0)
    faces = gencoords.cages.triangulate_quads(vertices, quads)
    point = np.array([[0.8663953216799689, 0.5176191592443049, 0.5082488492236183]])
    request = BindRequest("power", gamma=-16.0, storage='SPARSE', sparse_size=8, workers=1)
    with pytest.raises(bind_plan.ImpreciseCoordinatesError) as refused:
        run(plan_bind(point, vertices, faces, request))
    exact = gencoords.coordinates(point, vertices, faces, kind="power", gamma=-16.0, workers=1)
    rounding = 0.5 * np.finfo(np.float32).eps * np.abs(exact).sum()  # the float32 sum's bound
    assert refused.value.problem == "sums" and bind_plan.TRANSLATION_PRECISION < refused.value.error <= rounding
    assert refused.value.largest == pytest.approx(np.abs(exact).max(), rel=1e-6)  # all 8 kept
    _, plan = run(plan_bind(point, vertices, faces, BindRequest("power", gamma=-8.0, workers=1)))
    assert plan.max_affine_error == abs(plan.slots.astype(np.float64).sum() - 1.0) < 1e-6



def test_sizes_that_multiply_the_cages_rounding_into_a_jitter_are_refused_by_the_origins_distance():
    """Power coordinates with gamma -16 weigh this point of a 4-unit cube with sizes adding
    up to 620: float32 rounding of the cage's positions, half an epsilon of their distance
    from where they are measured, moves the point by up to that many roundings. Near the
    origin that is 1e-5 of the cage's size; measured from 40 units away, 2e-4, over
    TRANSLATION_PRECISION: refused, as stored sums that pass. Gamma -8's sizes add up to
    4.5, a few roundings as any deformer's, and mean value's to 1: bound from anywhere."""
    vertices, quads = gencoords.cages.shapes.block_cage(np.ones((1, 1, 1), dtype=bool), size=4.0)
    vertices = vertices - vertices.mean(axis=0)
    faces = gencoords.cages.triangulate_quads(vertices, quads)
    point = np.array([[0.8763953216799689, 0.5176191592443049, 0.5082488492236183]])
    request = BindRequest("power", gamma=-16.0, storage='SPARSE', sparse_size=8, workers=1)
    _, plan = run(plan_bind(point, vertices, faces, request))
    sizes = np.abs(plan.slots.astype(np.float64)).sum()
    assert 600 < sizes < 640 and plan.max_affine_error < bind_plan.TRANSLATION_PRECISION
    far = np.array([[-40.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # the mesh's origin, the cage's
    with pytest.raises(bind_plan.ImpreciseCoordinatesError) as refused:
        run(plan_bind(point, vertices, faces, replace(request, origins=far)))
    jitter = sizes * 0.5 * np.finfo(np.float32).eps * 42.0 / np.linalg.norm(np.ptp(vertices, axis=0))
    assert refused.value.problem == "rounding" and refused.value.error == pytest.approx(jitter, rel=1e-6)
    assert refused.value.largest == pytest.approx(sizes, rel=1e-6) and jitter > bind_plan.TRANSLATION_PRECISION
    assert refused.value.distance == pytest.approx(42.0 / np.linalg.norm(np.ptp(vertices, axis=0)))
    farther = np.array([[-1e5, 0.0, 0.0]])  # even one rounding is 4e-4 of the cage's size there
    for kind, gamma in (("power", -8.0), ("mean_value", None)):
        _, plan = run(plan_bind(point, vertices, faces, replace(request, kind=kind, gamma=gamma, origins=farther)))
        assert 0.99 < np.abs(plan.slots.astype(np.float64)).sum() <= bind_plan.ROUNDING_AMPLIFICATION

def solved_counts(monkeypatch):
    """The number of points of every ``solve_points`` call of the plans that follow."""
    counts, solve = [], figures.solve_points
    monkeypatch.setattr(figures, "solve_points", lambda request, cage, points, *args, **kwargs: counts.append(
        len(points)) or solve(request, cage, points, *args, **kwargs))
    return counts


def test_automatic_estimates_on_a_few_points_and_measures_nothing_it_would_throw_away(monkeypatch, irregular):
    """An irregular cage where compact storage saves nothing: the few points' estimate
    decides exact, the larger sample is never computed, and measuring it would have
    decided the same (deviations are maxima over points: the few bound the many)."""
    vertices, faces, points = irregular
    monkeypatch.setattr(storage_choice, "EXACT_MAX_PRODUCT", 0)
    monkeypatch.setattr(bind_plan, "ESTIMATE_SAMPLES", 100)
    counts = solved_counts(monkeypatch)
    _, plan = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    assert plan.storage == 'EXACT' and plan.slot_count == len(vertices)
    assert plan.storage_choice == "Automatic: exact (compact would need more than 30 of the 60 slots for 1e-3)"
    assert counts == [100, len(points)]  # the estimate's points, then the slots: no sample measured
    exact = gencoords.coordinates(points, vertices, faces)
    request = BindRequest("mean_value", workers=1)
    measured = bind_plan.choose_by_measuring(request, exact, vertices, faces, len(points))
    assert measured.storage == 'EXACT' and measured.reason == plan.storage_choice
    # The estimate is a lower bound: compact with half the slots misses on the few points
    # by no more than on all of them.
    basis = compact.motion_basis(vertices, faces, 30)
    few = deviations.residual_deviations(exact[::9] - exact[::9] @ basis @ basis.T, vertices)
    every = deviations.residual_deviations(exact - exact @ basis @ basis.T, vertices)
    assert few[0] <= every[0] and few[1].max() <= every[1].max()
    assert max(few[0], few[1].max()) >= bind_plan.AUTO_DEVIATION * storage_choice.AUTO_SAMPLE_MARGIN


def test_automatic_measures_where_the_estimate_allows_compact_and_bisects_to_the_fewest_slots(monkeypatch):
    monkeypatch.setattr(storage_choice, "EXACT_MAX_PRODUCT", 0)
    vertices, faces = icosphere(3)  # smooth: few slots reproduce the coordinates
    rng = np.random.default_rng(3)
    points = 0.6 * rng.uniform(-1.0, 1.0, (3000, 3)) / np.sqrt(3.0)
    counts = solved_counts(monkeypatch)
    _, plan = run(plan_bind(points, vertices, faces, BindRequest("mean_value", workers=1)))
    step = len(points) // bind_plan.ESTIMATE_SAMPLES
    assert counts[:2] == [len(points[::step]), len(points[::len(points) // bind_plan.DEVIATION_SAMPLES])]
    assert plan.storage == 'COMPACT'
    # The bisection finds what trying every size finds.
    exact = gencoords.coordinates(points[::len(points) // bind_plan.DEVIATION_SAMPLES], vertices, faces)
    sizes = list(range(6, len(vertices) // 2 + 1, 3))
    basis = compact.motion_basis(vertices, faces, sizes[-1])
    fewest, _, _ = compact.smallest_size(exact, basis, vertices,
                                         bind_plan.AUTO_DEVIATION * storage_choice.AUTO_SAMPLE_MARGIN, sizes)
    assert plan.slot_count == fewest < len(vertices) // 2


def test_automatic_picks_sparse_with_the_fewest_pairs_under_the_target(monkeypatch):
    monkeypatch.setattr(storage_choice, "EXACT_MAX_PRODUCT", 0)
    vertices, faces = gencoords.cages.shapes.octahedron((1.0, 1.2, 1.5))  # 6 vertices
    points = random_interior_points(np.random.default_rng(6), vertices, 400)
    request = BindRequest("mean_value", compact_size=4, workers=1)
    _, plan = run(plan_bind(points, vertices, faces, request))
    # 4 of 6 pairs miss the target, 8 (all 6) keep it: the deviation is float32 rounding.
    assert (plan.storage, plan.slot_count) == ('SPARSE', 6)
    assert plan.storage_choice.startswith("Automatic: sparse, 6 pairs (deviation ")
    np.testing.assert_allclose(sparse.dense_weights(plan.indices, plan.slots, 6),
                               gencoords.coordinates(points, vertices, faces), atol=1e-7)


def test_sparse_plan_keeps_the_largest_pairs_and_measures_them(irregular):
    vertices, faces, points = irregular
    request = BindRequest("wachspress", storage='SPARSE', sparse_size=8, workers=1)
    _, plan = run(plan_bind(points, vertices, faces, request))
    exact = gencoords.coordinates(points, vertices, faces, kind="wachspress")
    indices, weights = sparse.placed_pairs(exact, 8, vertices)
    assert plan.storage == 'SPARSE' and plan.storage_choice == "Sparse: each vertex's 8 largest coordinates"
    np.testing.assert_array_equal(plan.indices, indices)
    np.testing.assert_array_equal(plan.slots, weights.astype(np.float32))
    smooth, drag, vertex = pair_deviations.deviations(exact, indices, weights.astype(np.float32), vertices)
    assert (plan.deviation_smooth, plan.deviation_drag) == pytest.approx((smooth, drag), rel=1e-9)
    assert plan.deviation_drag_vertex == vertex and drag > 1e-4  # 8 of 60: not exact, and said so
    assert bind_plan.plan_bytes(plan) == len(points) * 8 * 8


def test_harmonic_plans_two_levels_by_default_positive_and_local():
    from tests.fixtures import character
    cage_vertices, quads = character.character_cage()
    triangles = gencoords.cages.triangulate_quads(cage_vertices, quads)
    points, _, labels = character.body_mesh(0.2)
    request = BindRequest("harmonic", resolution=24, workers=1)
    fractions, plan = run(plan_bind(points, cage_vertices, triangles, request))
    assert plan.storage == 'SPARSE' and plan.slot_count == CORNER_COUNT and 0 < plan.node_count <= len(points)
    assert plan.storage_choice.startswith("Automatic: sparse in two levels")
    assert max(plan.deviation_smooth, plan.deviation_drag) < bind_plan.AUTO_DEVIATION
    assert (plan.node_weights >= 0).all() and (plan.slots >= 0).all() and plan.negative_points == 0
    coordinates = sparse.layout_coordinates(plan.indices, plan.slots, len(cage_vertices),
                                            (plan.node_indices, plan.node_weights))
    np.testing.assert_allclose(coordinates.sum(axis=1), 1.0, atol=1e-6)
    # Linear precision: the stored pairs place every point (float32 rounding only).
    diagonal = np.linalg.norm(np.ptp(cage_vertices, axis=0))
    assert np.linalg.norm(coordinates @ cage_vertices - points, axis=1).max() < 1e-6 * diagonal
    assert plan.linear_precision < 1e-6
    # The left hand's cage vertices weigh nothing in the other limbs (locality).
    hand = character.cage_limb_vertices(cage_vertices, "left_arm")
    others = np.isin(labels, ("right_arm", "left_leg", "right_leg", "head"))
    assert coordinates[np.ix_(others, hand)].max() < 1e-5
    assert fractions[-1] in (0.5, 1.0) and fractions == sorted(fractions)  # the solve's progress, then the layout


def test_automatic_keeps_every_pair_at_few_nodes_where_harmonic_coordinates_are_not_local():
    """A sphere of 39,600 points deep in a 162-vertex icosphere: its 1,180 grid nodes weigh
    most of the cage, 128 pairs each deviate 3e-3 (over the target); all 162 fit in 2
    stored columns (132 slots a column), and Automatic keeps them, deviating by float32
    rounding alone."""
    vertices, faces = icosphere(2, radius=2.0)
    theta, phi = np.meshgrid(np.linspace(0, np.pi, 200)[1:-1], np.linspace(0, 2 * np.pi, 200, endpoint=False))
    points = 1.4 * np.column_stack([(np.sin(theta) * np.cos(phi)).ravel(), (np.sin(theta) * np.sin(phi)).ravel(),
                                    np.cos(theta).ravel()])
    _, plan = run(plan_bind(points, vertices, faces, BindRequest("harmonic", resolution=16, workers=1)))
    assert plan.storage == 'SPARSE' and plan.node_weights.shape[1] == len(vertices) == 162
    assert max(plan.deviation_smooth, plan.deviation_drag) < 1e-6
    vectors, per_column = -(-len(vertices) // 3), len(points) // plan.node_count  # three pairs a vector
    assert plan.node_count < len(points) // 30 and -(-vectors // per_column) == 2 <= two_level.NODE_COLUMN_BUDGET
    counts = two_level.automatic_node_slot_counts(len(points), plan.node_count, len(vertices))
    assert counts[-2] < 162 == counts[-1]  # tried first, the fewer pairs missed the target


def test_the_harmonic_solve_reports_progress_and_closing_the_plan_stops_it(monkeypatch):
    """The solve runs beside the plan's generator, which yields its progress meanwhile (a
    modal Bind's progress bar and Esc); closing the generator (Esc) ends it."""
    import threading

    monkeypatch.setattr(bind_plan, "POLL_SECONDS", 0.005)
    vertices, faces = icosphere(1)
    points = 0.5 * vertices[:20]
    request = BindRequest("harmonic", resolution=32, workers=1)
    # A grid this small is solved inline: no thread (its memory stays in the caller's arena).
    def no_thread(*args, **kwargs):
        raise AssertionError("a thread for a short solve")

    with monkeypatch.context() as patch:
        patch.setattr(bind_plan.threading, "Thread", no_thread)
        assert run(plan_bind(points, vertices, faces, request))[1].linear_precision < 1e-6
    monkeypatch.setattr(bind_plan, "INLINE_FIELD_PAIRS", 0)  # from here it counts as long
    # Freed memory is handed back before the thread starts and after it ends (its arena's).
    released = []
    monkeypatch.setattr(bind_plan, "release_freed_memory", lambda: released.append(
        any(thread.name == "gencoords-bind" for thread in threading.enumerate())))
    fractions, plan = run(plan_bind(points, vertices, faces, request))
    during = [f for f in fractions if 0.0 < f < 0.5]
    assert len(during) >= 2 and during == sorted(during) and plan.linear_precision < 1e-6
    assert released == [False, False]
    steps = plan_bind(points, vertices, faces, request)
    while next(steps) == 0.0:  # until the solve has begun reporting
        pass
    steps.close()
    assert not any(thread.name == "gencoords-bind" for thread in threading.enumerate())
    assert released == [False, False] * 2  # a cancel too
    # A failure in the solve reaches the caller.
    def failing(*args, **kwargs):
        raise gencoords.CageError("bad_faces", "a failure in the solve")

    monkeypatch.setattr(bind_plan, "harmonic_field", failing)
    with pytest.raises(gencoords.CageError, match="a failure in the solve"):
        run(plan_bind(points, vertices, faces, request))


@pytest.mark.parametrize("kind", ["mean_value", "harmonic", "green"])
def test_points_outside_are_refused_on_the_plans_first_step_before_any_coordinates(monkeypatch, kind):
    """Issue 37 item 12: Harmonic refused 499 outside points of 28k after 8.5 s of an 11.1 s
    Bind (the field solved first), mean value after most chunks. The first step refuses
    them, naming every one, with the coordinates and the field never computed."""
    vertices, faces = icosphere(2)
    rng = np.random.default_rng(5)
    points = 0.8 * vertices[rng.integers(0, len(vertices), 2000)] * rng.uniform(0.0, 1.0, (2000, 1))
    outside = np.sort(rng.choice(len(points), 7, replace=False))
    points[outside] = 1.5 * vertices[:7]

    def never(*args, **kwargs):
        raise AssertionError("coordinates computed before the refusal")

    for name in ("coordinates", "green_coordinates"):
        monkeypatch.setattr(gencoords.Cage, name, never)
    monkeypatch.setattr(bind_plan, "harmonic_field", never)
    steps = plan_bind(points, vertices, faces, BindRequest(kind, workers=1))
    with pytest.raises(gencoords.OutsideCageError) as error:
        next(steps)
    np.testing.assert_array_equal(error.value.indices, outside)
    assert ("Green coordinates do not extrapolate" in str(error.value)) == (kind == "green")
