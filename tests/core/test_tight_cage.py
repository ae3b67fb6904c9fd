"""Tight cages in the core: triangle-triangle intersection against known cases and an
independent ray formula, volumes against known solids and the character's capsules,
and pushing a cage out until it encloses a mesh."""

import numpy as np
import pytest

import gencoords
from gencoords.cages import enclosing, self_intersection, surface, tight_cage, volumes
from gencoords.cages.shapes import icosphere, octahedron
from tests.fixtures import character

FLAT = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]


@pytest.mark.parametrize("other, crossing", [
    ([[0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [3.0, 3.0, 0.0]], True),    # an edge pierces it
    ([[0.5, 0.5, 0.5], [0.5, 0.5, 1.0], [3.0, 3.0, 0.5]], False),    # above it
    ([[-1.0, 0.5, -1.0], [-1.0, 0.5, 1.0], [3.0, 0.5, 0.0]], True),  # crossing through, no corner inside
    ([[0.0, 0.0, 0.0], [0.5, 0.5, -1.0], [0.5, 0.5, 1.0]], True),    # a shared corner, then crossing
    ([[0.0, 0.0, 0.0], [-1.0, 0.0, 1.0], [-1.0, -1.0, 0.0]], False),  # a shared corner only
    ([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, -1.0, 1.0]], False),   # a shared edge, bent
    ([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, -1.0, 0.0]], False),   # a shared edge, flat
    ([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.5, 0.0]], True),     # a shared edge, folded over
    ([[0.5, 0.5, 0.0], [3.0, 0.5, 0.0], [0.5, 3.0, 0.0]], True),     # coplanar, overlapping
    ([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [2.0, 1.0, 0.0]], False),    # coplanar, touching a corner
    ([[2.0, 2.0, 0.0], [3.0, 2.0, 0.0], [2.0, 3.0, 0.0]], False),    # coplanar, apart
    ([[1.0, 1.0, 0.0], [1.0, 1.0, 1.0], [3.0, 3.0, 0.5]], False),    # touching an edge at a corner
])
def test_triangle_pairs_with_known_answers(other, crossing):
    flat, other = np.array([FLAT]), np.array([other])
    assert self_intersection.triangles_intersect(flat, other).tolist() == [crossing]
    assert self_intersection.triangles_intersect(other, flat).tolist() == [crossing]  # symmetric


def _moller_trumbore(first, second):
    """Reference: some edge of one triangle meets the other at a parameter in (0, 1)."""
    found = np.zeros(len(first), dtype=bool)
    for one, other in ((first, second), (second, first)):
        a, b, c = other[:, 0], other[:, 1], other[:, 2]
        for i in range(3):
            origin, direction = one[:, i], one[:, (i + 1) % 3] - one[:, i]
            e1, e2 = b - a, c - a
            p = np.cross(direction, e2)
            det = np.einsum("pi,pi->p", e1, p)
            s = origin - a
            q = np.cross(s, e1)
            with np.errstate(divide="ignore", invalid="ignore"):  # parallel: NaN, no hit
                u = np.einsum("pi,pi->p", s, p) / det
                v = np.einsum("pi,pi->p", direction, q) / det
                t = np.einsum("pi,pi->p", e2, q) / det
            found |= (u > 0) & (v > 0) & (u + v < 1) & (t > 0) & (t < 1)
    return found


def test_random_pairs_agree_with_the_moller_trumbore_ray_test():
    rng = np.random.default_rng(7)
    first, second = rng.normal(size=(20_000, 3, 3)), rng.normal(size=(20_000, 3, 3)) + 0.5
    ours = self_intersection.triangles_intersect(first, second)
    np.testing.assert_array_equal(ours, _moller_trumbore(first, second))
    assert 0.1 < ours.mean() < 0.9  # both answers occur often


