"""Quad-native mean value coordinates (gencoords.mean_value_quad_coordinates): each quad a
bilinear patch, checked against an independent dense quadrature of the same integral."""

import numpy as np
import pytest

import gencoords
from gencoords.construction import quad_cage, quad_integrals
from gencoords.cages.shapes import block_cage, icosphere


def _bent_box(seed=0, bend=0.15):
    """Two unit cubes in a row, corners moved: ten non-planar quads, (12, 3), (10, 4)."""
    vertices, quads = block_cage(np.ones((2, 1, 1), dtype=bool))
    rng = np.random.default_rng(seed)
    return vertices + rng.uniform(-bend, bend, vertices.shape), quads


def _thin_box(seed=2, bend=0.01):
    """A bent box 1 x 0.12 x 0.12, corners moved: four 1:8 side quads, cut into strips
    along their length (quad_integrals.canonical_rolls), (8, 3), (6, 4)."""
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    vertices = vertices * [1.0, 0.12, 0.12]
    return vertices + np.random.default_rng(seed).uniform(-bend, bend, vertices.shape), quads


def _roofed_box():
    """A bent cube whose top quad is a pyramid of 4 triangles: a mixed cage, polygons list."""
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    vertices = vertices + np.random.default_rng(3).uniform(-0.1, 0.1, vertices.shape)
    top = next(i for i, q in enumerate(quads) if (vertices[q, 2] > 0.5).all())
    apex = len(vertices)
    ring = quads[top]
    polygons = [list(q) for i, q in enumerate(quads) if i != top]
    polygons += [[int(ring[i]), int(ring[(i + 1) % 4]), apex] for i in range(4)]
    return np.vstack([vertices, [[0.5, 0.5, 1.4]]]), polygons


def _inside(vertices, count, seed=1):
    """Points well inside a (bent) box: a shrunken copy of its vertices' mixes."""
    rng = np.random.default_rng(seed)
    mix = rng.dirichlet(np.ones(len(vertices)), count)
    centre = vertices.mean(axis=0)
    return centre + 0.6 * (mix @ vertices - centre)


def _dense_weights(points, vertices, polygons, nodes=160):
    """The mean value integral by a fine tensor Gauss rule over every face, written apart
    from the module: quads bilinear, triangles through the square (s, t) -> (s, s t)."""
    g, gw = np.polynomial.legendre.leggauss(nodes)
    g, gw = 0.5 * (g + 1.0), 0.5 * gw
    u, v = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    area = np.outer(gw, gw).ravel()
    weights = np.zeros((len(points), len(vertices)))
    for face in polygons:
        c = vertices[list(face)]
        if len(face) == 4:
            hats = np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], axis=1)
            du = (1 - v)[:, None] * (c[1] - c[0]) + v[:, None] * (c[2] - c[3])
            dv = (1 - u)[:, None] * (c[3] - c[0]) + u[:, None] * (c[2] - c[1])
            normal, jacobian = np.cross(du, dv), area
        else:
            hats = np.stack([1 - u, u * (1 - v), u * v], axis=1)
            normal = np.broadcast_to(np.cross(c[1] - c[0], c[2] - c[0]), (len(u), 3))
            jacobian = area * u
        y = hats @ c
        for row, x in enumerate(points):
            r = y - x
            kernel = (r * normal).sum(axis=1) / (r * r).sum(axis=1) ** 2 * jacobian
            weights[row, list(face)] += kernel @ hats
    return weights


@pytest.mark.parametrize("cage", [_bent_box, _roofed_box, _thin_box])
def test_agrees_with_a_dense_quadrature_of_the_integral(cage):
    vertices, polygons = cage()
    polygons = [list(p) for p in polygons]
    points = _inside(vertices, 6)
    dense = _dense_weights(points, vertices, polygons)
    expected = dense / dense.sum(axis=1, keepdims=True)
    got = gencoords.mean_value_quad_coordinates(points, vertices, polygons)
    assert np.abs(got - expected).max() < 1e-6


def _relabelled(polygons, seed=5):
    """Each quad's corners from another one, order kept (orientation-preserving)."""
    rng = np.random.default_rng(seed)
    return [list(np.roll(p, rng.integers(1, 4))) if len(p) == 4 else list(p) for p in polygons]


