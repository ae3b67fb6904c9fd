"""Mean value integrals over triangles and bilinear quad patches (docs/MATH.md, "Quad cages").

The mean value weight of a cage vertex j at a point x is the integral over the cage of
``phi_j(y) (y - x).n(y) / |y - x|^4 dA(y)``: the solid angle the cage subtends at x,
each direction weighted by ``phi_j / |y - x|`` (``phi_j`` the linear hat on a triangle,
the bilinear hat on a quad ``p(u, v) = (1-u)(1-v) c0 + u(1-v) c1 + uv c2 + (1-u)v c3``).
On a triangle the integral has a closed form (:func:`triangle_weights`). On a quad
(:func:`quad_weights`), far from x a 4 x 4 Gauss rule; near, the patch is cut into
strips across u: along v a bilinear patch is straight, its ``(y - x).n`` linear in v and
``|y - x|^2`` quadratic, so the integral along v has a closed form (:func:`line_integrals`)
and only u takes a Gauss rule, a strip halved where x is near it for its width. Each quad
is first listed from a corner chosen by its corners as a set (:func:`canonical_rolls`),
so the result does not depend on which corner a quad lists first.
"""

import numpy as np

__all__ = ["triangle_weights", "corner_normals", "bilinear_hats", "patch_rule", "line_integrals",
           "canonical_rolls", "quad_weights", "FAR_RATIO", "STRIP_BANDS", "DEEPEST_LEVEL"]

# A pair nearer a quad's centre than this many of its radii (to its farthest corner) is
# integrated strip by strip; farther, the 4 x 4 rule on the whole quad, all pairs through
# matrix products. Measured on the artist fixtures: from 3 radii against the 3 x 3 rule
# from 4, the cape and the hand 15 to 30 % faster, the others level (5 x 5 from 2.5: the
# cape and the hand as fast, the character and the quadruped slower); the coordinates
# within 1.4e-7 of a converged rule (10 x 10 from 6 radii, strips of 14 to 20 nodes).
FAR_RATIO = 3.0
_FAR_ORDER = 4
# The Gauss-Legendre rule in u of a strip by the distance of x from the strip's middle line
# (v at its middle u) in the strip's half-widths (along u): (from this ratio, nodes),
# farthest first; nearer than the last, the strip is halved. Measured against 30 to 60
# nodes on the artist fixtures: the pairs' error under 5e-8 of a point's weights, 6 to 10
# nodes a pair (a 10-node band from 1 half-width: 3e-4).
STRIP_BANDS = ((4.0, 4), (2.5, 6), (1.5, 10))
# Strips this many halvings thin are narrower than float64 resolves: the last rule.
DEEPEST_LEVEL = 60
# (point, quad, node) entries of a block of the far rule's temporaries: about a
# processor's cache (2 MB), where the element-wise passes run several times as fast.
_BLOCK_ENTRIES = 1 << 18
_STRIP_ENTRIES = 1 << 13  # (strip, node) entries of a block: 10 quantities each
# A line nearer x than this (|a x b|^2, unit-sized frame) subtends nothing measurable: its
# closed form would divide rounding by zero.
_LINE_FLOOR = 1e-30


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


_FAR_RULE = patch_rule(_FAR_ORDER)


def _dot(a, b, axis=-1):
    """Dot products along an axis of length 3 (the last by default)."""
    a, b = np.moveaxis(a, axis, 0), np.moveaxis(b, axis, 0)
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _whole_quads(points, corners):
    """The Gauss rule on every (point, quad) pair at once, through matrix products.

    points (k, 3), corners (q, 4, 3), both in a unit-sized frame -> (k, q, 4) corner
    weights and (k, q) solid angles. |y - x|^2 expanded loses digits only where y is near
    x, and those pairs are redone strip by strip (:func:`quad_weights`).
    """
    hats, node_weights = _FAR_RULE
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


