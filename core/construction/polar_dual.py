"""Wachspress weights from the polar dual, in closed form (2D and 3D).

The construction with the polar dual as generating surface (heights 1) gives Wachspress
coordinates. Its weights also have a closed form with far fewer terms (docs/MATH.md,
"Wachspress through the polar dual"): with ``p_T = n_T / det E_T`` the polar dual's
vertex for facet T (``n_T`` the scaled facet normal, :attr:`PreparedCage.facet_normals`), the
weight of vertex v is, up to a constant factor, the volume of the cone from x over the
polar dual's face of v. Cut into one piece per ridge R = {v, ...} with facets p and q:

    2D:  w_v = det(n_p, n_q) / (D_p D_q)                              (R = {v})
    3D:  w_v = -1/2 * sum over edges R at v of s_v (v - x) . (n_p x n_q) / (D_p D_q |v - x|^2)

with ``D = det E`` and s_v = +1 for the ridge's first vertex, -1 for its second. Per
point this is one product per ridge and two affine terms per edge, against the general
form's scalars, three Floater terms per ridge and N-1 minors: Wachspress in 2D and 3D
is evaluated here (tests hold it equal to the construction). In 4D and above the polar
face of a vertex is no longer a polygon, and the construction is used.
"""

from dataclasses import dataclass

import numpy as np

from .general import sum_rows
from ..base.topology import gather_table

__all__ = ["PolarDualTerms", "polar_dual_terms", "wachspress_polar_weights"]

# The construction's weights per unit of the formula's terms, by dimension (the
# orientation conventions of n_p x n_q and det E; tests check both).
_TO_CONSTRUCTION = {2: 1.0, 3: -0.5}


@dataclass(frozen=True)
class PolarDualTerms:
    """Per-cage data of the closed form, one term per (ridge vertex, ridge).

    Attributes
    ----------
    facets : (r, 2) int
        The ridge's two facets p and q.
    term_offsets : (p r, 1) float
    term_normals : (p r, N) float
        Term ``(slot, ridge)`` before the division by ``D_p D_q`` (and, 3D, by
        ``|v - x|^2``) is ``term_offset - term_normal . x`` (x relative to the cage's
        origin); rows are slot-major.
    vertex_terms : (n, w) int
        Gather table of the terms by vertex.
    """

    facets: np.ndarray
    term_offsets: np.ndarray
    term_normals: np.ndarray
    vertex_terms: np.ndarray


def polar_dual_terms(cage):
    """The :class:`PolarDualTerms` of a closed, oriented 2D or 3D cage; None above 3D."""
    dim = cage.dimension
    if dim > 3:
        return None
    topology = cage.topology
    facets, _ = topology.ridge_facets()
    normal_p, normal_q = cage.facet_normals[facets[:, 0]], cage.facet_normals[facets[:, 1]]
    if dim == 2:
        offsets = _TO_CONSTRUCTION[2] * (normal_p[:, 0] * normal_q[:, 1] - normal_p[:, 1] * normal_q[:, 0])
        return PolarDualTerms(facets, offsets[:, None], np.zeros((len(offsets), 2)),
                              gather_table(topology.ridges[:, 0], len(cage.vertices)))
    along_edge = np.cross(normal_p, normal_q)  # (r, 3)
    offsets, normals = [], []
    for slot, sign in enumerate((1.0, -1.0)):
        scale = _TO_CONSTRUCTION[3] * sign
        corners = cage.vertices[topology.ridges[:, slot]]
        offsets.append(scale * np.einsum("rN,rN->r", corners, along_edge))
        normals.append(scale * along_edge)
    return PolarDualTerms(facets, np.concatenate(offsets)[:, None], np.concatenate(normals),
                          gather_table(topology.ridges.T.reshape(-1), len(cage.vertices)))


def wachspress_polar_weights(cage, terms, frame):
    """Homogeneous Wachspress weights of a chunk of points by the closed form.

    Parameters
    ----------
    cage : gencoords.construction.general.PreparedCage
    terms : PolarDualTerms
    frame : gencoords.construction.general.PointFrame
        Of the k points, with their facet determinants.

    Returns
    -------
    weights : (n, k) float
        Equal to the construction's (:func:`gencoords.weights` with kind="wachspress").
    """
    with np.errstate(divide="ignore", invalid="ignore"):  # poles: the caller takes limits
        inverse_det = 1.0 / frame.facet_det
    ridges = len(terms.facets)
    per_ridge = np.take(inverse_det, terms.facets[:, 0], axis=0)
    per_ridge *= np.take(inverse_det, terms.facets[:, 1], axis=0)  # 1 / (D_p D_q)
    slots = len(terms.term_offsets) // ridges
    values = np.empty((len(terms.term_offsets) + 1, per_ridge.shape[1]))
    values[-1] = 0.0  # the gather table's padding
    rows = values[:-1].reshape(slots, ridges, -1)
    if cage.dimension == 2:
        np.multiply(terms.term_offsets.reshape(1, ridges, 1), per_ridge, out=rows)
        return sum_rows(values, terms.vertex_terms)
    np.matmul(terms.term_normals, -frame.centred_points.T, out=values[:-1])
    values[:-1] += terms.term_offsets
    rows *= per_ridge
    weights = sum_rows(values, terms.vertex_terms)
    with np.errstate(divide="ignore", invalid="ignore"):
        weights /= frame.vertex_lengths_squared
    return weights