@pytest.mark.parametrize("cage", [_bent_box, _roofed_box, _thin_box])
def test_independent_of_each_quads_first_corner(cage):
    vertices, polygons = cage()
    points = _inside(vertices, 50)
    b = gencoords.mean_value_quad_coordinates(points, vertices, [list(p) for p in polygons])
    for seed in range(3):
        again = gencoords.mean_value_quad_coordinates(points, vertices, _relabelled(polygons, seed))
        assert np.abs(again - b).max() < 1e-10


@pytest.mark.parametrize("cage", [_bent_box, _roofed_box])
def test_partition_of_unity_and_linear_precision(cage):
    vertices, polygons = cage()
    points = _inside(vertices, 200)
    b = gencoords.mean_value_quad_coordinates(points, vertices, [list(p) for p in polygons])
    assert np.abs(b.sum(axis=1) - 1.0).max() < 1e-10
    assert np.abs(b @ vertices - points).max() < 1e-10


def test_the_correction_is_the_quadratures_small_error():
    vertices, quads = _bent_box()
    local = (vertices - vertices.mean(axis=0)) / 3.0
    points = _inside(local, 100)
    weights, _ = quad_cage.integrated_weights(points, local, np.asarray(quads))
    _, change = quad_cage.restore_linear_precision(weights / weights.sum(axis=1, keepdims=True), local, points)
    assert change.max() < 1e-7


def test_on_a_quad_its_bilinear_weights():
    vertices, quads = _bent_box()
    rng = np.random.default_rng(4)
    face = quads[3]
    u, v = rng.uniform(0, 1, (2, 20))
    hats = quad_integrals.bilinear_hats(u, v)
    points = hats @ vertices[face] + 1e-12 * rng.normal(size=(20, 3))
    b = gencoords.mean_value_quad_coordinates(points, vertices, quads)
    expected = np.zeros_like(b)
    expected[:, face] = hats
    assert np.abs(b - expected).max() < 1e-9


def test_near_a_quad_the_coordinates_approach_its_bilinear_weights():
    vertices, quads = _bent_box()
    face = quads[3]
    on = quad_integrals.bilinear_hats(np.array([0.3]), np.array([0.6]))
    inward = -np.cross(vertices[face[1]] - vertices[face[0]], vertices[face[3]] - vertices[face[0]])
    point = on @ vertices[face] + 1e-6 * inward / np.linalg.norm(inward)
    b = gencoords.mean_value_quad_coordinates(point, vertices, quads)
    assert np.isfinite(b).all() and np.abs(b[0, face] - on[0]).max() < 1e-4


def test_a_cage_of_triangles_gives_mean_value():
    vertices, faces = icosphere(1)
    points = 0.7 * _inside(vertices, 30)
    expected = gencoords.coordinates(points, vertices, faces, kind="mean_value")
    got = gencoords.mean_value_quad_coordinates(points, vertices, faces)
    assert np.abs(got - expected).max() < 1e-10


def test_a_quad_with_a_short_side():
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    vertices = vertices.copy()
    top_right = (vertices[:, 2] == 1.0) & (vertices[:, 0] == 1.0)
    vertices[top_right, 0] = 1e-3  # the top quad and the x=1 side 1e-3 wide at the top
    vertices[top_right, 2] = 1.0 + 1e-3 * np.array([0.3, -0.2])  # and not planar
    points = np.array([[0.3, 0.4, 0.5], [0.04, 0.5, 0.9], [0.02, 0.3, 0.95]])  # 0.04 to 0.06 from the faces
    b = gencoords.mean_value_quad_coordinates(points, vertices, quads)
    dense = _dense_weights(points, vertices, quads, nodes=400)
    assert np.abs(b - dense / dense.sum(axis=1, keepdims=True)).max() < 1e-6
    assert np.abs(b @ vertices - points).max() < 1e-10


def test_points_outside_are_refused():
    vertices, quads = _bent_box()
    with pytest.raises(gencoords.OutsideCageError) as error:
        gencoords.mean_value_quad_coordinates([[0.8, 0.5, 0.5], [9.0, 0.0, 0.0]], vertices, quads)
    assert error.value.indices.tolist() == [1]


def _bad(vertices, quads, face, corners):
    quads = [list(q) for q in quads]
    vertices = vertices.copy()
    vertices[quads[face][corners[0]]] = corners[1]
    return vertices, quads