def test_closed_meshes_do_not_cross_themselves_and_two_overlapping_ones_do():
    for vertices, faces in (octahedron(), icosphere(2), _character_cage()):
        assert self_intersection.self_intersections(vertices, faces).shape == (0, 2)
    vertices, faces = icosphere(2)
    both = np.concatenate([vertices, vertices + [0.93, 0.11, 0.07]])  # generic: no mirror symmetry
    pairs = self_intersection.self_intersections(both, np.concatenate([faces, faces + len(vertices)]))
    assert len(pairs) and (pairs[:, 0] < len(faces)).all() and (pairs[:, 1] >= len(faces)).all()
    # The octahedron's top vertex pulled down through its lower half: three pairs of faces
    # cross (the ray test finds the same three among all pairs).
    vertices, faces = octahedron()
    vertices[4] = [0.71, 0.23, -0.47]
    pairs = self_intersection.self_intersections(vertices, faces)
    assert pairs.tolist() == [[1, 4], [2, 4], [3, 4]]
    first, second = np.triu_indices(len(faces), 1)
    reference = _moller_trumbore(vertices[faces[first]], vertices[faces[second]])
    assert np.column_stack([first, second])[reference].tolist() == pairs.tolist()
    # On the plane x - y - z = 1 of face 7, face 3 folds over it across their shared edge:
    # a crossing the ray test cannot see (coplanar), found in the plane.
    vertices[4] = [0.7, 0.2, -0.5]
    assert self_intersection.self_intersections(vertices, faces).tolist() == [[1, 4], [2, 4], [3, 7]]


def _character_cage():
    vertices, quads = character.character_cage()
    return vertices, gencoords.cages.triangulate_quads(vertices, quads)


