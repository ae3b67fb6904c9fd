"""Independent formulas for named coordinates, written straight from the literature.

None of these shares code with ``core``: they are the oracles the general construction
is checked against. Plain loops are fine here (few points, small cages).
"""

from itertools import combinations

import numpy as np


def normalise(weights):
    weights = np.asarray(weights, dtype=float)
    return weights / weights.sum(axis=-1, keepdims=True)


def _cot(u, v):
    """Cotangent of the angle between 2D or 3D vectors u and v."""
    if len(u) == 2:  # numpy 2 deprecates np.cross of 2D vectors
        cross = u[0] * v[1] - u[1] * v[0]
    else:
        cross = np.cross(u, v)
    return np.dot(u, v) / np.linalg.norm(np.atleast_1d(cross))


def mean_value_2d_trigonometric(x, polygon):
    """Floater's mean value weights, paper eq. (4): (tan(a_{i-1}/2) + tan(a_i/2)) / |v_i - x|."""
    e = polygon - x
    lengths = np.linalg.norm(e, axis=1)
    following = np.roll(e, -1, axis=0)
    angle = np.arctan2(e[:, 0] * following[:, 1] - e[:, 1] * following[:, 0],
                       np.einsum("ij,ij->i", e, following))  # a_i between e_i and e_{i+1}
    tangent = np.tan(angle / 2.0)
    return (np.roll(tangent, 1) + tangent) / lengths


def discrete_harmonic_2d_cotangent(x, polygon):
    """Cotangent form (13): cotangents of the angles opposite the spoke x-v_i.

    w_i = cot(angle at v_{i-1} in triangle x v_{i-1} v_i) + cot(angle at v_{i+1} in x v_i v_{i+1}).
    """
    count = len(polygon)
    weights = np.empty(count)
    for i in range(count):
        previous, current, following = polygon[i - 1], polygon[i], polygon[(i + 1) % count]
        weights[i] = (_cot(x - previous, current - previous) + _cot(x - following, current - following))
    return weights


def floater_2d(x, polygon, c):
    """Floater, Hormann and Kos's construction: w_i = c_{i+1}/A_i + c_{i-1}/A_{i-1} - c_i B_i/(A_{i-1} A_i).

    A_i = area(x, v_i, v_{i+1}), B_i = area(x, v_{i-1}, v_{i+1}); c may depend on x.
    """
    def area(a, b):
        return 0.5 * ((a[0] - x[0]) * (b[1] - x[1]) - (a[1] - x[1]) * (b[0] - x[0]))

    count = len(polygon)
    weights = np.empty(count)
    for i in range(count):
        previous, current, following = polygon[i - 1], polygon[i], polygon[(i + 1) % count]
        a_prev, a_here = area(previous, current), area(current, following)
        b_here = area(previous, following)
        weights[i] = (c[(i + 1) % count] / a_here + c[i - 1] / a_prev
                      - c[i] * b_here / (a_prev * a_here))
    return weights


def mean_value_3d_ju(x, vertices, faces):
    """Ju, Schaefer and Warren 2005, "Mean value coordinates for closed triangular meshes".

    The robust pseudo-code of that paper (valid inside and outside, convex or not), for a
    point not on the mesh.
    """
    weights = np.zeros(len(vertices))
    e = vertices - x
    distance = np.linalg.norm(e, axis=1)
    unit = e / distance[:, None]
    for face in faces:
        u = unit[face]
        chord = np.array([np.linalg.norm(u[(i + 1) % 3] - u[(i + 2) % 3]) for i in range(3)])
        theta = 2.0 * np.arcsin(np.clip(chord / 2.0, -1.0, 1.0))
        half = theta.sum() / 2.0
        sin_theta = np.sin(theta)
        c = np.array([2.0 * np.sin(half) * np.sin(half - theta[i])
                      / (sin_theta[(i + 1) % 3] * sin_theta[(i + 2) % 3]) - 1.0 for i in range(3)])
        sign = np.sign(np.linalg.det(u))
        s = sign * np.sqrt(np.clip(1.0 - c * c, 0.0, None))
        if np.any(np.abs(s) <= 1e-12):
            continue  # x in the face's plane, off the face: no contribution
        for i in range(3):
            j, k = (i + 1) % 3, (i + 2) % 3
            weights[face[i]] += ((theta[i] - c[j] * theta[k] - c[k] * theta[j])
                                 / (distance[face[i]] * sin_theta[j] * s[k]))
    return weights


