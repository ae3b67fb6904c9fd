"""Green coordinates (core/green.py): the defining integrals, reproduction, similarity
invariance, boundary limits, outside points and bad inputs."""

import numpy as np
import pytest

import gencoords
from gencoords.base.errors import CageError, OutsideCageError
from gencoords import green_coordinates, green_deform
from gencoords.construction.green import GreenOutsideError, green_chunk_size, green_rows, green_terms
from gencoords.construction.green_deform import stretch_factors
from gencoords.base.orientation import orient_facets_outward
from gencoords.cages.shapes import irregular_octahedron
from gencoords.construction.validation import validate_cage
from tests.fixtures.polytopes import dented_icosphere, icosphere


def l_prism():
    """A non-convex closed cage: an L-shaped polygon extruded, triangulated, outward."""
    outline = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    vertices = np.vstack([np.c_[outline, np.zeros(6)], np.c_[outline, np.ones(6)]])
    cap = np.array([[3, 4, 5], [3, 5, 0], [3, 0, 1], [3, 1, 2]])  # fan from the reflex corner
    sides = [[i, (i + 1) % 6, 6 + (i + 1) % 6] for i in range(6)] + [[i, 6 + (i + 1) % 6, 6 + i] for i in range(6)]
    faces = np.vstack([cap[:, ::-1], cap + 6, sides])
    return vertices, orient_facets_outward(vertices, faces)


CAGES = {
    "icosphere": icosphere(1),
    "irregular": irregular_octahedron(),
    "dented": dented_icosphere(),
    "l_prism": l_prism(),
}
# Points well inside each cage (for quadrature: at least ~0.15 of the size from the surface).
DEEP = {
    "icosphere": [[0.0, 0.0, 0.0], [0.3, -0.2, 0.1], [-0.1, 0.4, -0.3]],
    "irregular": [[0.1, 0.0, 0.1], [0.3, 0.1, 0.0], [-0.1, 0.1, -0.2]],
    "dented": [[0.0, 0.0, 0.0], [-0.3, 0.2, 0.1], [0.2, -0.4, 0.2]],
    "l_prism": [[0.5, 0.5, 0.5], [1.5, 0.5, 0.4], [0.5, 1.5, 0.6]],
}


def unit_normals(vertices, faces):
    doubled = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    return doubled / np.linalg.norm(doubled, axis=1, keepdims=True)


def size(vertices):
    return float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))


def quadrature(point, vertices, faces, levels=48):
    """phi and psi by their defining integrals, a midpoint rule on each face cut into
    levels^2 similar triangles: phi_i = sum over faces of the integral of the hat
    function times dG/dn, psi_j = -integral of G over face j, G = -1 / (4 pi r)."""
    centres = []
    for i in range(levels):
        for j in range(levels - i):
            centres.append(((i + 1 / 3) / levels, (j + 1 / 3) / levels))
            if i + j < levels - 1:
                centres.append(((i + 2 / 3) / levels, (j + 2 / 3) / levels))
    centres = np.array(centres)
    hats = np.c_[1.0 - centres.sum(axis=1), centres]  # (q, 3)
    normals = unit_normals(vertices, faces)
    phi, psi = np.zeros(len(vertices)), np.zeros(len(faces))
    for face, corner in enumerate(faces):
        triangle = vertices[corner]
        area = 0.5 * np.linalg.norm(np.cross(triangle[1] - triangle[0], triangle[2] - triangle[0]))
        xi = hats @ triangle
        r = np.linalg.norm(xi - point, axis=1)
        weight = area / len(centres)
        psi[face] = weight * np.sum(1.0 / (4.0 * np.pi * r))
        normal_derivative = (xi - point) @ normals[face] / (4.0 * np.pi * r ** 3)
        np.add.at(phi, corner, weight * hats.T @ normal_derivative)
    return phi, psi


def random_inside(rng, vertices, faces, count):
    """Random points strictly inside (rejection by point location, 1e-3 of the size off the surface)."""
    cage = gencoords.Cage(vertices, faces)
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    points = rng.uniform(low, high, size=(20 * count, 3))
    points = points[cage.point_locations(points) == gencoords.INSIDE]
    assert len(points) >= count
    return points[:count]