@pytest.mark.parametrize("move, problem", [
    ((2, [-0.2, 0.5, 1.0]), "folded_quad"),       # a top corner dragged across the opposite diagonal
])
def test_a_folded_quad_is_refused_by_its_index(move, problem):
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    top = next(i for i, q in enumerate(quads) if (vertices[q, 2] == 1.0).all())
    vertices, quads = _bad(vertices, quads, top, move)
    with pytest.raises(gencoords.CageError) as error:
        gencoords.mean_value_quad_coordinates([[0.5, 0.5, 0.3]], vertices, quads)
    assert error.value.problem == problem and top in error.value.faces
    assert f"quad {top}" in str(error.value)


def test_a_bow_tie_is_refused_by_its_index():
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    quads = [list(q) for q in quads]
    bow_tie = [quads[0][0], quads[0][2], quads[0][1], quads[0][3]]  # corners crossed
    quads[0] = bow_tie
    with pytest.raises(gencoords.CageError) as error:
        gencoords.mean_value_quad_coordinates([[0.5, 0.5, 0.5]], vertices, quads)
    assert 0 in error.value.faces


def test_polygons_of_five_corners_and_open_cages_are_refused_by_index():
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    quads = [list(q) for q in quads]
    with pytest.raises(gencoords.CageError, match="polygon 2 has 5 corners"):
        gencoords.mean_value_quad_coordinates([[0.5, 0.5, 0.5]], vertices, quads[:2] + [quads[2] + [0]] + quads[3:])
    with pytest.raises(gencoords.CageError) as error:
        gencoords.mean_value_quad_coordinates([[0.5, 0.5, 0.5]], vertices, quads[:5] + [quads[5][:3]])
    assert error.value.problem == "open" and set(error.value.faces) <= {1, 3, 5} and error.value.faces
    assert "the polygons: [" in str(error.value)


def test_outside_points_projected_and_located():
    vertices, quads = block_cage(np.ones((1, 1, 1), dtype=bool))
    points = np.array([[0.5, 0.5, 0.5], [0.3, 0.6, 1.5], [0.5, 0.5, 1.0]])
    locations = np.empty(3, dtype=np.int8)
    b = gencoords.mean_value_quad_coordinates(points, vertices, quads, outside="project", locations=locations)
    assert locations.tolist() == [1, -1, 0]
    assert np.abs(b[1] @ vertices - [0.3, 0.6, 1.0]).max() < 1e-12


def test_bind_plan_stores_the_quads_coordinates():
    from gencoords.planning.bind_plan import plan_bind
    from gencoords.planning.request import BindRequest

    vertices, quads = _bent_box()
    points = _inside(vertices, 40)
    polygons = np.asarray(quads)
    request = BindRequest(gencoords.MEAN_VALUE_QUADS, storage="EXACT", workers=1, polygons=polygons)
    steps = plan_bind(points, vertices, gencoords.cages.triangulate_quads(vertices, quads), request)
    try:
        while True:
            next(steps)
    except StopIteration as stop:
        plan = stop.value
    expected = gencoords.mean_value_quad_coordinates(points, vertices, quads)
    assert np.abs(plan.slots - expected).max() < 1e-6  # float32 slots
    assert plan.report.startswith("Mean value on quads")


def test_workers_compute_the_same_rows():
    vertices, polygons = _roofed_box()
    points = _inside(vertices, 700)
    here = gencoords.mean_value_quad_coordinates(points, vertices, polygons, workers=1)
    fractions = []
    spread = gencoords.mean_value_quad_coordinates(points, vertices, polygons, workers=2, progress=fractions.append)
    assert np.array_equal(here, spread)
    assert fractions and fractions[-1] == 1.0


