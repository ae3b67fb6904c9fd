"""Compact coordinates' deviation figures: the per-vertex drag formula against dragging
each cage vertex, and the slot count Automatic storage picks."""

import numpy as np
import pytest

import gencoords
from gencoords.tools import compact
from polytopes import random_convex_polytope, random_interior_points


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
    smooth, drag = compact.residual_deviations(residual, vertices)
    assert smooth == pytest.approx(compact.deviation(
        coordinates, slots, basis, vertices, compact.smooth_test_motion(vertices)), rel=1e-9)
    dragged = [compact.deviation(coordinates, slots, basis, vertices,
                                 compact.vertex_drag_motion(vertices, j))
               for j in range(len(vertices))]
    np.testing.assert_allclose(drag, dragged, rtol=1e-9)
    assert drag.max() > 1e-3  # a sharp drag deviates on this cage: the test can fail


def test_smallest_size_is_the_first_candidate_under_the_target(irregular):
    vertices, coordinates, full = irregular
    sizes = list(range(6, 40, 3))

    def both(size):
        residual = coordinates - coordinates @ full[:, :size] @ full[:, :size].T
        smooth, drag = compact.residual_deviations(residual, vertices)
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
    assert compact.deviation(coordinates, coordinates @ basis, basis, vertices, moved) < 1e-12