def _box(low, high):
    """A closed outward box from two corners: (8, 3), (12, 3)."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    vertices = np.asarray(low) + corners * (np.asarray(high) - np.asarray(low))
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    return vertices, gencoords.cages.triangulate_quads(vertices, quads)


def test_volumes_of_boxes_overlapping_and_apart():
    box, faces = _box([0.2, 0.0, 0.0], [1.2, 1.0, 1.0])
    assert volumes.signed_volume(box, faces) == pytest.approx(1.0)
    assert volumes.signed_volume(box, faces[:, ::-1]) == pytest.approx(-1.0)  # inward
    other, _ = _box([0.7, 0.0, 0.5], [1.7, 1.0, 1.5])  # overlaps by a quarter
    both, both_faces = np.concatenate([box, other]), np.concatenate([faces, faces + 8])
    assert volumes.signed_volume(both, both_faces) == pytest.approx(2.0)  # overlap twice
    assert volumes.union_volume(both, both_faces, columns=300) == pytest.approx(1.75, rel=1e-2)
    apart, _ = _box([3.0, 3.0, 3.0], [4.0, 4.0, 4.0])
    assert volumes.union_volume(np.concatenate([box, apart]), both_faces,
                                columns=400) == pytest.approx(2.0, rel=1e-2)


def test_union_volume_of_the_character_agrees_with_its_capsules():
    vertices, triangles, _ = character.body_mesh()
    measured = volumes.union_volume(vertices, triangles)
    # Independent: the share of a fine grid's cell centres within any capsule.
    step = 0.004
    axes = [np.arange(low + step / 2, high, step) for low, high in
            zip(vertices.min(axis=0), vertices.max(axis=0))]
    inside = 0
    for x in axes[0]:
        grid = np.stack(np.meshgrid([x], axes[1], axes[2], indexing="ij"), axis=-1).reshape(-1, 3)
        inside += int((character._capsule_distances(grid) < 0).any(axis=1).sum())
    # The polygonal capsules are slightly inside the round ones.
    assert 0.97 < measured / (inside * step ** 3) < 1.0
    assert measured < 0.97 * volumes.signed_volume(vertices, triangles)  # overlaps once


def test_enclose_pushes_a_shrunk_cage_out_until_every_point_is_inside():
    points = icosphere(3)[0] * 1.0
    vertices, faces = icosphere(1, radius=1.0)  # its faces cut chords: points outside
    tolerance = 1e-6
    assert (gencoords.point_locations(points, vertices, faces, tolerance) == gencoords.OUTSIDE).any()
    pushed, pushes = tight_cage.enclose(vertices, faces, points, 0.02, tolerance)
    assert pushes >= 1
    assert (gencoords.point_locations(points, pushed, faces, tolerance) == gencoords.INSIDE).all()
    assert (np.linalg.norm(pushed, axis=1) > 1.0).all()  # outward, along the normals
    assert np.linalg.norm(pushed, axis=1).max() < 1.3  # by about what was missing
    again, none = tight_cage.enclose(pushed, faces, points, 0.02, tolerance)
    assert none == 0 and np.array_equal(again, pushed)  # an enclosing cage is left alone
    with pytest.raises(tight_cage.TightCageError, match="stay outside.*raise the offset") as caught:
        tight_cage.enclose(vertices, faces, points, 0.02, tolerance, iterations=0)
    assert caught.value.problem == "outside"


def test_enclose_works_in_a_non_convex_cage():
    vertices, faces = _character_cage()
    body = character.body_points(3000, seed=1)
    shrunk = vertices.mean(axis=0) + 0.8 * (vertices - vertices.mean(axis=0))
    tolerance = 1e-6
    pushed, pushes = tight_cage.enclose(shrunk, faces, body, 0.01, tolerance)
    assert pushes >= 1
    assert (gencoords.point_locations(body, pushed, faces, tolerance) == gencoords.INSIDE).all()


def test_fit_tight_cage_refuses_a_cage_through_itself_and_measures_volume():
    vertices, faces = icosphere(2)
    both = np.concatenate([vertices, vertices + [0.93, 0.11, 0.07]])  # generic: no mirror symmetry
    both_faces = np.concatenate([faces, faces + len(vertices)])
    with pytest.raises(tight_cage.TightCageError, match="passes through itself") as caught:
        tight_cage.fit_tight_cage(both, both_faces, [[0.5, 0.0, 0.0]], 0.01, 1e-6)
    assert caught.value.problem == "self_intersecting"
    # A surface the simplification spoilt is named so (no cage exists yet to mend).
    with pytest.raises(tight_cage.TightCageError, match=r"simplifying the offset surface to 162 vertices "
                                                        r"spoiled it \(open, at its vertices") as caught:
        tight_cage.fit_tight_cage(vertices, faces[1:], [[0.0, 0.0, 0.0]], 0.01, 1e-6)
    assert caught.value.problem == "simplified"
    with pytest.raises(gencoords.CageError, match="Offset of 0.6 .* Lower Offset to 0.5") as caught:
        enclosing.check_offset(0.6)
    assert caught.value.problem == "offset"
    enclosing.check_offset(enclosing.LARGEST_OFFSET)
    fitted, pushes = tight_cage.fit_tight_cage(1.1 * vertices, faces, 0.9 * vertices, 0.01, 1e-6)
    assert pushes == 0 and np.array_equal(fitted, 1.1 * vertices)
    cage_vertices, cage_faces = _character_cage()
    body, body_faces, _ = character.body_mesh(0.5)
    ratio = volumes.volume_ratio(cage_vertices, cage_faces, body, body_faces)
    assert 3.0 < ratio < 4.0  # the artist's box-modelled cage: 3.4 times the body


def test_a_quad_cage_is_pushed_out_and_checked_as_its_quads_are_split():
    vertices, _ = _box([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    points = np.random.default_rng(3).uniform(-1.1, 1.1, (2000, 3))  # some beyond every face
    no_triangles = np.zeros((0, 3), dtype=np.int64)
    fitted, pushes = tight_cage.fit_tight_cage(vertices, no_triangles, points, 0.05, 1e-6,
                                               stored_as=np.float32, quads=quads)
    assert pushes >= 1 and np.array_equal(fitted, fitted.astype(np.float32))
    split = surface.cage_triangles(fitted, no_triangles, quads)
    np.testing.assert_array_equal(split, gencoords.cages.triangulate_quads(fitted, quads))
    assert (gencoords.point_locations(points, fitted, split, 1e-6) == gencoords.INSIDE).all()


def test_a_push_moves_a_patch_its_neighbours_half_as_far():
    vertices, faces = octahedron()
    pushes = tight_cage.outward_pushes(vertices, faces, [[2.0, 0.0, 0.0]], 0.5)
    assert pushes[0] == pytest.approx(1.5 * np.sqrt(3.0))  # 1.5 along the nearest face's normal
    # Vertex 1, opposite (1, 0, 0), is on no face that needs moving: it goes half as far
    # as the farthest of its neighbours (2, 3, 4, 5).
    assert pushes[1] == pytest.approx(0.5 * pushes[2:].max()) and 0.0 < pushes[1] < pushes[0]


def test_pinched_vertices_are_where_two_sheets_meet_and_are_refused():
    vertices, faces = octahedron()
    assert surface.pinched_vertices(faces).size == 0
    assert surface.pinched_vertices(_character_cage()[1]).size == 0
    # Two octahedra touching at a corner: the second's bottom (5) is the first's top (4).
    touching = np.concatenate([vertices, vertices[:5] + [0.0, 0.0, 2.0]])
    both = np.concatenate([faces, np.array([6, 7, 8, 9, 10, 4])[faces]])
    assert surface.pinched_vertices(both).tolist() == [4]
    gencoords.advanced.validate_cage(touching, both, convex=False)  # edge-manifold, closed
    with pytest.raises(tight_cage.TightCageError, match="touches itself at 1 vertices") as caught:
        tight_cage.fit_tight_cage(touching, both, [[0.0, 0.0, 0.5]], 0.01, 1e-6)
    assert caught.value.problem == "pinched"


def test_mesh_extent_refuses_points_without_a_size_and_takes_lines_and_planes():
    from gencoords.cages.enclosing import EXTENT_STEPS, mesh_extent

    line = np.column_stack([np.linspace(0.0, 2.0, 5), np.zeros(5), np.zeros(5)])
    assert mesh_extent(line) == pytest.approx(2.0)
    assert mesh_extent(np.column_stack([line[:, :2], line[:, 0]])) == pytest.approx(np.sqrt(8.0))
    for points, resolution, said in (([[1.0, 2.0, 3.0]] * 4, 0.0, "sits at one point"),
                                     ([[1e6, 0.0, 0.0]] * 3, 0.1, "sits at one point"),
                                     (line, 2.0 / EXTENT_STEPS, "lies within 2 of one another")):
        with pytest.raises(gencoords.CageError, match=said) as caught:
            mesh_extent(points, resolution)
        assert caught.value.problem == "no_extent"
    assert mesh_extent(line, 1.99 / EXTENT_STEPS) == pytest.approx(2.0)  # just enough


def _first_hits(origins, directions, vertices, triangles):
    """Reference ray caster (Moller-Trumbore, all pairs): distance to the first hit of
    each ray and the cosine between the hit triangle's normal and the ray."""
    corners = vertices[triangles]
    a, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normals = np.cross(e1, e2)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    p = np.cross(directions[:, None], e2[None])
    det = np.einsum("rti,ti->rt", p, e1)
    s = origins[:, None] - a[None]
    q = np.cross(s, e1[None])
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.einsum("rti,rti->rt", s, p) / det
        v = np.einsum("ri,rti->rt", directions, q) / det
        t = np.einsum("ti,rti->rt", e2, q) / det
        t = np.where((u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-9), t, np.inf)  # parallel: NaN, no hit
    first = t.argmin(axis=1)
    return t[np.arange(len(t)), first], np.einsum("ri,ri->r", normals[first], directions)


