"""Mean value integrals over triangles and bilinear quad patches (docs/MATH.md, "Quad cages").

The mean value weight of a cage vertex j at a point x is the integral over the cage of
``phi_j(y) (y - x).n(y) / |y - x|^4 dA(y)``: the solid angle the cage subtends at x,
each direction weighted by ``phi_j / |y - x|`` (``phi_j`` the linear hat on a triangle,
the bilinear hat on a quad ``p(u, v) = (1-u)(1-v) c0 + u(1-v) c1 + uv c2 + (1-u)v c3``).
On a triangle the integral has a closed form (:func:`triangle_weights`). On a quad it is
integrated numerically (:func:`quad_weights`): a quadtree over (u, v) refined where a
sub-patch is close to x for its size, each accepted sub-patch by a tensor Gauss-Legendre
rule; at the deepest level a sub-patch is flat to rounding and its fan of 4 triangles
around its centre takes the closed form. Every choice depends only on the sub-patches'
corners as a set, so the result does not depend on which corner a quad lists first.
"""

import numpy as np

__all__ = ["triangle_weights", "corner_normals", "bilinear_hats", "patch_rule", "quad_weights",
           "GAUSS_ORDER", "NEAR_RATIO", "DEEPEST_LEVEL"]

# Gauss-Legendre nodes per side of a (sub-)patch, and how far (in its radii, from its
# centre) a point must be for that rule: the rule's error falls like (ratio * 2) ** -(2
# * order), about 1e-9 of the sub-patch's share at 4 nodes and 3 radii (measured against
# a dense rule in tests/core/test_quad_mean_value.py).
GAUSS_ORDER = 5
NEAR_RATIO = 2.0
# Sub-patches this many halvings deep are flat to float64 rounding: fan of 4 triangles.
DEEPEST_LEVEL = 40


def triangle_weights(relative):
    """The mean value integral of each corner's hat over triangles, in closed form.

    Parameters
    ----------
    relative : (p, 3, 3) float
        Each triangle's corners minus its point x, counter-clockwise seen from outside.

    Returns
    -------
    weights : (p, 3) float
        Positive where x is behind the triangle (inside a cage), negative in front, 0 in
        its plane outside it. ``weights @ relative`` is the integral of the unit vector
        over the triangle's spherical image, the mean value identity.
    solid_angle : (p,) float
        The signed solid angle the triangle subtends at x.
    """
    lengths = np.linalg.norm(relative, axis=2)
    unit = relative / lengths[:, :, None]
    before, after = np.roll(unit, 1, axis=1), np.roll(unit, -1, axis=1)
    # theta_i: the angle of the edge opposite corner i, seen from x (stable half-chord form).
    theta = 2.0 * np.arcsin(np.clip(0.5 * np.linalg.norm(after - before, axis=2), 0.0, 1.0))
    half = 0.5 * theta.sum(axis=1, keepdims=True)
    sines = np.sin(theta)
    sine_after, sine_before = np.roll(sines, -1, axis=1), np.roll(sines, 1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cosine = 2.0 * np.sin(half) * np.sin(half - theta) / (sine_after * sine_before) - 1.0
        sign = np.sign(np.linalg.det(unit))[:, None]
        sine = sign * np.sqrt(np.clip(1.0 - cosine ** 2, 0.0, None))
        cos_after, cos_before = np.roll(cosine, -1, axis=1), np.roll(cosine, 1, axis=1)
        numerator = theta - cos_after * np.roll(theta, 1, axis=1) - cos_before * np.roll(theta, -1, axis=1)
        weights = numerator / (lengths * sine_after * np.roll(sine, 1, axis=1))
    # In the triangle's plane outside it (or degenerate as seen from x) nothing is subtended.
    flat = (np.abs(sine) <= 1e-12).any(axis=1) | ~np.isfinite(weights).all(axis=1)
    weights = np.where(flat[:, None], 0.0, 0.5 * weights)
    triple = np.einsum("pi,pi->p", unit[:, 0], np.cross(unit[:, 1], unit[:, 2]))
    dots = np.einsum("pij,pij->pi", unit, np.roll(unit, -1, axis=1)).sum(axis=1)
    return weights, 2.0 * np.arctan2(triple, 1.0 + dots)


def corner_normals(corners):
    """The bilinear patch's corner normals: ``p_u x p_v = sum_i hat_i(u, v) normals_i``.

    Parameters
    ----------
    corners : (..., 4, 3) float

    Returns
    -------
    normals : (..., 4, 3) float
        At corner i, the cross product of its two edges, in the patch's orientation.
    """
    after, before = np.roll(corners, -1, axis=-2), np.roll(corners, 1, axis=-2)
    return np.cross(after - corners, before - corners)


def bilinear_hats(u, v):
    """Bilinear hats of the 4 corners at parameters u, v: (...) -> (..., 4)."""
    return np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], axis=-1)


