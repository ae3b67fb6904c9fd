"""Harmonic coordinates as a kind of the public API: ``gencoords.coordinates(...,
kind="harmonic")``, ``Cage.coordinates`` and ``weights`` take them with the other kinds'
arguments (``resolution`` the grid's), and give what ``harmonic_coordinates`` gives."""

import numpy as np
import pytest

import gencoords
from gencoords.cages.shapes import icosphere, octahedron
from gencoords.surfaces.named import HARMONIC

RESOLUTION = 16
# A turn about (1, 2, 3): no cage face parallel to the grid's.
TURN = np.linalg.qr(np.array([[1.0, 2.0, 3.0], [-2.0, 1.0, 0.5], [0.3, -1.0, 1.0]]).T)[0]


@pytest.fixture(scope="module")
def cage_and_points():
    """An icosphere (its faces at least 0.9 from its centre), turned, scaled and moved, and
    points inside it, some in cells at the cage."""
    vertices, faces = icosphere(1)
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(300, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points = directions * 0.88 * rng.uniform(0.0, 1.0, size=(300, 1)) ** (1 / 3)
    move = [3.0, -1.0, 0.5]
    return vertices @ TURN * 2.0 + move, faces, points @ TURN * 2.0 + move


@pytest.fixture(scope="module")
def harmonic(cage_and_points):
    vertices, faces, points = cage_and_points
    return gencoords.coordinates(points, vertices, faces, kind="harmonic", resolution=RESOLUTION)


def test_the_kind_is_named_once_in_the_kinds_table():
    assert HARMONIC == "harmonic" and HARMONIC not in gencoords.advanced.KINDS  # no generating surface
    assert not gencoords.needs_convex(HARMONIC)


def test_a_partition_of_unity_never_negative(harmonic):
    np.testing.assert_allclose(harmonic.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert harmonic.min() >= 0.0


def test_linear_precision_within_what_the_grid_gives(cage_and_points, harmonic):
    vertices, _, points = cage_and_points
    diagonal = np.linalg.norm(np.ptp(vertices, axis=0))
    assert np.linalg.norm(harmonic @ vertices - points, axis=1).max() < 1e-9 * diagonal


def test_the_same_as_harmonic_coordinates_and_in_a_cage_kept(cage_and_points, harmonic):
    vertices, faces, points = cage_and_points
    direct = gencoords.harmonic_coordinates(points, vertices, faces, resolution=RESOLUTION)
    np.testing.assert_array_equal(harmonic, direct)
    with gencoords.Cage(vertices, faces) as cage:
        np.testing.assert_array_equal(cage.coordinates(points, kind="harmonic", resolution=RESOLUTION), direct)
        field = cage._fields[RESOLUTION]
        locations = np.empty(len(points), dtype=np.int8)
        half = cage.coordinates(points[:50], kind="harmonic", resolution=RESOLUTION, dtype=np.float32,
                                locations=locations[:50])
        assert cage._fields[RESOLUTION] is field  # solved once
        assert half.dtype == np.float32 and (locations[:50] == gencoords.INSIDE).all()
        np.testing.assert_array_equal(cage.weights(points[:50], kind="harmonic", resolution=RESOLUTION),
                                      direct[:50])


def test_the_default_resolution_is_harmonic_fields_and_weights_are_the_coordinates(monkeypatch):
    monkeypatch.setattr(gencoords.harmonic.field, "DEFAULT_RESOLUTION", 8)  # read where it is used
    vertices, faces = octahedron()
    point = [[0.1, 0.2, -0.1]]
    with gencoords.Cage(vertices, faces) as cage:
        coordinates = cage.coordinates(point, kind="harmonic")
        assert list(cage._fields) == [8]
    np.testing.assert_array_equal(coordinates, gencoords.harmonic_coordinates(point, vertices, faces, resolution=8))
    np.testing.assert_array_equal(coordinates, gencoords.harmonic_coordinates(point, vertices, faces, resolution=None))
    np.testing.assert_array_equal(gencoords.weights(point, vertices, faces, kind="harmonic"), coordinates)


def test_outside_points_are_refused_or_projected():
    vertices, faces = octahedron()
    with pytest.raises(gencoords.OutsideCageError):
        gencoords.coordinates([[2.0, 0.0, 0.0]], vertices, faces, kind="harmonic", resolution=8)
    projected = gencoords.coordinates([[2.0, 0.0, 0.0]], vertices, faces, kind="harmonic", resolution=8,
                                      outside="project")
    np.testing.assert_allclose(projected @ vertices, [[1.0, 0.0, 0.0]], atol=1e-9)
    with pytest.raises(ValueError, match="do not extrapolate"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, kind="harmonic", outside="extrapolate")


def test_arguments_of_other_kinds_are_refused_by_name():
    vertices, faces = octahedron()
    with pytest.raises(ValueError, match="gamma applies to kind='power'"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, kind="harmonic", gamma=0.5)
    with pytest.raises(ValueError, match="resolution applies to kind='harmonic' only"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, kind="mean_value", resolution=8)
    with pytest.raises(ValueError, match="resolution must be an integer"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, kind="harmonic", resolution=1)
    with pytest.raises(ValueError, match="no ridge scalars"):
        gencoords.advanced.ridge_scalars([[0.1, 0.0, 0.0]], vertices, faces, kind="harmonic")
    with pytest.raises(ValueError, match="unknown kind 'harmonics'.*harmonic"):
        gencoords.coordinates([[0.1, 0.0, 0.0]], vertices, faces, kind="harmonics")
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(gencoords.CageError, match="3D triangle cage"):
        gencoords.coordinates([[0.5, 0.5]], square, [[0, 1], [1, 2], [2, 3], [3, 0]], kind="harmonic")