def canonical_rolls(corners):
    """How far to roll each quad's corners so that u runs along its shorter pair of sides,
    from the lowest corner (x, then y, then z) of the two choices (of four, for equal
    pairs): chosen from the corners as a set, the same whichever corner is listed first.

    Parameters
    ----------
    corners : (q, 4, 3) float

    Returns
    -------
    rolls : (q,) int
        Rolled corner k is listed corner ``(k + rolls) % 4``.
    """
    sides = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=2)
    along_u = sides + np.roll(sides, -2, axis=1)  # a roll's sides along u: r and r + 2
    quad = np.repeat(np.arange(len(corners)), 4)
    order = np.lexsort((corners[..., 2].ravel(), corners[..., 1].ravel(), corners[..., 0].ravel(),
                        along_u.ravel(), quad))
    return order[::4] % 4


def _strip_rule(order):
    """The Gauss-Legendre rule on [0, 1]: (n,) nodes g, (3, n) powers 1, g, g^2 and (n, 2)
    columns w, w g (a node's weight, times its node)."""
    nodes, weights = np.polynomial.legendre.leggauss(order)
    nodes, weights = 0.5 * (nodes + 1.0), 0.5 * weights
    return nodes, np.vander(nodes, 3, increasing=True).T, np.stack([weights, weights * nodes], axis=1)


_STRIP_RULES = [_strip_rule(order) for _, order in STRIP_BANDS]


def line_integrals(c_x, c_y, c_z, alpha, beta, delta, start_dot_end, gamma, s0, s1):
    """The integrals along v of the lines ``y = x + a + v b`` (v in [0, 1]) of a patch.

    With ``c = a x b``, ``(y - x).n = s0 + v s1`` (n the patch's ``p_u x p_v``; along a
    line ``b.n = 0``) and ``|y - x|^2 = q(v) = alpha + 2 beta v + delta v^2``, ``alpha =
    a.a``, ``beta = a.b``, ``delta = b.b``, ``gamma = |a + b|^2 = q(1)``, ``start_dot_end =
    a.(a + b)``; ``D = |c|^2 = alpha delta - beta^2``. The antiderivatives of ``v^m / q^2``
    reduce to ``Phi = int dv / q = theta / sqrt(D)``, theta the angle the line subtends.
    Every argument is an array of one shape.

    Returns
    -------
    first, second : float arrays
        ``int (1 - v) (s0 + s1 v) / q^2 dv`` and ``int v (s0 + s1 v) / q^2 dv``.
    solid : float array
        ``int (s0 + s1 v) / q^(3/2) dv``.
    """
    squared = c_x * c_x + c_y * c_y + c_z * c_z
    seen = squared > _LINE_FLOOR
    squared = np.where(seen, squared, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):  # only where not seen: x on the line
        root, root_alpha, root_gamma = np.sqrt(squared), np.sqrt(alpha), np.sqrt(gamma)
        # theta by its half-angle tangent: exact for small angles and for angles near pi.
        phi = 2.0 * np.arctan(root / (root_alpha * root_gamma + start_dot_end)) / root
        to_alpha, to_gamma, to_delta = 1.0 / alpha, 1.0 / gamma, 1.0 / delta
        j0 = ((delta + beta) * to_gamma - beta * to_alpha + delta * phi) * (0.5 / squared)
        j1 = (0.5 * (to_alpha - to_gamma) - beta * j0) * to_delta
        j2 = (phi - 2.0 * beta * j1 - alpha * j0) * to_delta
        second = s0 * j1 + s1 * j2
        first = s0 * j0 + s1 * j1 - second
        k0 = ((delta + beta) / root_gamma - beta / root_alpha) / squared
        k1 = (1.0 / root_alpha - 1.0 / root_gamma - beta * k0) * to_delta
        solid = s0 * k0 + s1 * k1
        return np.where(seen, first, 0.0), np.where(seen, second, 0.0), np.where(seen, solid, 0.0)