def patch_rule(order=GAUSS_ORDER):
    """The tensor Gauss-Legendre rule on the unit square.

    Returns
    -------
    hats : (order**2, 4) float
        The corners' bilinear hats at the nodes.
    weights : (order**2,) float
        Summing to 1.
    """
    nodes, weights = np.polynomial.legendre.leggauss(order)
    nodes, weights = 0.5 * (nodes + 1.0), 0.5 * weights
    u, v = np.meshgrid(nodes, nodes, indexing="ij")
    return bilinear_hats(u.ravel(), v.ravel()), np.outer(weights, weights).ravel()


_RULE_HATS, _RULE_WEIGHTS = patch_rule()
# Child c's corners as mixes of its parent's: the quadtree's split at the midpoints.
_MIDPOINTS = np.array([[1, 0, 0, 0], [.5, .5, 0, 0], [0, 1, 0, 0], [0, .5, .5, 0], [0, 0, 1, 0],
                       [0, 0, .5, .5], [0, 0, 0, 1], [.5, 0, 0, .5], [.25, .25, .25, .25]])
_CHILDREN = _MIDPOINTS[[[0, 1, 8, 7], [1, 2, 3, 8], [8, 3, 4, 5], [7, 8, 5, 6]]]  # (4, 4, 4)


def _near(points, corners):
    """Whether each point is closer to its (sub-)patch than NEAR_RATIO of its radius.

    points (p, 3), corners (p, 4, 3) -> (p,) bool: from the centre and the farthest corner,
    both the same whichever corner is listed first.
    """
    centre = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centre[:, None], axis=2).max(axis=1)
    return np.linalg.norm(points - centre, axis=1) < NEAR_RATIO * radius


def _gauss(points, patches):
    """Gauss rule on (sub-)patches: points (p, 3), patches (p, 4, 6+) (corners, corner
    normals) -> (p, 4) corner weights and (p,) solid angles. Nodes by pairs, (nodes, p)
    planes per axis: one matrix product and contiguous element-wise work."""
    planes = patches[:, :, :6].transpose(1, 2, 0)  # (4, 6, p)
    values = (_RULE_HATS @ planes.reshape(4, -1)).reshape(len(_RULE_HATS), 6, -1)
    relative = values[:, :3] - points.T[None]
    squared = _dot(relative, relative, axis=1)
    kernel = _dot(relative, values[:, 3:], axis=1) * _RULE_WEIGHTS[:, None] / squared ** 2
    return (_RULE_HATS.T @ kernel).T, (kernel * np.sqrt(squared)).sum(axis=0)


def _dot(a, b, axis=-1):
    """Dot products along an axis of length 3 (the last by default)."""
    a, b = np.moveaxis(a, axis, 0), np.moveaxis(b, axis, 0)
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _fan(points, corners):
    """The 4 triangles around each sub-patch's centre, in closed form: (p, 4), (p,)."""
    centre = corners.mean(axis=1, keepdims=True)
    weights, solid = np.zeros((len(points), 4)), np.zeros(len(points))
    for i in range(4):
        triangle = np.concatenate([corners[:, [i, (i + 1) % 4]], centre], axis=1) - points[:, None]
        w, s = triangle_weights(triangle)
        weights[:, [i, (i + 1) % 4]] += w[:, :2]
        weights += 0.25 * w[:, 2:]  # the centre's hat is a quarter of each corner's
        solid += s
    return weights, solid


