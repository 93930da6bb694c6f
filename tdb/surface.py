"""The surface that a level's kept points stand for, rebuilt in two ways.

**The TIN rebuild** (:func:`kept_mesh`, :func:`mesh_height`): the Delaunay TIN of the kept
points, with each tile that keeps only its corners split along the diagonal its category
implies. It is the surface a user sees: ``tdb aoi``'s GeoTIFF, PNG and PLY faces, and the
reduction's published RMSE. The four corners of a tile that keeps nothing else lie on one
circle, so Delaunay's choice of diagonal there is a tie, which Qhull breaks by the order of the
points, not by the terrain. The tile's category was matched on the whole dense sub-grid, so it
knows better: the split nearer to the category's template (scaled to the corners by least
squares) is taken. Where the template says nothing about the corners (flat, no data, equal
template corners) the diagonal that joins the closer heights is.

**The line rebuild** (:func:`line_rebuild`, :func:`line_rebuild_at`): within each tile alone,
the nodes that are not kept are bridged by straight lines along the tile's rows and columns
(weighted by the inverse square of their gaps), edges first, then the interior
(:data:`LINE_PASSES`). It needs no triangulation and no neighbour, so it is what the reduction
chooses its kept nodes by, and what change detection and the DEM of difference compare tile by
tile. A plane is rebuilt exactly by both; elsewhere the two differ by the choice of triangles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tdb.categories import NO_DATA, subgrid_uv, templates
from tdb.fill import fill_lines, fill_lines_stack
from tdb.rasterise import PostGrid, rasterise
from tdb.tiles import SUBGRID, TileIndex, corner_nodes
from tdb.tin import Tin, locate, surface_height, triangulate

LINE_PASSES = 2  # a tile known only at its corners gets its edges in the first pass, its interior in the next


def line_rebuild(nodes: NDArray[np.float64]) -> NDArray[np.float64]:
    """The line rebuild of tile sub-grids (T, n, n) whose NaN nodes are not kept; NaN where a
    tile keeps too little to bridge them."""
    return np.asarray(fill_lines(nodes, passes=LINE_PASSES), np.float64)


def line_rebuild_at(nodes: NDArray[np.float64], cells: NDArray[np.intp] | None = None) -> NDArray[np.float64]:
    """:func:`line_rebuild` (T, len(cells)) at the flat sub-grid indices ``cells`` (all if None);
    many tiles of a database share their pattern of kept nodes, and this works per pattern."""
    return fill_lines_stack(nodes, passes=LINE_PASSES, cells=cells)


def split_heights(
    corners: NDArray[np.float64], u: NDArray[np.float64], v: NDArray[np.float64], anti: NDArray[np.bool_]
) -> NDArray[np.float64]:
    """Heights at (u, v) in the unit tile of the two triangles over its corners (…, 4: SW, SE, NW, NE),
    split along SW–NE, or along SE–NW where ``anti``; all arguments broadcast."""
    sw, se, nw, ne = (corners[..., k] for k in range(4))
    main = np.where(u >= v, sw + u * (se - sw) + v * (ne - se), sw + v * (nw - sw) + u * (ne - nw))
    other = np.where(
        u + v <= 1, sw + u * (se - sw) + v * (nw - sw), ne + (1 - u) * (nw - ne) + (1 - v) * (se - ne)
    )
    return np.where(anti, other, main)


def anti_diagonal(
    corners: NDArray[np.float64], codes: NDArray[np.uint8], *, n: int = SUBGRID
) -> NDArray[np.bool_]:
    """(T,) True where a tile of corner heights (T, 4: SW, SE, NW, NE) and category ``codes`` is split
    along SE–NW rather than SW–NE (see the module's description)."""
    known = codes != NO_DATA
    tpl = templates(n)[np.where(known, codes, 0)]
    at = tpl[:, corner_nodes(n)]
    dt = at - at.mean(axis=1, keepdims=True)
    var = (dt**2).sum(axis=1)
    scale = np.where(var > 1e-12, (dt * corners).sum(axis=1) / np.where(var > 1e-12, var, 1.0), 0.0)
    predicted = corners.mean(axis=1, keepdims=True) + scale[:, None] * (tpl - at.mean(axis=1, keepdims=True))
    uv = subgrid_uv(n)
    c = corners[:, None, :]
    e_main = ((split_heights(c, uv[:, 0], uv[:, 1], np.zeros(1, bool)) - predicted) ** 2).sum(axis=1)
    e_anti = ((split_heights(c, uv[:, 0], uv[:, 1], np.ones(1, bool)) - predicted) ** 2).sum(axis=1)
    closer = np.abs(corners[:, 1] - corners[:, 2]) < np.abs(corners[:, 0] - corners[:, 3])
    says = known & (var > 1e-12) & (np.abs(e_main - e_anti) > 1e-12 * (1 + e_main + e_anti))
    return np.where(says, e_anti < e_main, closer)


@dataclass(frozen=True)
class KeptMesh:
    """A Delaunay TIN of kept points whose corner-only tiles are re-split.

    ``faces`` are the triangles to draw; ``halves`` gives, per Delaunay simplex, the re-split tile
    it lies in (index into ``origin``, ``corners`` and ``anti``), or −1.
    """

    tri: Tin
    z: NDArray[np.float64]
    faces: NDArray[np.intp]
    halves: NDArray[np.intp]
    origin: NDArray[np.float64]
    corners: NDArray[np.float64]
    anti: NDArray[np.bool_]
    size: float


def kept_mesh(  # noqa: PLR0913 (the points' three arrays and the tiles' three)
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
    *,
    xg: NDArray[np.int64],
    yg: NDArray[np.int64],
    code: NDArray[np.uint8],
    level: int,
    n: int = SUBGRID,
) -> KeptMesh:
    """The mesh of one level's kept points (x, y, z) and that level's tiles (xg, yg, code).

    Raises :class:`tdb.errors.DegenerateInputError` (from the triangulation) for fewer than three
    points or points on one line.
    """
    xy = np.column_stack([x, y])
    tri = triangulate(xy)
    step = level / (n - 1)
    ki, kj = np.round(x / step).astype(np.int64), np.round(y / step).astype(np.int64)
    s = tri.simplices
    vi, vj = ki[s], kj[s]
    i0, j0 = vi.min(axis=1), vj.min(axis=1)
    span = n - 1
    # a half of a tile: its bounding box is one whole tile and its vertices are that tile's corners
    half = (
        (vi.max(axis=1) - i0 == span)
        & (vj.max(axis=1) - j0 == span)
        & (i0 % span == 0)
        & (j0 % span == 0)
        & (
            ((vi == i0[:, None]) | (vi == i0[:, None] + span)) & ((vj == j0[:, None]) | (vj == j0[:, None] + span))
        ).all(axis=1)
    )
    cand = np.flatnonzero(half)
    found, inverse, count = np.unique(
        np.column_stack([i0[cand], j0[cand]]), axis=0, return_inverse=True, return_counts=True
    )
    inverse = inverse.ravel()
    pair = count == 2  # both halves; the circle argument says a corner-only tile always has both
    key = found[pair]
    halves = np.full(len(s), -1, np.intp)
    ok = pair[inverse]
    halves[cand[ok]] = (np.cumsum(pair) - 1)[inverse[ok]]
    points = TileIndex(ki, kj)
    corner_idx = np.column_stack(
        [points.find(key[:, 0] + di, key[:, 1] + dj) for di, dj in ((0, 0), (span, 0), (0, span), (span, span))]
    )
    tiles = TileIndex(np.asarray(xg) // level, np.asarray(yg) // level)
    t = tiles.find(key[:, 0] // span, key[:, 1] // span)
    codes = np.append(np.asarray(code, np.uint8), np.uint8(NO_DATA))[np.where(t >= 0, t, len(code))]
    corners = z[corner_idx]
    anti = anti_diagonal(corners, codes, n=n)

    faces = s.copy()
    sw, se, nw, ne = corner_idx.T
    tri_a = np.where(anti[:, None], np.column_stack([sw, se, nw]), np.column_stack([sw, se, ne]))
    tri_b = np.where(anti[:, None], np.column_stack([se, ne, nw]), np.column_stack([sw, ne, nw]))
    members = cand[ok]
    members = members[np.argsort(halves[members], kind="stable")]  # sorted by their tile: two per tile
    faces[members[0::2]] = tri_a
    faces[members[1::2]] = tri_b
    return KeptMesh(tri, np.asarray(z, np.float64), faces, halves, key * step, corners, anti, level)


def mesh_grid(mesh: KeptMesh, grid: PostGrid) -> NDArray[np.float64]:
    """Heights of the mesh at the posts of ``grid`` (rows, cols); NaN outside it. The same as
    :func:`mesh_height` at those posts (its faces are the re-split tiles' triangles), without
    locating a post."""
    xy = mesh.tri.qhull.points + mesh.tri.origin
    return rasterise(xy, mesh.z, mesh.faces, grid)


def mesh_height(mesh: KeptMesh, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """Heights of the mesh at ``xy`` (M, 2); NaN outside it."""
    simplex = locate(mesh.tri, xy)
    out, _ = surface_height(mesh.tri, mesh.z, xy, simplex)
    t = np.where(simplex >= 0, mesh.halves[simplex], -1)
    on = np.flatnonzero(t >= 0)
    if len(on):
        k = t[on]
        u = (xy[on, 0] - mesh.origin[k, 0]) / mesh.size
        v = (xy[on, 1] - mesh.origin[k, 1]) / mesh.size
        out[on] = split_heights(mesh.corners[k], u, v, mesh.anti[k])
    return out
