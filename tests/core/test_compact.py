"""Compact coordinates' deviation figures: the per-vertex drag formula against dragging
each cage vertex, and the slot count Automatic storage picks."""

import numpy as np
import pytest

import gencoords
from gencoords.storage import compact, deviations
from gencoords.cages.shapes import icosphere
from tests.fixtures.polytopes import random_convex_polytope, random_interior_points


@pytest.fixture(scope="module")
def irregular():
    """An irregular 40-vertex cage, 300 points inside it, their exact coordinates and the
    cage's full motion basis."""
    rng = np.random.default_rng(19)
    vertices, faces = random_convex_polytope(rng, 3, 40)
    points = random_interior_points(rng, vertices, 300)
    coordinates = gencoords.coordinates(points, vertices, faces)
    return vertices, coordinates, compact.motion_basis(vertices, faces, len(vertices))


@pytest.mark.parametrize("size", [4, 12, 24])
def test_residual_deviations_equal_moving_the_cage(irregular, size):
    vertices, coordinates, full = irregular
    basis = full[:, :size]
    slots = (coordinates @ basis).astype(np.float32)  # stored as float32
    residual = coordinates - slots @ basis.T
    smooth, drag = deviations.residual_deviations(residual, vertices)
    assert smooth == pytest.approx(deviations.deviation(
        coordinates, slots, basis, vertices, deviations.smooth_test_motion(vertices)), rel=1e-9)
    dragged = [deviations.deviation(coordinates, slots, basis, vertices,
                                 deviations.vertex_drag_motion(vertices, j))
               for j in range(len(vertices))]
    np.testing.assert_allclose(drag, dragged, rtol=1e-9)
    assert drag.max() > 1e-3  # a sharp drag deviates on this cage: the test can fail


def test_smallest_size_is_the_first_candidate_under_the_target(irregular):
    vertices, coordinates, full = irregular
    sizes = list(range(6, 40, 3))

    def both(size):
        residual = coordinates - coordinates @ full[:, :size] @ full[:, :size].T
        smooth, drag = deviations.residual_deviations(residual, vertices)
        return smooth, drag.max()

    target = 0.5 * max(both(24))  # reachable, but not with the first candidates
    size, smooth, drag = compact.smallest_size(coordinates, full, vertices, target, sizes)
    assert size is not None and size > sizes[0]
    assert (smooth, drag) == pytest.approx(both(size), rel=1e-9)
    assert max(smooth, drag) < target
    assert max(both(sizes[sizes.index(size) - 1])) >= target
    missed, smooth, drag = compact.smallest_size(coordinates, full, vertices, 1e-12, sizes)
    assert missed is None and (smooth, drag) == pytest.approx(both(sizes[-1]), rel=1e-9)


def test_an_affine_basis_reproduces_affine_motions_exactly(irregular):
    vertices, coordinates, full = irregular
    basis = full[:, :4]
    rng = np.random.default_rng(1)
    moved = vertices @ (np.eye(3) + 0.3 * rng.normal(size=(3, 3))).T + rng.normal(size=3)
    assert deviations.deviation(coordinates, coordinates @ basis, basis, vertices, moved) < 1e-12


def test_green_compact_follows_similarities_and_measures_the_worst_drag_exactly():
    from gencoords.construction.green_deform import green_displacements
    vertices, faces = icosphere(2)
    points = np.random.default_rng(0).uniform(-0.45, 0.45, (1500, 3))
    phi, psi = gencoords.green_coordinates(points, vertices, faces)
    rows = np.hstack([phi, psi])
    basis = compact.green_motion_basis(vertices, faces, 24)
    residual = rows - (rows @ basis) @ basis.T
    rotation, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    rotation *= np.sign(np.linalg.det(rotation))
    similarity = green_displacements(vertices, 1.3 * vertices @ rotation.T + [0.2, -0.1, 0.3], faces)
    assert np.abs(residual @ similarity).max() < 1e-12  # the first 8 columns span them
    smooth, drag = deviations.residual_deviations(residual, vertices, faces=faces)
    diagonal = np.linalg.norm(np.ptp(vertices, axis=0))
    brute = np.array([np.linalg.norm(residual @ green_displacements(vertices, deviations.vertex_drag_motion(vertices, j),
                                                                     faces), axis=1).max()
                      for j in range(len(vertices))]) / diagonal
    assert drag.max() == pytest.approx(brute.max(), rel=1e-12) and drag.argmax() == brute.argmax()
    assert (drag >= brute * (1 - 1e-12)).all()  # the others: exact, or upper bounds below the worst
    moved = deviations.smooth_test_motion(vertices)
    expected = np.linalg.norm(residual @ green_displacements(vertices, moved, faces), axis=1).max() / diagonal
    assert smooth == pytest.approx(expected, rel=1e-12) and smooth > 0.0