def test_a_kind_of_coordinates_and_weights_with_the_same_arguments():
    """``kind=MEAN_VALUE_QUADS`` of the public functions: the quads' own coordinates,
    bitwise, for a mixed list, an (m, 4) and an (m, 3) array of faces."""
    vertices, polygons = _roofed_box()
    on_a_quad = vertices[polygons[0]].mean(axis=0)  # its bilinear patch's middle
    points = np.vstack([_inside(vertices, 40), on_a_quad, [3.0, 0.5, 0.5]])  # inside, on a face, outside
    kind = gencoords.MEAN_VALUE_QUADS
    expected = gencoords.mean_value_quad_coordinates(points, vertices, polygons, outside="project")
    locations = np.empty(len(points), dtype=np.int8)
    got = gencoords.coordinates(points, vertices, polygons, kind=kind, outside="project", locations=locations)
    assert got.dtype == np.float64 and np.array_equal(got, expected)
    assert list(locations[-2:]) == [0, -1] and (locations[:-2] == 1).all()
    single = gencoords.coordinates(points[:40], vertices, polygons, kind=kind, dtype=np.float32)
    assert single.dtype == np.float32 and np.array_equal(single, expected[:40].astype(np.float32))
    weights = gencoords.weights(points, vertices, polygons, kind=kind)
    assert np.array_equal(weights, gencoords.mean_value_quad_coordinates(points, vertices, polygons,
                                                                        outside="extrapolate"))
    cube, quads = _bent_box()
    assert np.array_equal(gencoords.coordinates(_inside(cube, 5), cube, quads, kind=kind),
                          gencoords.mean_value_quad_coordinates(_inside(cube, 5), cube, quads))
    tetrahedron = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    triangles = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    assert np.array_equal(gencoords.coordinates([[0.1, 0.2, 0.3]], tetrahedron, triangles, kind=kind),
                          gencoords.mean_value_quad_coordinates([[0.1, 0.2, 0.3]], tetrahedron, triangles))


@pytest.mark.parametrize("call, message", [
    (lambda v, p: gencoords.coordinates(v.mean(0), v, p, kind="mean_value_quads", gamma=1.0), "gamma applies"),
    (lambda v, p: gencoords.weights(v.mean(0), v, p, kind="mean_value_quads", resolution=8), "resolution applies"),
    (lambda v, p: gencoords.coordinates(v.mean(0), v, p + [[0, 1, 2, 3, 4]], kind="mean_value_quads"),
     "has 5 corners"),
    (lambda v, p: gencoords.coordinates(v.mean(0), v, p), "faces must be"),  # quads, of another kind
    (lambda v, p: gencoords.advanced.ridge_scalars(v.mean(0), v, p, "mean_value_quads"), "not by ridge_scalars"),
    (lambda v, p: gencoords.Cage(*icosphere(1)).coordinates(v.mean(0), kind="mean_value_quads"),
     "not by Cage.coordinates"),
])
def test_the_kind_is_refused_where_it_does_not_apply(call, message):
    vertices, polygons = _roofed_box()
    with pytest.raises(ValueError, match=message):
        call(vertices, polygons)


def test_each_quad_is_integrated_from_the_same_corner_u_along_its_short_sides():
    """quad_integrals.canonical_rolls: the strips run along a quad's long sides, whichever
    corner is listed first, so that a thin quad needs few strips and no corner decides."""
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.125, 0.0], [0.0, 0.125, 0.0]])
    chosen = []
    for shift in range(4):
        listed = np.roll(corners, shift, axis=0)[None]
        roll = quad_integrals.canonical_rolls(listed)[0]
        rolled = listed[0, (np.arange(4) + roll) % 4]
        assert np.linalg.norm(rolled[1] - rolled[0]) == 0.125  # u along a short side
        chosen.append(rolled)
    assert all(np.array_equal(rolled, chosen[0]) for rolled in chosen)


def test_a_thin_quad_near_a_point_agrees_with_a_dense_quadrature():
    """A 1:40 quad 0.002 of its length from the point (strips halved toward it), listed
    from each corner."""
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.05], [1.0, 0.025, 0.0], [0.0, 0.025, 0.0]])
    point = np.array([[0.37, 0.011, -0.002]])
    g, gw = np.polynomial.legendre.leggauss(400)
    g, gw = 0.5 * (g + 1.0), 0.5 * gw
    u, v = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    hats = quad_integrals.bilinear_hats(u, v)
    y = hats @ corners
    normal = np.cross((1 - v)[:, None] * (corners[1] - corners[0]) + v[:, None] * (corners[2] - corners[3]),
                      (1 - u)[:, None] * (corners[3] - corners[0]) + u[:, None] * (corners[2] - corners[1]))
    r = y - point
    dense = (np.outer(gw, gw).ravel() * (r * normal).sum(axis=1) / (r * r).sum(axis=1) ** 2) @ hats
    for shift in range(4):
        weights, _ = quad_integrals.quad_weights(point, np.roll(corners, shift, axis=0)[None])
        assert np.abs(np.roll(weights[0, 0], -shift) - dense).max() < 1e-6 * np.abs(dense).sum()