@pytest.mark.parametrize("name", CAGES)
def test_closed_form_matches_quadrature_of_the_defining_integrals(name):
    vertices, faces = CAGES[name]
    points = np.array(DEEP[name])
    phi, psi = green_coordinates(points, vertices, faces)
    for row, point in enumerate(points):
        # The midpoint rule's error is ~c h^2: Richardson's extrapolation from 24 and 48
        # levels leaves ~1e-7 at these distances; a wrong sign, factor or term gives 1e-2.
        coarse, fine = quadrature(point, vertices, faces, 24), quadrature(point, vertices, faces, 48)
        expected_phi, expected_psi = ((4.0 * f - c) / 3.0 for f, c in zip(fine, coarse))
        assert np.abs(phi[row] - expected_phi).max() < 1e-6
        assert np.abs(psi[row] - expected_psi).max() < 1e-6 * size(vertices)


@pytest.mark.parametrize("name", CAGES)
def test_reproduction_and_partition_of_unity_inside(name):
    vertices, faces = CAGES[name]
    points = random_inside(np.random.default_rng(3), vertices, faces, 60)
    phi, psi = green_coordinates(points, vertices, faces)
    assert phi.shape == (60, len(vertices)) and psi.shape == (60, len(faces))
    reproduced = phi @ vertices + psi @ unit_normals(vertices, faces)
    assert np.abs(reproduced - points).max() < 1e-12 * size(vertices)
    assert np.abs(phi.sum(axis=1) - 1.0).max() < 1e-12
    assert (psi > 0.0).all()  # -integral of G = integral of 1 / (4 pi r) > 0


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


@pytest.mark.parametrize("name", CAGES)
def test_similarity_of_the_cage_moves_points_by_the_same_similarity(name):
    vertices, faces = CAGES[name]
    rng = np.random.default_rng(5)
    points = random_inside(rng, vertices, faces, 30)
    phi, psi = green_coordinates(points, vertices, faces)
    rotation, scale, shift = random_rotation(rng), 2.7, np.array([3.0, -1.0, 0.5])
    moved = green_deform(phi, psi, vertices, scale * vertices @ rotation.T + shift, faces)
    assert np.abs(moved - (scale * points @ rotation.T + shift)).max() < 1e-11 * scale * size(vertices)
    # At rest the deformation is the identity.
    assert np.abs(green_deform(phi, psi, vertices, vertices, faces) - points).max() < 1e-12 * size(vertices)


def test_stretch_factors_are_one_at_rest_and_the_ratio_of_a_similarity():
    vertices, faces = CAGES["irregular"]
    rotation = random_rotation(np.random.default_rng(2))
    assert np.allclose(stretch_factors(vertices, vertices, faces), 1.0, rtol=0, atol=1e-14)
    assert np.allclose(stretch_factors(vertices, 0.25 * vertices @ rotation.T + 7.0, faces), 0.25, rtol=1e-13)
    # A stretch along x changes faces differently (and a face in a plane x = c not at all).
    stretched = stretch_factors(vertices, vertices * [1.6, 1.0, 1.0], faces)
    assert stretched.min() > 1.0 and np.ptp(stretched) > 0.05


@pytest.mark.parametrize("name", ["icosphere", "l_prism"])
@pytest.mark.parametrize("depth", [1e-3, 1e-6])
def test_points_near_faces_edges_and_vertices_reproduce_themselves(name, depth):
    vertices, faces = CAGES[name]
    normals = unit_normals(vertices, faces)
    scale = size(vertices)
    points = []
    for face in range(0, len(faces), 3):
        triangle = vertices[faces[face]]
        for barycentric in ([0.2, 0.3, 0.5], [0.5, 0.5, 0.0], [0.0, 0.4, 0.6], [1.0, 0.0, 0.0]):
            on_surface = np.array(barycentric) @ triangle
            # Inwards along the normal, and inwards towards the face's centre.
            points.append(on_surface - depth * scale * normals[face])
            towards_centre = triangle.mean(axis=0) - on_surface
            if np.linalg.norm(towards_centre) > 0:
                step = towards_centre / np.linalg.norm(towards_centre) - normals[face]
                points.append(on_surface + depth * scale * step / np.linalg.norm(step))
    points = np.array(points)
    points = points[gencoords.Cage(vertices, faces).point_locations(points) == gencoords.INSIDE]
    assert len(points) > 20
    phi, psi = green_coordinates(points, vertices, faces)
    assert np.isfinite(phi).all() and np.isfinite(psi).all()
    reproduced = phi @ vertices + psi @ normals
    assert np.abs(reproduced - points).max() < 1e-8 * scale
    assert np.abs(phi.sum(axis=1) - 1.0).max() < 1e-8


