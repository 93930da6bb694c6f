"""Sohn & Dowman (2002): ground by tetrahedra and the MDL criterion.

1. Initial model: a rectangle around the data whose corner heights are the mean
   of their TIN neighbours (§4.1).
2. Downward divide-and-conquer: per triangle, the point furthest below joins the
   ground; re-triangulate until no point lies below the TIN (§4.2).
3. Upward divide-and-conquer: every triangle whose buffer space (0 < h ≤ δh) is
   not empty proposes tetrahedra with its member points as apex; candidates that
   leave a point below a lateral facet are rejected; each survivor is scored by
   the description length of Eq. 11–13 over the TIN of the points in its facets,
   and the shortest joins the ground, until no triangle finds a winner (§4.3).

Choices where the paper is silent are in docs/ground.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.ground.ground_tin import GroundTin
from tdb.bbox import column_range
from tdb.tin import (
    Tin,
    angle_between,
    barycentric,
    cross_pairs,
    group_starts,
    locate,
    triangulate,
    unit_normals,
)

EPS = 1e-9


@dataclass(frozen=True)
class SohnParams:
    """δh = 1 m, α = 0.1 and β = 45° as the paper gives them; the below-facet tolerance (0.1 m)
    and the buffer's growth (none), which depart from it, as leave-one-site-out on the ISPRS
    sites chose them (``benchmarks/paper_filters_cv.py``; freeing δh too read worse held out)."""

    delta_h: float = 1.0
    alpha: float = 0.1
    beta: float = 45.0
    max_candidates: int = 16  # lowest member points tried per triangle
    reject_facets: int = 3  # reject when this many lateral facets have a point below (3 = literal; see docs)
    below_tolerance: float = 0.1  # how far below a facet (m) a point must be to count as below
    # the buffer's height grows by this much per metre from the point's nearest ground vertex
    # (0: the paper's fixed δh); terrain rises between sparse ground as it does between returns
    buffer_grade: float = 0.0
    max_iterations: int = 200


def p_on(dtheta: NDArray[np.float64], p: SohnParams) -> NDArray[np.float64]:
    """Eq. 13, 'ons': probability of a smooth triangle with angle difference Δθ (degrees)."""
    return 1.0 / (1.0 + np.exp(p.alpha * (dtheta - p.beta)))


def p_buf(dtheta: NDArray[np.float64], p: SohnParams) -> NDArray[np.float64]:
    """Eq. 13, 'bufs': probability of a discontinuity triangle with angle difference Δθ."""
    return 1.0 / (1.0 + np.exp(-p.alpha * (dtheta - p.beta)))


def description_length(
    dtheta_ons: NDArray[np.float64], dtheta_bufs: NDArray[np.float64], n_offs: int, height: float, p: SohnParams
) -> float:
    """Eq. 12 for one tetrahedron: polarity terms + L(T_out) = −log2 N_offs + L(T_in) = log2 H."""
    return float(
        -np.log2(p_on(dtheta_ons, p)).sum()
        - np.log2(p_buf(dtheta_bufs, p)).sum()
        - np.log2(max(n_offs, 1))
        + np.log2(max(height, 1e-3))
    )


def initial_corners(xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """§4.1: rectangle corners just outside the data, z = mean of their TIN neighbours."""
    lo, hi = column_range(xyz[:, :2])
    pad = 0.01 * (hi - lo).max() + 1.0
    corners = np.array(
        [
            [lo[0] - pad, lo[1] - pad],
            [hi[0] + pad, lo[1] - pad],
            [hi[0] + pad, hi[1] + pad],
            [lo[0] - pad, hi[1] + pad],
        ]
    )
    tri = triangulate(np.vstack([xyz[:, :2], corners]))
    indptr, indices = tri.vertex_neighbor_vertices
    n = len(xyz)
    z = np.empty(4)
    for k in range(4):
        nb = indices[indptr[n + k] : indptr[n + k + 1]]
        nb = nb[nb < n]
        z[k] = xyz[nb, 2].mean() if len(nb) else xyz[:, 2].min()
    return np.column_stack([corners, z])


def _per_group_argmin(group: NDArray[np.intp], value: NDArray[np.float64]) -> NDArray[np.intp]:
    """Index (into the arrays) of the smallest value in each group."""
    order = np.lexsort((value, group))
    g = group[order]
    first = np.r_[True, g[1:] != g[:-1]]
    return order[first]


def downward(xyz: NDArray[np.float64], corners: NDArray[np.float64], p: SohnParams) -> NDArray[np.bool_]:
    """§4.2: grow the ground until no point lies below the TIN. Returns the ground mask."""
    ground = np.zeros(len(xyz), bool)
    for _ in range(p.max_iterations):
        idx, simplex, h = heights_above_tin(xyz, corners, ground)
        neg = h < -EPS
        if not neg.any():
            break
        ground[idx[neg][_per_group_argmin(simplex[neg], h[neg])]] = True
    return ground


def heights_above_tin(
    xyz: NDArray[np.float64], corners: NDArray[np.float64], ground: NDArray[np.bool_]
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """Non-ground point indices, their triangle in the ground TIN and their height above it."""
    verts = np.vstack([corners, xyz[ground]])
    tri = triangulate(verts[:, :2])
    idx = np.flatnonzero(~ground)
    simplex = locate(tri, xyz[idx, :2])
    lam = barycentric(tri, simplex, xyz[idx, :2])
    return idx, simplex, xyz[idx, 2] - (lam * verts[tri.simplices[simplex], 2]).sum(axis=1)


def _buffer_height(
    tin: GroundTin, simplex: NDArray[np.intp], xy: NDArray[np.float64], p: SohnParams
) -> NDArray[np.float64] | float:
    """δh for each point over its TIN triangle: the paper's, grown by ``p.buffer_grade`` per metre
    from the triangle's nearest vertex."""
    if p.buffer_grade == 0.0:
        return p.delta_h
    corners = tin.points[tin.simplices[simplex], :2]  # (F, 3, 2)
    nearest = np.sqrt(((corners - xy[:, None, :]) ** 2).sum(axis=2)).min(axis=1)
    return p.delta_h + p.buffer_grade * nearest


