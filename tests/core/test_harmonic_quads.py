"""Harmonic coordinates on quad cages (gencoords.harmonic_quad_field, issue 36): each quad
its bilinear patch, so the field does not depend on which corner a quad lists first."""

import numpy as np
import pytest

import gencoords
from gencoords.construction.quad_cage import fan_split
from gencoords.construction.quad_integrals import bilinear_hats
from gencoords.harmonic.boundary_values import nearest_boundary_points, segment_crossings
from gencoords.cages.shapes import block_cage

RESOLUTION = 14


def _bent_box(seed=0, bend=0.15):
    """Two unit cubes in a row, corners moved: ten non-planar quads, (12, 3), (10, 4)."""
    vertices, quads = block_cage(np.ones((2, 1, 1), dtype=bool))
    return vertices + np.random.default_rng(seed).uniform(-bend, bend, vertices.shape), np.asarray(quads)


def _inside(vertices, count=60, seed=1):
    mix = np.random.default_rng(seed).dirichlet(np.ones(len(vertices)), count)
    centre = vertices.mean(axis=0)
    return centre + 0.6 * (mix @ vertices - centre)


@pytest.fixture(scope="module")
def box():
    vertices, quads = _bent_box()
    fields = [gencoords.harmonic_quad_field(vertices, np.roll(quads, -shift, axis=1), resolution=RESOLUTION,
                                            workers=1) for shift in (0, 1)]
    return vertices, quads, fields


def test_the_field_does_not_depend_on_each_quads_first_corner(box):
    vertices, quads, (first, relabelled) = box
    assert first.node_coordinates.shape == relabelled.node_coordinates.shape
    assert np.abs(first.node_coordinates - relabelled.node_coordinates).max() <= 1e-10
    points = _inside(vertices)
    assert np.abs(first.coordinates(points) - relabelled.coordinates(points)).max() <= 1e-10


def test_the_triangle_split_does_depend_on_it(box):  # what the quads' patches are for
    vertices, quads, _ = box
    points = _inside(vertices)
    split = [gencoords.harmonic_field(vertices, fan_split(np.roll(quads, -shift, axis=1))[0],
                                      resolution=RESOLUTION, workers=1).coordinates(points) for shift in (0, 1)]
    assert np.abs(split[0] - split[1]).max() > 1e-2