@pytest.mark.parametrize("name", ["icosphere", "irregular", "l_prism"])
def test_boundary_points_get_the_limit_from_inside(name):
    vertices, faces = CAGES[name]
    normals = unit_normals(vertices, faces)
    scale = size(vertices)
    # In the face, on an edge, at a vertex, and within the tolerance of an edge and a vertex.
    cases = ([0.2, 0.3, 0.5], [0.5, 0.5, 0.0], [0.0, 0.25, 0.75], [1.0, 0.0, 0.0],
             [0.5, 0.5 - 1e-12, 1e-12], [1.0 - 2e-12, 1e-12, 1e-12])
    for face in (0, len(faces) // 2, len(faces) - 1):
        on = np.array([np.array(b) @ vertices[faces[face]] for b in cases])
        # On the face, within the tolerance outside, and 1e-7 of the size inside.
        phi, psi = green_coordinates(np.vstack([on, on + 1e-11 * scale * normals[face]]), vertices, faces)
        assert np.isfinite(phi).all() and np.isfinite(psi).all()
        reproduced = phi @ vertices + psi @ normals
        assert np.abs(reproduced - np.vstack([on, on])).max() < 1e-10 * scale
        assert np.abs(phi.sum(axis=1) - 1.0).max() < 1e-10
        # The interior limit: continuous from inside (the jump is to the outside). Near a
        # sharp vertex or right-angled edge a step along one face's normal leaves the inside.
        near = on - 1e-7 * scale * normals[face]
        inside = gencoords.Cage(vertices, faces).point_locations(near) == gencoords.INSIDE
        assert inside[0]  # the point inside the face
        near_phi, near_psi = green_coordinates(near[inside], vertices, faces)
        assert np.abs(near_phi - phi[:len(on)][inside]).max() < 1e-4
        assert np.abs(near_psi - psi[:len(on)][inside]).max() < 1e-4 * scale


def test_outside_points_raise_or_project():
    vertices, faces = CAGES["l_prism"]
    points = np.array([[0.5, 0.5, 0.5], [1.3, 1.6, 0.5], [3.0, 0.5, 0.5]])  # inside, in the notch, beyond
    with pytest.raises(GreenOutsideError, match="do not extrapolate") as error:
        green_coordinates(points, vertices, faces)
    assert isinstance(error.value, OutsideCageError) and list(error.value.indices) == [1, 2]
    with pytest.raises(ValueError, match="do not extrapolate"):
        green_coordinates(points, vertices, faces, outside="extrapolate")
    phi, psi = green_coordinates(points, vertices, faces, outside="project")
    nearest = np.array([[0.5, 0.5, 0.5], [1.0, 1.6, 0.5], [2.0, 0.5, 0.5]])  # the notch's nearest wall: x = 1
    expected_phi, expected_psi = green_coordinates(nearest, vertices, faces)
    assert np.abs(phi - expected_phi).max() < 1e-12
    assert np.abs(psi - expected_psi).max() < 1e-12


def test_float32_output_and_chunks_give_the_same_rows():
    vertices, faces = icosphere(2)
    points = random_inside(np.random.default_rng(8), vertices, faces, 200)
    phi, psi = green_coordinates(points, vertices, faces)
    phi32, psi32 = green_coordinates(points, vertices, faces, dtype=np.float32)
    assert phi32.dtype == psi32.dtype == np.float32
    assert np.array_equal(phi32, phi.astype(np.float32)) and np.array_equal(psi32, psi.astype(np.float32))
    # The chunk body, on an arbitrary split of the rows (the worker pool's units).
    cage = validate_cage(vertices, faces, convex=False)
    terms = green_terms(cage)
    assert green_chunk_size(cage) < len(points)
    # Both location paths (a convex cage's plane distances, others' winding numbers).
    for convex in (True, False):
        out_phi, out_psi = np.empty_like(phi), np.empty_like(psi)
        for rows in (slice(0, 77), slice(77, 200)):
            where = green_rows(cage, terms, points[rows], convex, 1e-9 * cage.size, "raise", out_phi[rows],
                               out_psi[rows])
            assert (where == gencoords.INSIDE).all()
        assert np.abs(out_phi - phi).max() < 1e-15 and np.abs(out_psi - psi).max() < 1e-15


def test_green_keeps_triangle_angles_better_than_mean_value_under_a_stretch():
    cage_vertices, cage_faces = icosphere(1)
    mesh_vertices, mesh_faces = icosphere(2, radius=0.6)
    stretched = cage_vertices * [1.6, 1.0, 1.0]

    def angles(v):
        t = v[mesh_faces]
        a, b = t[:, [1, 2, 0]] - t, t[:, [2, 0, 1]] - t
        cosine = np.einsum("fij,fij->fi", a, b) / np.linalg.norm(a, axis=2) / np.linalg.norm(b, axis=2)
        return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))

    rest = angles(mesh_vertices)
    phi, psi = green_coordinates(mesh_vertices, cage_vertices, cage_faces)
    green = np.abs(angles(green_deform(phi, psi, cage_vertices, stretched, cage_faces)) - rest).mean()
    mean_value = np.abs(angles(gencoords.coordinates(mesh_vertices, cage_vertices, cage_faces) @ stretched) - rest).mean()
    assert green < 0.6 * mean_value  # measured: 4.4 against 11 degrees (642-vertex mesh)