def upward(
    xyz: NDArray[np.float64],
    corners: NDArray[np.float64],
    ground: NDArray[np.bool_],
    p: SohnParams,
    tri_all: Tin,
) -> NDArray[np.bool_]:
    """§4.3: add the MDL-best tetrahedron apex of every triggered triangle until none is found."""
    ground = ground.copy()
    all_tris = tri_all.simplices
    tri_normals = unit_normals(xyz[all_tris[:, 0]], xyz[all_tris[:, 1]], xyz[all_tris[:, 2]])
    tin = GroundTin.build(np.vstack([corners, xyz[ground]]))
    free = np.flatnonzero(~ground)
    simplex = tin.locate(xyz[free, :2])
    for _ in range(p.max_iterations):
        lam = barycentric(tin, simplex, xyz[free, :2])
        vz = tin.points[tin.simplices, 2]
        h = xyz[free, 2] - (lam * vz[simplex]).sum(axis=1)
        in_buffer = (h > EPS) & (h <= _buffer_height(tin, simplex, xyz[free, :2], p))
        if not in_buffer.any():
            break
        # Candidates: every member point of each triggered triangle (the lowest
        # max_candidates of them, which bounds the work on huge early triangles).
        triggered = np.zeros(len(tin.simplices), bool)
        triggered[simplex[in_buffer]] = True
        cand = np.flatnonzero(triggered[simplex] & (h > EPS))
        order = np.lexsort((h[cand], simplex[cand]))
        cand = cand[order]
        _, starts, sizes = group_starts(simplex[cand])
        rank = np.arange(len(cand)) - np.repeat(starts, sizes)
        cand = cand[rank < p.max_candidates]
        # Rejection rule, literally: ∀k φ^ik s^ik < 0, i.e. every lateral facet has a point below it.
        ci, mi = cross_pairs(simplex[cand], simplex)
        columns = np.ascontiguousarray(lam.T)
        apex = cand[ci]
        t, k = _facet_t([c[mi] for c in columns], [c[apex] for c in columns])
        below = h[mi] - t * h[apex] < -p.below_tolerance
        facet_below = np.bincount(3 * ci[below] + k[below], minlength=3 * len(cand)).reshape(-1, 3) > 0
        rejected = facet_below.sum(axis=1) >= p.reject_facets
        cand = cand[~rejected]
        if len(cand) == 0:
            break
        dl = _description_lengths(xyz, free, cand, simplex, lam, h, tin, tri_normals, all_tris, p)
        won = cand[_per_group_argmin(simplex[cand], dl)]
        ground[free[won]] = True
        stay = np.ones(len(free), bool)
        stay[won] = False
        tin, simplex = tin.insert(xyz[free[won]], simplex[won], xyz[free[stay], :2], simplex[stay])
        free = free[stay]
    return ground


