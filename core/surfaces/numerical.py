"""Ridge scalars of any star-shaped generating surface, by numerical integration.

A surface star-shaped around x is a radius ``rho(u)`` per unit direction u. The region
it encloses with a ridge R, seen from x, is the cone over R's spherical simplex S_R cut
at distance rho, so (docs/MATH.md, "Any surface: numerical ridge scalars")

    d_R = 1/(N-1) * integral over S_R of rho(u)^(N-1) du.

S_R is cut into pieces by geodesic subdivision: the simplex spanned by the unit vectors
``u_a = e_a / l_a`` is split ``levels`` times into 2^(N-2) (Freudenthal's subdivision),
each new corner pushed back onto the sphere, so that every piece is small on the sphere
however close x is to the ridge. On a piece with unit corners c, pulled back to their
flat simplex (points ``y = sum_j b_j c_j``), ``du = |m(c)| db / |y|^(N-1)`` with
``|m(c)|`` the generalized cross product's norm; a Gauss rule of ``_PIECE_NODES`` points
per direction integrates each piece. The error falls by about 2^(2 _PIECE_NODES) per
level for smooth surfaces; the unit sphere (mean value) needs only the Gram matrices.
"""

import itertools
from functools import lru_cache

import numpy as np

from ..base.simplex import generalized_cross

__all__ = ["DEFAULT_LEVELS", "simplex_rule", "geodesic_pieces", "unit_sphere_ridge_scalars",
           "surface_ridge_scalars"]

# Subdivision levels by default. Measured (tests/core/test_surfaces.py): mean value to
# about 1e-9 relative in 3D and 4e-7 in 4D at interior points of random polytopes.
# Cost: 2^((N-2) levels) pieces per ridge.
DEFAULT_LEVELS = 5
# Gauss points per direction on each piece.
_PIECE_NODES = 3
# Above 4D, mean value coordinates use fewer levels (8^levels pieces per ridge in 5D).
_MEAN_VALUE_LEVELS_ABOVE_4D = 3
# Pieces evaluated at once (bounds the (pieces, p, p, r k) temporaries).
_PIECE_BATCH = 64


@lru_cache(maxsize=32)
def simplex_rule(corners, nodes):
    """A Gauss rule on the standard simplex with ``corners`` vertices (dimension corners-1).

    Collapsed coordinates t in [0, 1]^q, q = corners - 1: ``b_0 = 1 - t_1``,
    ``b_j = t_1 ... t_j (1 - t_{j+1})``, ``b_q = t_1 ... t_q``, with Jacobian
    ``prod_j t_j^(q-j)``; Gauss-Legendre in each t.

    Parameters
    ----------
    corners : int
        p >= 1 (p = 1: the single point, weight 1).
    nodes : int
        Points per direction.

    Returns
    -------
    barycentric : (Q, p) float
        Q = nodes^(p-1) nodes.
    weights : (Q,) float
        Summing to the simplex's measure ``1 / (p-1)!``.
    """
    dimension = corners - 1
    if dimension == 0:
        return np.ones((1, 1)), np.ones(1)
    abscissae, gauss = np.polynomial.legendre.leggauss(nodes)
    abscissae, gauss = 0.5 * (abscissae + 1.0), 0.5 * gauss
    grid = np.stack(np.meshgrid(*[abscissae] * dimension, indexing="ij"), axis=-1).reshape(-1, dimension)
    weights = np.prod(np.stack(np.meshgrid(*[gauss] * dimension, indexing="ij"), axis=-1)
                      .reshape(-1, dimension), axis=1)
    barycentric = np.empty((len(grid), corners))
    running = np.ones(len(grid))
    for j in range(dimension):
        barycentric[:, j] = running * (1.0 - grid[:, j])
        weights *= grid[:, j] ** (dimension - 1 - j)  # the collapse's Jacobian
        running = running * grid[:, j]
    barycentric[:, dimension] = running
    barycentric.flags.writeable = weights.flags.writeable = False
    return barycentric, weights


@lru_cache(maxsize=8)
def _freudenthal(dimension):
    """The 2^q simplices of Freudenthal's subdivision of a q-simplex: (2^q, q+1, q+1)
    barycentric corners (row j: corner j of the piece in the parent's coordinates).

    In coordinates ``x_i = b_i + ... + b_q`` the simplex is 1 >= x_1 >= ... >= x_q >= 0;
    doubled, it is cut by Kuhn's triangulation of the unit cubes into the simplices
    ``z, z + e_pi1, z + e_pi1 + e_pi2, ...`` that stay inside it.
    """
    pieces = []
    for base in itertools.product((0, 1), repeat=dimension):
        for order in itertools.permutations(range(dimension)):
            corners = [np.array(base, dtype=float)]
            for axis in order:
                corners.append(corners[-1].copy())
                corners[-1][axis] += 1.0
            corners = np.array(corners)
            if (corners[:, :-1] >= corners[:, 1:]).all() and corners.max() <= 2.0:
                cumulative = np.concatenate([np.full((dimension + 1, 1), 2.0), corners,
                                             np.zeros((dimension + 1, 1))], axis=1) / 2.0
                pieces.append(cumulative[:, :-1] - cumulative[:, 1:])
    return np.array(pieces)