def _boxes(*bounds):
    """Closed, outward boxes (low, high): vertices (8b, 3) and triangles (12b, 3)."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    quads = np.array([[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]])
    vertices = np.concatenate([np.array(low) + corners * (np.array(high) - low) for low, high in bounds])
    quads = np.concatenate([quads + 8 * i for i in range(len(bounds))])
    return vertices, np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def test_the_narrowest_gap_is_between_facing_parts_not_in_creases():
    """Two unit cubes 0.05 apart side by side, and a third box overlapping the first from
    above (creases where they meet): the gap is 0.05, cast by an independent ray caster;
    without the second cube no parts face each other. The offset keeping it is a sixth."""
    from gencoords.cages.enclosing import offset_for_gap

    first, second, overlapping = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)), ((1.05, 0.0, 0.0), (2.05, 1.0, 1.0)), \
        ((0.25, 0.25, 0.9), (0.75, 0.75, 1.6))
    for bounds, gap in (((first, second, overlapping), 0.05), ((first, overlapping), np.inf)):
        vertices, triangles = _boxes(*bounds)
        origins, directions = surface.ray_samples(vertices, triangles)
        assert len(origins) == 4 * len(triangles)
        np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
        distances, cosines = _first_hits(origins + 1e-9 * directions, directions, vertices, triangles)
        assert surface.narrowest_gap(distances, cosines) == pytest.approx(gap)
    assert offset_for_gap(0.05, 0.05) == pytest.approx(0.05 / 6) and offset_for_gap(0.001, 0.05) == 0.001