def _facet_t(
    p: list[NDArray[np.float64]], a: list[NDArray[np.float64]]
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Share of the apex in point p's height on the lateral facet that holds it.

    With barycentrics λp of p and λa of the apex in the base triangle, given as their three
    columns ``p`` and ``a``, p lies in the facet opposite the vertex k minimising
    λp[k]/λa[k] =: t, and the facet's height over the base plane at p is t·H. Returns (t, k).
    """
    least, k = _least_of_three([p[q] / np.maximum(a[q], EPS) for q in range(3)])
    return np.clip(least, 0.0, 1.0), k


def _least_of_three(r: list[NDArray[np.float64]]) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Elementwise least of three arrays and which one it is (the first on ties): on 1-D
    columns this runs several times faster than ``argmin`` along a short last axis."""
    k = np.where(r[1] < r[0], 1, 0)
    least = np.minimum(r[0], r[1])
    third = r[2] < least
    k[third] = 2
    return np.where(third, r[2], least), k


def _facet_normals(base: NDArray[np.float64], apex: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upward unit normals (M, 3 facets, xyz) of the three lateral facets of each tetrahedron:
    base (M, 3 vertices, xyz) with vertex k replaced by the apex (M, xyz)."""
    m = len(apex)
    facets = np.repeat(base[:, None], 3, axis=1)  # (M, k, vertex, xyz)
    facets[:, [0, 1, 2], [0, 1, 2]] = apex[:, None, :]
    flat = facets.reshape(3 * m, 3, 3)
    return unit_normals(flat[:, 0], flat[:, 1], flat[:, 2]).reshape(m, 3, 3)


def _description_lengths(  # noqa: PLR0913 (a numeric kernel over the upward step's arrays)
    xyz: NDArray[np.float64],
    free: NDArray[np.intp],
    cand: NDArray[np.intp],
    simplex: NDArray[np.intp],
    lam: NDArray[np.float64],
    h: NDArray[np.float64],
    tin: GroundTin,
    tri_normals: NDArray[np.float64],
    all_tris: NDArray[np.intp],
    p: SohnParams,
) -> NDArray[np.float64]:
    """Eq. 12 for every candidate tetrahedron, over the global TIN triangles in its base.

    Work per (candidate, TIN triangle) pair is kept to gathers and a few products:
    facet normals are computed per candidate and barycentrics per triangle.
    """
    n_cand = len(cand)
    base_simplex = simplex[cand]
    # Global TIN triangles in the candidates' base triangles: a triangle belongs to the
    # base triangle holding its non-ground vertices (the first one found).
    point_simplex = np.full(len(xyz), -1)
    point_simplex[free] = simplex
    vs = point_simplex[all_tris]
    c_simplex = np.where(vs[:, 0] >= 0, vs[:, 0], np.where(vs[:, 1] >= 0, vs[:, 1], vs[:, 2]))
    tri_ids = np.flatnonzero(np.isin(c_simplex, base_simplex))
    # Per TIN triangle, once: its corners' barycentrics in its base triangle and heights above
    # the base plane. A lateral facet k rises over the base plane by H·λ[k]/λa[k] (zero on the
    # base edge opposite k, H at the apex), so a corner's height above facet k is
    # h − H·λ[k]/λa[k]: per pair, a few gathers and one product.
    base_of = np.repeat(c_simplex[tri_ids], 3)
    corner_xyz = xyz[all_tris[tri_ids]].reshape(-1, 3)
    lam_v = barycentric(tin, base_of, corner_xyz[:, :2])
    h_v = (corner_xyz[:, 2] - (lam_v * tin.points[tin.simplices[base_of], 2]).sum(axis=1)).reshape(-1, 3)
    # Column by column below: gathers and elementwise operations on 1-D arrays run several
    # times faster than reductions along a short last axis.
    lam_vk = np.ascontiguousarray(lam_v.reshape(-1, 3, 3).transpose(1, 2, 0))  # (corner, base vertex, T)
    lam_c = lam_vk.mean(axis=0)  # (base vertex, T): the centroid's
    h_v = np.ascontiguousarray(h_v.T)  # (corner, T)
    ci, tj = cross_pairs(base_simplex, c_simplex[tri_ids])
    normals = _facet_normals(tin.points[tin.simplices[base_simplex]], xyz[free[cand]])
    # Which facet holds each triangle's centroid (the k of _facet_t): the least λc[k]/λa[k].
    inv_a = np.ascontiguousarray((1.0 / np.maximum(lam[cand], EPS)).T)  # (base vertex, C)
    _, k = _least_of_three([lam_c[q][tj] * inv_a[q][ci] for q in range(3)])
    rise = (h[cand] * inv_a).ravel()[k * n_cand + ci]  # H / λa[k]
    n_on = np.zeros(len(ci), np.int8)
    at = k * len(tri_ids) + tj
    for v in range(3):
        n_on += h_v[v][tj] - lam_vk[v].ravel()[at] * rise <= p.delta_h
    # Offs cost nothing (their length is the −log2 N_offs term): angles only for ons and bufs.
    labelled = np.flatnonzero(n_on > 0)
    dtheta = angle_between(tri_normals[tri_ids[tj[labelled]]], normals[ci[labelled], k[labelled]])
    # −log2 of Eq. 13's logistic, as a softplus: one stable ufunc instead of exp, divide and log
    x = p.alpha * (dtheta - p.beta)
    cost = np.logaddexp(0.0, np.where(n_on[labelled] == 3, x, -x)) / np.log(2.0)
    dl = np.bincount(ci[labelled], cost, minlength=n_cand).astype(np.float64)
    n_offs = np.bincount(ci, (n_on == 0).astype(np.float64), minlength=n_cand).astype(np.float64)
    return dl - np.log2(np.maximum(n_offs, 1.0)) + np.log2(np.maximum(h[cand], 1e-3))


def sohn_dowman(xyz: NDArray[np.float64], *, params: SohnParams | None = None) -> NDArray[np.bool_]:
    """Ground mask by the Sohn–Dowman filter.

    Parameters
    ----------
    xyz : (N, 3) coordinates in metres.
    params : δh, α, β and safety limits; the paper's values by default.

    Returns
    -------
    (N,) bool: True for on-terrain points (TIN vertices and points within δh above the final TIN).
    """
    p = params or SohnParams()
    xyz = np.asarray(xyz, float)
    tri_all = triangulate(xyz[:, :2])
    corners = initial_corners(xyz)
    ground = downward(xyz, corners, p)
    ground = upward(xyz, corners, ground, p, tri_all)
    idx, _, h = heights_above_tin(xyz, corners, ground)
    on = ground.copy()
    on[idx[h <= p.delta_h]] = True
    return on