def _faces_around(vertex, faces):
    """Faces containing a vertex, in order around it (each shares an edge with the next)."""
    ring = [f for f in faces if vertex in f]
    # In face (vertex, a, b) (rotated), the next face around contains (vertex, b).
    rotated = []
    for face in ring:
        i = list(face).index(vertex)
        rotated.append((face[(i + 1) % 3], face[(i + 2) % 3]))
    ordered = [0]
    while len(ordered) < len(ring):
        _, last_b = rotated[ordered[-1]]
        ordered.append(next(j for j, (a, _) in enumerate(rotated) if a == last_b))
    return [ring[j] for j in ordered]


def wachspress_3d_polar_dual(x, vertices, faces):
    """Wachspress weights as polar-dual face areas (Ju, Schaefer, Warren, Desbrun 2005).

    The polar dual of the cage about x has one vertex n_f / h_f per face f (unit outward
    normal over distance to x); the dual face of vertex i is the polygon of its faces'
    dual vertices, lying in the plane p . (v_i - x) = 1. Weight: its area / |v_i - x|.
    """
    weights = np.empty(len(vertices))
    for i in range(len(vertices)):
        polygon = []
        for face in _faces_around(i, faces):
            a, b, c = vertices[face]
            normal = np.cross(b - a, c - a)
            normal /= np.linalg.norm(normal)
            polygon.append(normal / np.dot(a - x, normal))
        polygon = np.array(polygon)
        area_vector = 0.5 * sum(np.cross(polygon[j], polygon[(j + 1) % len(polygon)])
                                for j in range(len(polygon)))
        weights[i] = np.linalg.norm(area_vector) / np.linalg.norm(vertices[i] - x)
    return weights


def discrete_harmonic_3d_cotangent(x, vertices, faces):
    """Cotangent form (20): w_i = sum over faces T of i of cot(theta_i^T) h_i^T / 2.

    theta_i^T: dihedral angle of the tetrahedron {x} + T at the edge opposite i, between
    T and the triangle {x, v_j, v_k}; h_i^T = |v_j - v_k|.
    """
    weights = np.zeros(len(vertices))
    for face in faces:
        for slot in range(3):
            i, j, k = face[slot], face[(slot + 1) % 3], face[(slot + 2) % 3]
            edge = vertices[k] - vertices[j]
            direction = edge / np.linalg.norm(edge)

            def across(point):  # component orthogonal to the edge
                offset = point - vertices[j]
                return offset - np.dot(offset, direction) * direction

            weights[i] += _cot(across(vertices[i]), across(x)) * np.linalg.norm(edge) / 2.0
    return weights


