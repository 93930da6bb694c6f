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
from scipy.spatial import Delaunay

from ingest.ground.ground_tin import GroundTin
from ingest.ground.tin import (
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
    """Defaults from the paper: δh = 1 m, α = 0.1, β = 45°."""

    delta_h: float = 1.0
    alpha: float = 0.1
    beta: float = 45.0
    max_candidates: int = 16  # lowest member points tried per triangle
    reject_facets: int = 3  # reject when this many lateral facets have a point below (3 = literal; see docs)
    below_tolerance: float = 0.1  # how far below a facet (m) a point must be to count as below
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
    lo, hi = xyz[:, :2].min(axis=0), xyz[:, :2].max(axis=0)
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


def upward(
    xyz: NDArray[np.float64],
    corners: NDArray[np.float64],
    ground: NDArray[np.bool_],
    p: SohnParams,
    tri_all: Delaunay,
) -> NDArray[np.bool_]:
    """§4.3: add the MDL-best tetrahedron apex of every triggered triangle until none is found."""
    ground = ground.copy()
    all_tris = tri_all.simplices
    centroid_xy = xyz[all_tris, :2].mean(axis=1)
    tri_normals = unit_normals(xyz[all_tris[:, 0]], xyz[all_tris[:, 1]], xyz[all_tris[:, 2]])
    tin = GroundTin.build(np.vstack([corners, xyz[ground]]))
    free = np.flatnonzero(~ground)
    simplex = tin.locate(xyz[free, :2])
    for _ in range(p.max_iterations):
        lam = barycentric(tin, simplex, xyz[free, :2])
        vz = tin.points[tin.simplices, 2]
        h = xyz[free, 2] - (lam * vz[simplex]).sum(axis=1)
        in_buffer = (h > EPS) & (h <= p.delta_h)
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
        t, k = _facet_t(lam[mi], lam[cand[ci]])
        below = h[mi] - t * h[cand[ci]] < -p.below_tolerance
        facet_below = np.zeros((len(cand), 3), bool)
        np.logical_or.at(facet_below, (ci[below], k[below]), True)
        rejected = facet_below.sum(axis=1) >= p.reject_facets
        cand = cand[~rejected]
        if len(cand) == 0:
            break
        dl = _description_lengths(xyz, free, cand, simplex, lam, h, tin, centroid_xy, tri_normals, all_tris, p)
        won = cand[_per_group_argmin(simplex[cand], dl)]
        ground[free[won]] = True
        stay = np.ones(len(free), bool)
        stay[won] = False
        tin, simplex = tin.insert(xyz[free[won]], simplex[won], xyz[free[stay], :2], simplex[stay])
        free = free[stay]
    return ground


def _facet_t(
    lam_p: NDArray[np.float64], lam_a: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Share of the apex in point p's height on the lateral facet that holds it.

    With barycentrics λp of p and λa of the apex in the base triangle, p lies in
    the facet opposite the vertex k minimising λp[k]/λa[k] =: t, and the facet's
    height over the base plane at p is t·H. Returns (t, k).
    """
    ratio = lam_p / np.maximum(lam_a, EPS)
    k = ratio.argmin(axis=1)
    return np.clip(ratio[np.arange(len(k)), k], 0.0, 1.0), k


def _facet_planes(
    base: NDArray[np.float64], apex: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The three lateral facets of each tetrahedron: base (M, 3 vertices, xyz) with vertex k
    replaced by the apex (M, xyz). Returns planes z = a·x + b·y + c as (M, 3 facets, [a, b, c])
    and upward unit normals (M, 3 facets, xyz)."""
    m = len(apex)
    facets = np.repeat(base[:, None], 3, axis=1)  # (M, k, vertex, xyz)
    facets[:, [0, 1, 2], [0, 1, 2]] = apex[:, None, :]
    flat = facets.reshape(3 * m, 3, 3)
    normals = unit_normals(flat[:, 0], flat[:, 1], flat[:, 2])
    nz = np.where(np.abs(normals[:, 2]) < EPS, EPS, normals[:, 2])
    a, b = -normals[:, 0] / nz, -normals[:, 1] / nz
    c = flat[:, 0, 2] - a * flat[:, 0, 0] - b * flat[:, 0, 1]
    return np.column_stack([a, b, c]).reshape(m, 3, 3), normals.reshape(m, 3, 3)


def _description_lengths(
    xyz: NDArray[np.float64],
    free: NDArray[np.intp],
    cand: NDArray[np.intp],
    simplex: NDArray[np.intp],
    lam: NDArray[np.float64],
    h: NDArray[np.float64],
    tin: GroundTin,
    centroid_xy: NDArray[np.float64],
    tri_normals: NDArray[np.float64],
    all_tris: NDArray[np.intp],
    p: SohnParams,
) -> NDArray[np.float64]:
    """Eq. 12 for every candidate tetrahedron, over the global TIN triangles in its base.

    Work per (candidate, TIN triangle) pair is kept to gathers and a few products:
    facet planes are computed per candidate and barycentrics per triangle.
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
    lam_c = barycentric(tin, c_simplex[tri_ids], centroid_xy[tri_ids])  # per triangle, once
    ci, tj = cross_pairs(base_simplex, c_simplex[tri_ids])
    planes, normals = _facet_planes(tin.points[tin.simplices[base_simplex]], xyz[free[cand]])
    # Which facet holds each triangle's centroid (the k of _facet_t). The work per
    # (candidate, triangle) pair dominates the filter: gathers are flat and contiguous.
    k = (lam_c[tj] / np.maximum(lam[cand], EPS)[ci]).argmin(axis=1)
    flat = 3 * ci + k
    a, b, c = (np.ascontiguousarray(planes[:, :, q]).ravel()[flat][:, None] for q in range(3))
    # Label the triangle's vertices by height over the facet plane (Eq. 6 with δh).
    corners_xyz = xyz[all_tris[tri_ids]]
    tx, ty, tz = (np.ascontiguousarray(corners_xyz[:, :, q]) for q in range(3))  # (T, 3) each
    d = tz[tj] - (a * tx[tj] + b * ty[tj] + c)
    n_on = np.count_nonzero(d <= p.delta_h, axis=1)
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