@lru_cache(maxsize=32)
def geodesic_pieces(corners, levels):
    """Barycentric corners of the pieces after ``levels`` subdivisions: (S, p, p) float."""
    dimension = corners - 1
    pieces = np.eye(corners)[None]
    if dimension == 0:
        return pieces
    split = _freudenthal(dimension)
    for _ in range(levels):
        pieces = np.einsum("sij,tjk->tsik", split, pieces).reshape(-1, corners, corners)
    pieces.flags.writeable = False
    return pieces


def unit_sphere_ridge_scalars(gram, measure, levels=None):
    """d of the unit sphere (mean value) for any ridge size, numerically, from Gram matrices.

    A piece's corners are unit combinations of the ``u_a``, so their Gram matrix ``C``
    follows from the ridge's; then ``|m(c)| = sqrt(det C)`` and ``|y|^2 = b^T C b``.

    Parameters
    ----------
    gram : (p, p, r, k) float
        The ridges' Gram matrices of ``e = v - x`` (:attr:`PointFrame.ridge_gram`).
    measure : (r, k) float
        ``|m_R|`` (only its shape and zeros are used: a ridge through x encloses nothing).
    levels : int, optional
        Subdivision levels; default ``DEFAULT_LEVELS`` up to 4D, fewer above.

    Returns
    -------
    d : (r, k) float
    """
    size = gram.shape[0]
    if levels is None:
        levels = DEFAULT_LEVELS if size <= 3 else _MEAN_VALUE_LEVELS_ABOVE_4D
    with np.errstate(divide="ignore", invalid="ignore"):
        lengths = np.sqrt(np.stack([gram[a, a] for a in range(size)]))  # (p, r, k)
        unit_gram = gram / (lengths[:, None] * lengths[None, :])
    flat = np.moveaxis(unit_gram.reshape(size, size, -1), -1, 0)  # (r k, p, p)
    barycentric, weights = simplex_rule(size, _PIECE_NODES)
    pieces = geodesic_pieces(size, levels)
    total = np.zeros(len(flat))
    for start in range(0, len(pieces), _PIECE_BATCH):
        corner = pieces[start:start + _PIECE_BATCH]  # (s, p, p)
        piece_gram = np.einsum("sia,Rab,sjb->Rsij", corner, flat, corner, optimize=True)
        norms = np.sqrt(np.einsum("Rsii->Rsi", piece_gram))
        piece_gram /= norms[..., :, None] * norms[..., None, :]  # corners on the sphere
        volume = np.sqrt(np.maximum(np.linalg.det(piece_gram), 0.0))  # |m(c)|
        squared = np.einsum("qi,Rsij,qj->Rsq", barycentric, piece_gram, barycentric, optimize=True)
        total += np.einsum("Rs,Rsq,q->R", volume, squared ** (-0.5 * size), weights)
    d = total.reshape(measure.shape) / size
    return np.where(measure > 0.0, d, 0.0)


def surface_ridge_scalars(corners, points, radius, levels=DEFAULT_LEVELS):
    """d of a star-shaped surface given by its radius function, for one chunk of points.

    Parameters
    ----------
    corners : (r, p, N) float
        The ridges' vertices.
    points : (k, N) float
    radius : callable
        ``radius(points, directions)``: (k, N) and (k, s, N) unit vectors to (k, s)
        distances from each point to its surface along each direction.
    levels : int

    Returns
    -------
    d : (k, r) float
    """
    count, size, dim = corners.shape
    barycentric, weights = simplex_rule(size, _PIECE_NODES)
    pieces = geodesic_pieces(size, levels)
    spokes = corners[None] - points[:, None, None, :]  # e: (k, r, p, N)
    units = spokes / np.linalg.norm(spokes, axis=-1, keepdims=True)
    piece_corners = np.einsum("sja,kraN->krsjN", pieces, units)
    piece_corners /= np.linalg.norm(piece_corners, axis=-1, keepdims=True)
    along = np.einsum("qj,krsjN->krsqN", barycentric, piece_corners)  # y
    lengths = np.linalg.norm(along, axis=-1)
    shape = lengths.shape
    rho = np.asarray(radius(points, (along / lengths[..., None]).reshape(len(points), -1, dim)),
                     dtype=np.float64)
    if rho.shape != (len(points), lengths[0].size):
        raise ValueError(f"radius(points, directions) must return shape (k, s) = "
                         f"{(len(points), lengths[0].size)}, got {rho.shape}")
    if not (np.isfinite(rho).all() and (rho > 0.0).all()):
        raise ValueError("radius(points, directions) must return finite positive distances "
                         "(the surface must be star-shaped around every point)")
    volume = np.linalg.norm(generalized_cross(np.moveaxis(piece_corners, (3, 4), (0, 1))), axis=0)
    integrand = (rho.reshape(shape) / lengths) ** (dim - 1)
    return np.einsum("krs,krsq,q->kr", volume, integrand, weights) / (dim - 1)
