"""Mean value integrals over triangles and bilinear quad patches (docs/MATH.md, "Quad cages").

The mean value weight of a cage vertex j at a point x is the integral over the cage of
``phi_j(y) (y - x).n(y) / |y - x|^4 dA(y)``: the solid angle the cage subtends at x,
each direction weighted by ``phi_j / |y - x|`` (``phi_j`` the linear hat on a triangle,
the bilinear hat on a quad ``p(u, v) = (1-u)(1-v) c0 + u(1-v) c1 + uv c2 + (1-u)v c3``).
On a triangle the integral has a closed form (:func:`triangle_weights`). On a quad it is
integrated numerically (:func:`quad_weights`): a quadtree over (u, v) refined where a
sub-patch is close to x for its size, each accepted sub-patch by a tensor Gauss-Legendre
rule of as few nodes as its distance allows (``BANDS``); at the deepest level a sub-patch is flat to rounding and its fan of 4 triangles
around its centre takes the closed form. Every choice depends only on the sub-patches'
corners as a set, so the result does not depend on which corner a quad lists first.
"""

import numpy as np

__all__ = ["triangle_weights", "corner_normals", "bilinear_hats", "patch_rule", "quad_weights",
           "BANDS", "NEAR_RATIO", "DEEPEST_LEVEL"]

# The Gauss-Legendre rule of a (sub-)patch by how far a point is from it, in its radii
# (from its centre to its farthest corner): (from this ratio, nodes per side), farthest
# first; nearer than the last (NEAR_RATIO), the patch is halved (:func:`_subdivide`). A rule's
# relative error on a pair falls like rho ** (-2 * order), rho growing with the ratio;
# each band's worst is about 1e-4 of the pair's share on a skewed or 1:4 quad, the pair's
# share falling like ratio ** -3 (measured against a 14 x 14 rule on a fine quadtree).
BANDS = ((4.0, 3), (3.0, 4), (2.0, 5), (1.5, 8), (1.25, 10))
NEAR_RATIO = BANDS[-1][0]
# Sub-patches this many halvings deep are flat to float64 rounding: fan of 4 triangles.
DEEPEST_LEVEL = 40
# (point, quad, node) entries of a block of the Gauss rule's temporaries: about a
# processor's cache (2 MB), where the element-wise passes run several times as fast.
_BLOCK_ENTRIES = 1 << 18
_GAUSS_ENTRIES = 1 << 14  # (pair, node) entries: with the pairs' own temporaries


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


def patch_rule(order):
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


def _pair_rule(order):
    """:func:`patch_rule` with the nodes' products of hats, ``hats_i hats_j`` at column
    ``4 i + j``, then the same times the node's weight: (n, 4), (2, n, 16), (n,)."""
    hats, weights = patch_rule(order)
    products = (hats[:, :, None] * hats[:, None]).reshape(len(hats), 16)
    return hats, np.stack([products, weights[:, None] * products]), weights


_RULES = [_pair_rule(order) for _, order in BANDS]
# Child c's corners as mixes of its parent's: the quadtree's split at the midpoints.
_MIDPOINTS = np.array([[1, 0, 0, 0], [.5, .5, 0, 0], [0, 1, 0, 0], [0, .5, .5, 0], [0, 0, 1, 0],
                       [0, 0, .5, .5], [0, 0, 0, 1], [.5, 0, 0, .5], [.25, .25, .25, .25]])
_CHILDREN = _MIDPOINTS[[[0, 1, 8, 7], [1, 2, 3, 8], [8, 3, 4, 5], [7, 8, 5, 6]]]  # (4, 4, 4)
# An elongated sub-patch (its sides along one parameter this many times the other's) is
# halved across its length only, so that its children tend to squares: a 1:10 quad halved
# both ways stays 1:10 and needs ten times the children along a near point. Not a round
# number: a grid cage's quads are 1:2 and 1:3, exactly, and rounding must not decide.
_ELONGATED = 2.3
# Halving v, then halving u: (kind of split, children, the parent's normal's scale).
_SPLITS = ((_MIDPOINTS[[[0, 2, 3, 7], [7, 3, 4, 6]]], 0.5), (_MIDPOINTS[[[0, 1, 5, 6], [1, 2, 4, 5]]], 0.5),
           (_CHILDREN, 0.25))


def _bands(points, patches):
    """Which of ``_RULES`` each (point, sub-patch) pair takes, by the point's distance
    from the patch's centre (the corners' mean) in its radii (to its farthest corner),
    both the same whichever corner is listed first: points (p, 3), patches (4, 10+, p) ->
    (p,) int, len(_RULES) where the pair is too near and the patch is halved."""
    corners = patches[:, :3]
    centre = corners.mean(axis=0)
    radius = _dot(corners - centre, corners - centre, axis=1).max(axis=0)
    return _band_of(_dot(points.T - centre, points.T - centre, axis=0) / radius)