def mean_value_by_integration(x, vertices, facets, samples=400_000, seed=0):
    """Mean value weights from their definition, by Monte Carlo over directions.

    w_i = integral over unit directions u of lambda_i(u) / r(u), where the ray x + r u
    leaves the convex polytope through a facet at distance r and lambda are the
    barycentric coordinates of the exit point in that facet (Ju, Schaefer and Warren;
    Floater, Kos and Reimers). Independent of any closed form, in any dimension; the
    estimate's relative error is about 1 / sqrt(samples).
    """
    rng = np.random.default_rng(seed)
    dim = vertices.shape[1]
    directions = rng.normal(size=(samples, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    corners = vertices[facets]  # (m, N, N)
    # Facet hyperplanes n . y = c with n pointing away from x.
    normals = np.array([np.linalg.svd(c[1:] - c[0])[2][-1] for c in corners])
    offsets = np.einsum("mN,mN->m", normals, corners[:, 0])
    flip = offsets - normals @ x < 0
    normals[flip], offsets[flip] = -normals[flip], -offsets[flip]
    with np.errstate(divide="ignore"):
        distance = (offsets - normals @ x)[None, :] / (directions @ normals.T)
    distance[distance <= 0] = np.inf
    hit = np.argmin(distance, axis=1)
    reach = distance[np.arange(samples), hit]
    exits = x + reach[:, None] * directions
    weights = np.zeros(len(vertices))
    for facet in range(len(facets)):
        chosen = hit == facet
        # Barycentric coordinates of the exit points in the facet (least squares in its plane).
        system = np.vstack([corners[facet].T, np.ones(dim)])
        rhs = np.vstack([exits[chosen].T, np.ones(np.count_nonzero(chosen))])
        barycentric = np.linalg.lstsq(system, rhs, rcond=None)[0]  # (N, hits)
        np.add.at(weights, facets[facet], (barycentric / reach[chosen]).sum(axis=1))
    return weights


def wachspress_by_polar_dual_volumes(x, vertices, facets):
    """Wachspress weights in any dimension from the polar dual (Ju et al. 2005).

    The dual of facet f about x is the point n_f / h_f (unit outward normal over the
    distance from x). The dual facet of vertex i, the hull of the dual points of the
    facets around it, lies in the hyperplane p . (v_i - x) = 1; the weight is its
    (N-1)-volume over |v_i - x|. Volumes come from an explicit hull, not from the core.
    """
    corners = vertices[facets]
    normals = np.array([np.linalg.svd(c[1:] - c[0])[2][-1] for c in corners])
    heights = np.einsum("mN,mN->m", normals, corners[:, 0] - x)
    normals[heights < 0] *= -1
    duals = normals / np.abs(heights)[:, None]
    weights = np.empty(len(vertices))
    for i, vertex in enumerate(vertices):
        spoke = vertex - x
        around = duals[np.any(facets == i, axis=1)]
        basis = np.linalg.svd(spoke[None, :])[2][1:].T  # (N, N-1): the hyperplane's directions
        weights[i] = convex_volume(around @ basis) / np.linalg.norm(spoke)
    return weights


def convex_volume(points, tolerance=1e-9):
    """Volume of the convex hull of a few points in R^d, by brute force.

    Facets are the distinct hyperplanes through d of the points with all points on one
    side (coplanar points allowed, so non-simplicial hulls work); the volume is the sum
    of the cones from the centroid over the facets, each facet's volume recursively.
    """
    points = np.asarray(points, dtype=float)
    dim = points.shape[1]
    if dim == 1:
        return float(np.ptp(points[:, 0]))
    centre = points.mean(axis=0)
    scale = np.abs(points - centre).max()
    planes, volume = [], 0.0
    for subset in combinations(range(len(points)), dim):
        edges = points[list(subset[1:])] - points[subset[0]]
        singular, right = np.linalg.svd(edges)[1:]
        if singular[-1] <= tolerance * scale:
            continue  # the d points span less than a hyperplane
        normal = right[-1]
        offset = normal @ points[subset[0]]
        side = points @ normal - offset
        if side.max() > tolerance * scale and side.min() < -tolerance * scale:
            continue  # points on both sides: not a facet
        if any(abs(abs(normal @ n) - 1) < 1e-9 and abs(abs(offset) - abs(o)) < tolerance * scale
               for n, o in planes):
            continue  # a facet already counted
        planes.append((normal, offset))
        on_facet = points[np.abs(side) <= tolerance * scale]
        basis = np.linalg.svd(normal[None, :])[2][1:].T  # the facet's directions
        height = abs(normal @ centre - offset)
        volume += convex_volume(on_facet @ basis, tolerance) * height / dim
    return volume


def discrete_harmonic_by_stiffness(x, vertices, facets):
    """Discrete harmonic weights in any dimension from their definition (paper eq. 10).

    Minimising the Dirichlet energy of the piecewise linear function on the simplices
    {x} + facet over its value at x gives f(x) = sum w_i f_i / sum w_i with w_i minus the
    (x, v_i) entry of the linear finite-element stiffness matrix, assembled here simplex
    by simplex: vol(S) grad(lambda_x) . grad(lambda_i).
    """
    dim = vertices.shape[1]
    weights = np.zeros(len(vertices))
    for facet in facets:
        corners = np.vstack([x, vertices[facet]])  # (N+1, N)
        affine = np.vstack([np.ones(dim + 1), corners.T])  # barycentric coordinates = inv @ [1, y]
        gradients = np.linalg.inv(affine)[:, 1:]  # (N+1, N): gradient of each lambda
        volume = abs(np.linalg.det(affine)) / np.prod(range(1, dim + 1))
        weights[facet] -= volume * gradients[1:] @ gradients[0]
    return weights