def _pair_quadratics(edges):
    """The quantities of :func:`line_integrals` as quadratics in u, for (point, quad)
    pairs: edges (4, 3, p) (:func:`_edges`) -> (p, 3, 10), the coefficients of 1, u, u^2
    of each quantity in its order there.

    ``a(u) = r0 + u A``, ``b(u) = B0 + u B1``, ``p_u = A + v B1``: c, alpha, beta, delta
    quadratic, s0 = -A.c and s1 = -B1.c (linear: A.(A x B1) = B1.(r0 x B1) = 0). Taken
    from x, as the line integrals need near x; by axis, each a contiguous row.
    """
    r0, a, b0, b1 = edges
    table = np.empty((3, 10, r0.shape[1]))
    table[0, :3], table[2, :3] = _cross(r0, b0), _cross(a, b1)
    table[1, :3] = _cross(r0, b1) + _cross(a, b0)
    table[:, 3] = _dot(r0, r0, 0), 2.0 * _dot(r0, a, 0), _dot(a, a, 0)
    table[:, 4] = _dot(r0, b0, 0), _dot(r0, b1, 0) + _dot(a, b0, 0), _dot(a, b1, 0)
    table[:, 5] = _dot(b0, b0, 0), 2.0 * _dot(b0, b1, 0), _dot(b1, b1, 0)
    table[:, 6] = table[:, 3] + table[:, 4]
    table[:, 7] = table[:, 6] + table[:, 4] + table[:, 5]
    table[:, 8] = -_dot(a, table[:, :3].transpose(1, 0, 2), 0)
    table[:, 9] = -_dot(b1, table[:, :3].transpose(1, 0, 2), 0)
    return np.ascontiguousarray(table.transpose(2, 0, 1))


def _cross(u, w):
    """Cross products of (3, ...) arrays along their first axis."""
    return np.stack([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]])


def _edges(points, corners):
    """r0 = c0 - x, A = c1 - c0, B0 = c3 - c0, B1 = c2 - c3 - A: points (p, 3), corners
    (p, 4, 3) -> (4, 3, p)."""
    by_axis = np.ascontiguousarray(corners.transpose(1, 2, 0))  # (4, 3, p)
    a = by_axis[1] - by_axis[0]
    return np.stack([by_axis[0] - points.T, a, by_axis[3] - by_axis[0], by_axis[2] - by_axis[3] - a])


def _strips(quadratics, start, width, rule):
    """One Gauss rule on strips [start, start + width] of their pairs: quadratics (s, 3, 10)
    (:func:`_pair_quadratics`), start and width (s,) -> (s, 4) corner weights, (s,) solid
    angles. Each quadratic is shifted to the rule's node g (u = start + width g), the nodes'
    values one matrix product, their sums in u another."""
    nodes, powers, sums = rule
    c0, c1, c2 = quadratics[:, 0].T, quadratics[:, 1].T, quadratics[:, 2].T  # (10, s)
    local = np.stack([c0 + start * (c1 + start * c2), width * (c1 + 2.0 * start * c2), width * width * c2], axis=2)
    first, second, solid = line_integrals(*np.matmul(local, powers))  # (10, s, 3) @ (3, n)
    (first, first_u), (second, second_u) = (first @ sums).T * width, (second @ sums).T * width
    first_u, second_u = first_u * width, second_u * width
    return (np.stack([(1.0 - start) * first - first_u, start * first + first_u, start * second + second_u,
                      (1.0 - start) * second - second_u], axis=1), solid @ sums[:, 0] * width)


def _strip_bands(relative, start, width, reach):
    """Which of ``STRIP_BANDS`` each strip takes by the distance of x from its middle line
    in its half-widths: relative (s, 4, 3) (:func:`_edges`), start, width and reach (s,)
    (the longer side along u) -> (s,) int, len(STRIP_BANDS) to halve."""
    middle = (start + 0.5 * width)[:, None]
    begin, along = relative[:, 0] + middle * relative[:, 1], relative[:, 2] + middle * relative[:, 3]
    t = np.clip(-_dot(begin, along) / _dot(along, along), 0.0, 1.0)
    nearest = begin + t[:, None] * along
    ratios = _dot(nearest, nearest) / (0.5 * width * reach) ** 2
    return np.searchsorted(-np.array([r * r for r, _ in STRIP_BANDS]), -ratios, side="left")