def _band_of(squared_ratios):
    """:func:`_bands` from the squared ratios: (p,) -> (p,) int."""
    return np.searchsorted(-np.array([ratio ** 2 for ratio, _ in BANDS]), -squared_ratios, side="left")


def _gauss(points, patches, rule):
    """A Gauss rule on (sub-)patches: points (p, 3), patches (4, 6+, p) (corners, corner
    normals), rule (:func:`_pair_rule`) -> (4, p) corner weights and (p,) solid angles.

    With the corners taken from the point, ``r_i = c_i - x``, a node's ``|y - x|^2`` and
    ``(y - x).n`` are the quadratic forms ``sum h_i h_j r_i.r_j`` and ``sum h_i h_j
    r_i.n_j``: two matrix products over all nodes, the dot products once a pair. Taken
    from x, the sums lose under a hundred ulps from 1.25 radii on (the terms at most
    (1 + 1.25)^2 / 0.25^2 times the sum). In blocks of about a cache's size.
    """
    hats, products, node_weights = rule
    block = max(1, _GAUSS_ENTRIES // len(node_weights))
    weights, solid = np.empty((4, len(points))), np.empty(len(points))
    for start in range(0, len(points), block):
        rows = slice(start, start + block)
        relative = patches[:, :6, rows].transpose(1, 0, 2).copy()  # (6, 4, b): corners, normals by axis
        relative[:3] -= points[rows].T[:, None]
        # (2, 4, 4, b): r_i.r_j, then r_i.n_j (the products of hats are symmetric in i, j).
        forms = _dot(relative[None, :3, :, None], relative.reshape(2, 3, 1, 4, -1), axis=1)
        squared, kernel = products @ forms.reshape(2, 16, -1)  # |y - x|^2, w (y - x).n
        distance = np.sqrt(squared)
        np.multiply(squared, squared, out=squared)
        np.divide(kernel, squared, out=kernel)
        weights[:, rows] = hats.T @ kernel
        solid[rows] = np.multiply(distance, kernel, out=distance).sum(axis=0)
    return weights, solid


def _dot(a, b, axis=-1):
    """Dot products along an axis of length 3 (the last by default)."""
    a, b = np.moveaxis(a, axis, 0), np.moveaxis(b, axis, 0)
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _fan(points, corners):
    """The 4 triangles around each sub-patch's centre, in closed form: points (p, 3),
    corners (p, 4, 3) -> (4, p) corner weights, (p,) solid angles."""
    centre = corners.mean(axis=1, keepdims=True)
    weights, solid = np.zeros((len(points), 4)), np.zeros(len(points))
    for i in range(4):
        triangle = np.concatenate([corners[:, [i, (i + 1) % 4]], centre], axis=1) - points[:, None]
        w, s = triangle_weights(triangle)
        weights[:, [i, (i + 1) % 4]] += w[:, :2]
        weights += 0.25 * w[:, 2:]  # the centre's hat is a quarter of each corner's
        solid += s
    return weights.T, solid


def _whole_quads(points, corners):
    """The Gauss rule on every (point, quad) pair at once, through matrix products.

    points (k, 3), corners (q, 4, 3), both in a unit-sized frame -> (k, q, 4) corner
    weights and (k, q) solid angles. |y - x|^2 expanded loses digits only where y is near
    x, and those pairs are refined (:func:`quad_weights`).
    """
    hats, _, node_weights = _RULES[0]
    nodes = np.matmul(hats, corners).reshape(-1, 3)
    normals = np.matmul(hats, corner_normals(corners)).reshape(-1, 3) * np.tile(node_weights, len(corners))[:, None]
    # w (y - x).n and |y - x|^2, each one matrix product with the points lifted to [x, 1, |x|^2].
    lifted = np.column_stack([points, np.ones(len(points)), _dot(points, points)])
    kernel = lifted[:, :4] @ np.vstack([-normals.T, _dot(nodes, normals)])
    squared = lifted @ np.vstack([-2.0 * nodes.T, _dot(nodes, nodes), np.ones(len(nodes))])
    distance = np.sqrt(squared)
    np.multiply(squared, squared, out=squared)
    np.divide(kernel, squared, out=kernel)
    np.multiply(distance, kernel, out=distance)
    shape = len(points), len(corners), len(node_weights)
    weights = (kernel.reshape(-1, shape[2]) @ hats).reshape(shape[0], shape[1], 4)
    return weights, distance.reshape(shape).sum(axis=2)


def _subdivide(patches):
    """The children of each sub-patch: (4, 10, p) -> (4, 10, c) and (c,) the parent of
    each; 2 children across an elongated patch's length, else 4. By corner, a sub-patch's
    corners, its corner normals in its own parameters (the normal is bilinear; halving a
    parameter halves it) and its corners' hats of the quad's corners. Whether a patch is
    elongated compares sums of opposite sides, the same whichever corner is listed first."""
    corners = patches[:, :3]
    sides = np.sqrt(_dot(np.roll(corners, -1, axis=0) - corners, np.roll(corners, -1, axis=0) - corners, axis=1))
    along_u, along_v = sides[0] + sides[2], sides[1] + sides[3]
    split = np.where(along_u > _ELONGATED * along_v, 1, np.where(along_v > _ELONGATED * along_u, 0, 2))
    parts, parents = [], []
    for kind, (mixes, scale) in enumerate(_SPLITS):
        which = np.flatnonzero(split == kind)
        children = (mixes.reshape(-1, 4) @ patches[:, :, which].reshape(4, -1)).reshape(len(mixes), 4, 10, -1)
        children[:, :, 3:6] *= scale
        parts.append(children.transpose(1, 2, 0, 3).reshape(4, 10, -1))
        parents.append(np.tile(which, len(mixes)))
    return np.concatenate(parts, axis=2), np.concatenate(parents)


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
    block = max(1, _BLOCK_ENTRIES // (max(len(corners), 1) * len(_RULES[0][2])))
    weights, solid = (np.concatenate(parts) for parts in zip(
        *[_whole_quads(points[start:start + block], corners) for start in range(0, max(len(points), 1), block)]))
    centre = corners.mean(axis=1)
    radius = ((corners - centre[:, None]) ** 2).sum(axis=2).max(axis=1)
    distance = _dot(points, points)[:, None] - 2.0 * points @ centre.T + _dot(centre, centre)  # squared
    point_index, quad_index = np.nonzero(distance < BANDS[0][0] ** 2 * radius[None])
    weights[point_index, quad_index] = 0.0
    solid[point_index, quad_index] = 0.0
    band = _band_of(distance[point_index, quad_index] / radius[quad_index])
    order = np.argsort(band, kind="stable")
    point_index, quad_index = point_index[order], quad_index[order]
    patches = np.concatenate([corners, corner_normals(corners), np.broadcast_to(np.eye(4), (len(corners), 4, 4))],
                             axis=2).transpose(1, 2, 0)[:, :, quad_index]
    solid = solid.sum(axis=1)
    _refine(points, weights, solid, point_index, quad_index, patches, band[order])
    return weights, solid


def _refine(points, weights, solid, point_index, quad_index, patches, band):
    """Add the near pairs' integrals to ``weights`` (k, q, 4) and ``solid`` (k,): each
    (point, sub-patch) pair by the rule of its band (:func:`_bands`), halving those too
    near, the pairs (p,) and (4, 10, p) sub-patches (:func:`_subdivide`) sorted by band."""
    flat_weights = weights.reshape(-1, 4)
    for level in range(DEEPEST_LEVEL + 1):
        if level:
            patches, parents = _subdivide(patches)
            point_index, quad_index = point_index[parents], quad_index[parents]
            band = np.full(len(point_index), -1) if level == DEEPEST_LEVEL else _bands(points[point_index], patches)
            order = np.argsort(band, kind="stable")  # each rule's pairs together
            point_index, quad_index, patches, band = point_index[order], quad_index[order], patches[:, :, order], \
                band[order]
        bounds = np.searchsorted(band, np.arange(-1, len(BANDS) + 1))
        flat = point_index * weights.shape[1] + quad_index
        for rule in range(-1, len(BANDS)):
            done = slice(bounds[rule + 1], bounds[rule + 2])
            if done.start == done.stop:
                continue
            local, angle = (_fan(points[point_index[done]], patches[:, :3, done].transpose(2, 0, 1)) if rule < 0
                            else _gauss(points[point_index[done]], patches[:, :, done], _RULES[rule]))
            if level:
                np.add.at(flat_weights, flat[done], (local[:, None] * patches[:, 6:, done]).sum(axis=0).T)
            else:  # the whole quads, each pair once
                flat_weights[flat[done]] += local.T
            np.add.at(solid, point_index[done], angle)
        near = slice(bounds[-1], None)
        point_index, quad_index, patches = point_index[near], quad_index[near], patches[:, :, near]
        if not len(point_index):
            return