def test_non_negative_partition_of_unity_and_placement(box):
    vertices, _, (field, _) = box
    assert field.node_coordinates.min() >= 0.0
    np.testing.assert_allclose(field.node_coordinates.sum(axis=1), 1.0, atol=1e-12)
    points = _inside(vertices)
    rows = field.coordinates(points)
    assert rows.min() >= 0.0
    np.testing.assert_allclose(rows.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(rows @ vertices, points, atol=1e-10)


def _patch_points(vertices, quads, seed=2):
    """A point on each quad's patch at random (u, v): (points (q, 3), hats (q, 4))."""
    u, v = np.random.default_rng(seed).uniform(0.05, 0.95, (2, len(quads)))
    hats = bilinear_hats(u, v)
    return np.einsum("qi,qiN->qN", hats, vertices[quads]), hats


def test_on_a_quad_the_boundary_values_are_its_bilinear_hats(box):
    vertices, quads, _ = box
    points, hats = _patch_points(vertices, quads)
    for shift in (0, 1):  # listed from another corner: the same hats, moved with the corners
        polygons = np.roll(quads, -shift, axis=1)
        columns, values, distance = nearest_boundary_points(points, vertices, polygons, 0.1)
        np.testing.assert_array_equal(columns, polygons)
        np.testing.assert_allclose(values, np.roll(hats, -shift, axis=1), atol=1e-12)
        assert distance.max() <= 1e-12
        # A segment through the patch point (a grid edge) crosses it there.
        steps = np.tile([0.0, 0.0, 0.2], (len(points), 1)) + 0.05 * np.random.default_rng(3).normal(
            size=points.shape)
        fraction, columns, values = segment_crossings(points - 0.5 * steps, steps, vertices, polygons)
        np.testing.assert_allclose(fraction, 0.5, atol=1e-12)
        np.testing.assert_array_equal(columns, polygons)
        np.testing.assert_allclose(values, np.roll(hats, -shift, axis=1), atol=1e-12)


def test_a_point_between_a_quads_split_and_its_patch_is_where_the_patch_puts_it(box):
    vertices, quads, fields = box
    corners = vertices[quads]
    twist = corners[:, 0] - corners[:, 1] + corners[:, 2] - corners[:, 3]
    bent = int(np.argmax(np.linalg.norm(twist, axis=1)))
    centre = corners[bent].mean(axis=0)  # the patch's centre, |twist| / 4 from either diagonal
    inward = vertices.mean(axis=0) - centre
    inward *= 0.08 * np.linalg.norm(twist[bent]) / np.linalg.norm(inward)
    for field in fields:  # just inside the patch: its coordinates; just outside: refused
        assert field.coordinates([centre + inward]).min() >= 0.0
        with pytest.raises(gencoords.OutsideCageError):
            field.coordinates([centre - inward])
    split = [gencoords.harmonic_field(vertices, fan_split(np.roll(quads, -shift, axis=1))[0], resolution=8,
                                      workers=1) for shift in (0, 1)]
    refused = []
    for field in split:  # the two splits disagree on one of them: the test's points are in a sliver
        for point in (centre + inward, centre - inward):
            try:
                field.coordinates([point])
                refused.append(False)
            except gencoords.OutsideCageError:
                refused.append(True)
    assert refused[:2] != refused[2:]


def test_a_triangle_cage_gives_the_same_field_as_polygons():
    vertices, quads = _bent_box(seed=4)
    triangles = fan_split(quads)[0]
    as_triangles = gencoords.harmonic_field(vertices, triangles, resolution=10, workers=1)
    as_polygons = gencoords.harmonic_quad_field(vertices, triangles.tolist(), resolution=10, workers=1)
    np.testing.assert_array_equal(as_polygons.node_coordinates, as_triangles.node_coordinates)


def test_a_folded_quad_is_refused_naming_it():
    vertices, quads = _bent_box()
    top = int(np.flatnonzero((vertices[quads, 2] > 0.5).all(axis=1))[0])
    vertices = vertices.copy()
    a, _, c, _ = quads[top]
    vertices[a] = vertices[c] + 1.5 * (vertices[c] - vertices[a])  # across the opposite diagonal
    with pytest.raises(gencoords.CageError, match=rf"quad {top} folds over itself|polygons: \[.*{top}"):
        gencoords.harmonic_quad_field(vertices, quads, resolution=8, workers=1)


def test_the_nearest_patch_parameters_stop_stepping_only_at_a_fixed_point():
    """Points whose Gauss-Newton step leaves (u, v) as they were step no more (the
    boundary values' largest part on the hand): the parameters are bit for bit those of
    every point taking every step, and they place points on their patch."""
    from gencoords.construction import quad_cage

    vertices, quads = _bent_box(seed=3, bend=0.3)
    rng = np.random.default_rng(4)
    faces = rng.integers(0, len(quads), 3000)
    corners = vertices[quads[faces]]
    hats = bilinear_hats(*rng.uniform(0.0, 1.0, (2, 3000)))
    on = np.einsum("pi,pij->pj", hats, corners)
    points = on + rng.normal(0.0, 0.2, on.shape) * (np.arange(3000) % 2)[:, None]  # half on their patch
    u, v = np.full(3000, 0.5), np.full(3000, 0.5)
    c0, c1, c2, c3 = (corners[:, i] for i in range(4))
    for _ in range(quad_cage._NEWTON_STEPS):  # every point every step, as before
        du = (1 - v)[:, None] * (c1 - c0) + v[:, None] * (c2 - c3)
        dv = (1 - u)[:, None] * (c3 - c0) + u[:, None] * (c2 - c1)
        miss = points - np.einsum("pi,pij->pj", bilinear_hats(u, v), corners)
        uu, uv, vv = np.einsum("pN,pN->p", du, du), np.einsum("pN,pN->p", du, dv), np.einsum("pN,pN->p", dv, dv)
        along_u, along_v = np.einsum("pN,pN->p", du, miss), np.einsum("pN,pN->p", dv, miss)
        determinant = uu * vv - uv * uv
        inverse = np.where(determinant > 0.0, 1.0 / np.where(determinant > 0.0, determinant, 1.0), 0.0)
        u = np.clip(u + (vv * along_u - uv * along_v) * inverse, 0.0, 1.0)
        v = np.clip(v + (uu * along_v - uv * along_u) * inverse, 0.0, 1.0)
    parameters, distance = quad_cage.bilinear_parameters(points, corners)
    np.testing.assert_array_equal(parameters, np.stack([u, v], axis=1))
    assert distance[::2].max() < 1e-12 * np.ptp(vertices)


def _sliver_point(vertices, quads):
    """A point between the most bent quad's patch and one of its splits, outside the
    patch: (3,) float."""
    corners = vertices[quads]
    twist = corners[:, 0] - corners[:, 1] + corners[:, 2] - corners[:, 3]
    bent = int(np.argmax(np.linalg.norm(twist, axis=1)))
    centre = corners[bent].mean(axis=0)
    inward = vertices.mean(axis=0) - centre
    return centre - inward * 0.08 * np.linalg.norm(twist[bent]) / np.linalg.norm(inward)


def test_points_known_inside_are_located_the_same(box):
    """``sparse_rows(inside=...)``: the points a winding test on the quads' triangles found
    inside are not tested again away from the quads' boxes, and the rows are bit for bit
    those found without; a point between a split and the patch is refused all the same."""
    vertices, quads, (field, _) = box
    points = _inside(vertices, count=200)
    inside = np.ones(len(points), dtype=bool)
    for got, expected in zip(field.sparse_rows(points, inside=inside), field.sparse_rows(points + 0.0)):
        np.testing.assert_array_equal(got, expected)
    with_sliver = np.vstack([points, _sliver_point(vertices, quads)])
    with pytest.raises(gencoords.OutsideCageError) as refused:
        field.sparse_rows(with_sliver, inside=np.ones(len(with_sliver), dtype=bool))
    assert list(refused.value.indices) == [len(points)]
    for wrong in (inside[:-1], inside.astype(np.int8), list(inside)):
        with pytest.raises(ValueError, match=r"inside must be a numpy bool array of shape \(200,\)"):
            field.sparse_rows(points, inside=wrong)


def test_a_bind_refuses_a_point_outside_the_patches_whatever_the_cages_triangles():
    """The Bind's refusal tests the cage's triangles; the field, told which points that
    found inside, still tests those in a quad's box against its patch: a point inside
    one split but outside the patch is refused with either split as the cage's triangles."""
    from gencoords.planning.bind_plan import plan_bind
    from gencoords.planning.request import BindRequest

    vertices, quads = _bent_box()
    points = np.vstack([_inside(vertices, count=40), _sliver_point(vertices, quads)])
    passed_the_refusal = []
    for shift in (0, 1):
        triangles = fan_split(np.roll(quads, -shift, axis=1))[0]
        passed_the_refusal.append(len(gencoords.Cage(vertices, triangles).outside_points(points)) == 0)
        steps = plan_bind(points, vertices, triangles, BindRequest("harmonic", polygons=quads, resolution=8,
                                                                   workers=1))
        with pytest.raises(gencoords.OutsideCageError) as refused:
            list(steps)
        assert list(refused.value.indices) == [len(points) - 1]
    assert passed_the_refusal.count(True) == 1  # one split holds the point: the field refuses it