def _whole_quads(points, corners):
    """The Gauss rule on every (point, quad) pair at once, through matrix products.

    points (k, 3), corners (q, 4, 3), both in a unit-sized frame -> (k, q, 4) corner
    weights and (k, q) solid angles. |y - x|^2 expanded loses digits only where y is near
    x, and those pairs are :func:`_near` and refined.
    """
    nodes = np.matmul(_RULE_HATS, corners).reshape(-1, 3)
    normals = np.matmul(_RULE_HATS, corner_normals(corners)).reshape(-1, 3)
    kernel = points @ normals.T
    np.subtract(_dot(nodes, normals), kernel, out=kernel)
    np.multiply(kernel, np.tile(_RULE_WEIGHTS, len(corners)), out=kernel)
    squared = points @ (-2.0 * nodes.T)
    squared += (nodes ** 2).sum(axis=1)
    squared += (points ** 2).sum(axis=1)[:, None]
    distance = np.sqrt(squared)
    np.multiply(squared, squared, out=squared)
    np.divide(kernel, squared, out=kernel)
    np.multiply(distance, kernel, out=distance)
    shape = len(points), len(corners), len(_RULE_WEIGHTS)
    weights = (kernel.reshape(-1, shape[2]) @ _RULE_HATS).reshape(shape[0], shape[1], 4)
    return weights, distance.reshape(shape).sum(axis=2)


def _subdivide(patches):
    """The 4 children of each sub-patch, children of a pair together: (p, 4, 10) -> (4p,
    4, 10), a sub-patch's corners, its corner normals in its own parameters (the normal
    is bilinear; halving both parameters quarters it) and its corners' hats of the quad's
    corners."""
    children = np.matmul(_CHILDREN, patches[:, None]).reshape(-1, 4, patches.shape[2])
    children[:, :, 3:6] *= 0.25
    return children


def quad_weights(points, corners):
    """Mean value integrals of the corners' bilinear hats over quad patches.

    Parameters
    ----------
    points : (k, 3) float
        In a unit-sized frame (the cage's), none on a patch.
    corners : (q, 4, 3) float
        Each quad's corners, counter-clockwise seen from outside.

    Returns
    -------
    weights : (k, q, 4) float
        The integral of each corner's hat times the mean value kernel.
    solid_angle : (k,) float
        The signed solid angle all the quads subtend at each point.
    """
    weights, solid = _whole_quads(points, corners)
    centre = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centre[:, None], axis=2).max(axis=1)
    distance = np.linalg.norm(points[:, None] - centre[None], axis=2)
    point_index, quad_index = np.nonzero(distance < NEAR_RATIO * radius[None])
    weights[point_index, quad_index] = 0.0
    solid[point_index, quad_index] = 0.0
    solid = solid.sum(axis=1)
    patches = np.concatenate([corners, corner_normals(corners), np.broadcast_to(np.eye(4), (len(corners), 4, 4))],
                             axis=2)[quad_index]
    for level in range(1, DEEPEST_LEVEL + 1):
        if not len(point_index):
            break
        patches = _subdivide(patches)
        point_index, quad_index = np.repeat(point_index, 4), np.repeat(quad_index, 4)
        near = _near(points[point_index], patches[:, :, :3])
        deepest = level == DEEPEST_LEVEL
        done = np.ones_like(near) if deepest else ~near
        local, angle = (_fan(points[point_index[done]], patches[done, :, :3]) if deepest
                        else _gauss(points[point_index[done]], patches[done]))
        np.add.at(weights, (point_index[done], quad_index[done]), np.matmul(local[:, None], patches[done, :, 6:])[:, 0])
        np.add.at(solid, point_index[done], angle)
        point_index, quad_index, patches = point_index[~done], quad_index[~done], patches[~done]
    return weights, solid