def test_bad_inputs_raise_clear_errors():
    vertices, faces = icosphere(1)
    point = [[0.0, 0.0, 0.0]]
    with pytest.raises(CageError, match="3D triangle cage"):
        green_coordinates([[0.1, 0.1]], np.array([[0, 0], [1, 0], [0, 1]], float), [[0, 1], [1, 2], [2, 0]])
    with pytest.raises(CageError) as open_cage:
        green_coordinates(point, vertices, faces[1:])
    assert open_cage.value.problem == "open"
    with pytest.raises(CageError) as inward:
        green_coordinates(point, vertices, faces[:, ::-1])
    assert inward.value.problem == "inward"
    with pytest.raises(ValueError, match="non-finite"):
        green_coordinates([[np.nan, 0.0, 0.0]], vertices, faces)
    with pytest.raises(ValueError, match="dtype"):
        green_coordinates(point, vertices, faces, dtype=np.int32)
    with pytest.raises(ValueError, match="outside must be"):
        green_coordinates(point, vertices, faces, outside="clamp")
    phi, psi = green_coordinates(point, vertices, faces)
    with pytest.raises(ValueError, match="phi must have shape"):
        green_deform(phi[:, 1:], psi, vertices, vertices, faces)
    with pytest.raises(ValueError, match="psi must have shape"):
        green_deform(phi, psi[:, 1:], vertices, vertices, faces)
    with pytest.raises(ValueError, match="cage_positions"):
        green_deform(phi, psi, vertices, vertices[1:], faces)
    with pytest.raises(ValueError, match="psi must be finite"):
        green_deform(phi, np.full_like(psi, np.inf), vertices, vertices, faces)


def test_green_in_worker_processes_is_bitwise_the_same_with_progress_and_outside_errors():
    vertices, faces = icosphere(2)
    points = np.random.default_rng(7).uniform(-0.5, 0.5, (3000, 3))
    seen = []
    with gencoords.Cage(vertices, faces) as cage:
        phi, psi = cage.green_coordinates(points, workers=1)
        phi2, psi2 = cage.green_coordinates(points, workers=2, progress=seen.append, dtype=np.float32)
        assert np.array_equal(phi.astype(np.float32), phi2) and np.array_equal(psi.astype(np.float32), psi2)
        assert seen and seen[-1] == 1.0 and seen == sorted(seen)
        with pytest.raises(GreenOutsideError, match="do not extrapolate") as error:
            cage.green_coordinates(np.vstack([points, [[3.0, 0.0, 0.0]]]), workers=2)
        assert list(error.value.indices) == [len(points)]
        locations = np.empty(len(points) + 1, dtype=np.int8)
        cage.green_coordinates(np.vstack([points, [[3.0, 0.0, 0.0]]]), outside="project", workers=2,
                               locations=locations)
        assert locations[-1] == gencoords.OUTSIDE and (locations[:-1] == gencoords.INSIDE).all()