def _near_pairs(points, corners):
    """The mean value integrals of (point, quad) pairs strip by strip: points (p, 3),
    corners (p, 4, 3) rolled -> (p, 4) corner weights, (p,) solid angles. The strips are
    chosen level by level, then each rule runs once on all of its strips (a call's numpy
    overhead is worth tens of strips)."""
    edges = _edges(points, corners)
    quadratics = _pair_quadratics(edges)
    accepted = _accepted_strips(np.ascontiguousarray(edges.transpose(2, 0, 1)), np.sqrt(np.maximum(
        _dot(edges[1], edges[1], 0), _dot(edges[1] + edges[3], edges[1] + edges[3], 0))))
    owners, parts = [], []
    for rule, (pair, start, width) in zip(_STRIP_RULES, accepted):
        step = max(1, _STRIP_ENTRIES // len(rule[0]))
        for block in range(0, len(pair), step):
            taken = slice(block, block + step)
            local, angle = _strips(quadratics[pair[taken]], start[taken], width[taken], rule)
            owners.append(pair[taken])
            parts.append(np.column_stack([local, angle]))
    owner, part = (np.concatenate(x) if x else np.zeros((0,) * (1 + i)) for i, x in enumerate((owners, parts)))
    sums = np.stack([np.bincount(owner.astype(int), part[:, i], len(points)) for i in range(5)], axis=1)
    return sums[:, :4], sums[:, 4]


def _accepted_strips(relative, reach):
    """The strips of each pair and the rule each takes, halving those too near: relative
    (p, 4, 3) (:func:`_edges`), reach (p,) the longer side along u -> for each of
    ``STRIP_BANDS``, (s,) pairs, starts and widths."""
    pair, start, width = np.arange(len(reach)), np.zeros(len(reach)), np.ones(len(reach))
    accepted = [[] for _ in STRIP_BANDS]
    for level in range(DEEPEST_LEVEL + 1):
        band = _strip_bands(relative[pair], start, width, reach[pair])
        if level == DEEPEST_LEVEL:
            band = np.minimum(band, len(STRIP_BANDS) - 1)
        for rule, strips in enumerate(accepted):
            chosen = band == rule
            strips.append((pair[chosen], start[chosen], width[chosen]))
        halved = np.flatnonzero(band == len(STRIP_BANDS))
        if not len(halved):
            break
        pair, width = np.repeat(pair[halved], 2), np.repeat(0.5 * width[halved], 2)
        start = np.repeat(start[halved], 2) + np.tile([0.0, 1.0], len(halved)) * width
    return [[np.concatenate(column) for column in zip(*strips)] for strips in accepted]


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
    rolls = canonical_rolls(corners)
    listed = (np.arange(4) + rolls[:, None]) % 4
    corners = np.take_along_axis(corners, listed[:, :, None], axis=1)
    block = max(1, _BLOCK_ENTRIES // (max(len(corners), 1) * len(_FAR_RULE[1])))
    weights, solid = (np.concatenate(parts) for parts in zip(
        *[_whole_quads(points[start:start + block], corners) for start in range(0, max(len(points), 1), block)]))
    centre = corners.mean(axis=1)
    radius = ((corners - centre[:, None]) ** 2).sum(axis=2).max(axis=1)
    distance = _dot(points, points)[:, None] - 2.0 * points @ centre.T + _dot(centre, centre)  # squared
    point_index, quad_index = np.nonzero(distance < FAR_RATIO ** 2 * radius[None])
    solid[point_index, quad_index] = 0.0
    weights[point_index, quad_index], near_solid = _near_pairs(points[point_index], corners[quad_index]) if len(
        point_index) else (0.0, np.zeros(0))
    solid = solid.sum(axis=1) + np.bincount(point_index, near_solid, len(points))
    unrolled = np.empty_like(weights)
    unrolled[:, np.arange(len(corners))[:, None], listed] = weights
    return unrolled, solid
