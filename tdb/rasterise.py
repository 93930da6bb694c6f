"""A triangulated surface evaluated on a grid of posts by scan conversion.

Locating every post in a triangulation (a walk or a search per post) costs about a
microsecond a post. A grid needs none of it: each triangle covers the posts of a
few rows, and on each row a run of columns between two of its edges. So every
(triangle, row) pair gives its run, every run its posts, and every post its height
from its triangle's plane: a few array operations over all posts at once, whatever
the number of triangles. A post on an edge shared by two triangles lies in both
runs and gets the same height from either; posts outside every triangle stay NaN.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

EDGE = 1e-9  # posts: a post this close to an edge counts as on it (round-off of the run's ends)
CHUNK = 1_000_000  # posts per batch of runs: their arrays (8 MB each) stay in the heap and the caches
FACES = 1 << 19  # triangles per batch (bounds the memory of their corners and planes)


@dataclass(frozen=True)
class PostGrid:
    """Posts at ``x0 + c · cell`` east and ``y0 − r · cell`` north for columns c < ``cols``
    and rows r < ``rows`` (row 0 the northern one, as in a raster)."""

    x0: float
    y0: float
    cell: float
    rows: int
    cols: int


def rasterise(
    xy: NDArray[np.float64],
    z: NDArray[np.float64],
    faces: NDArray[np.intp],
    grid: PostGrid,
    *,
    max_edge: float | None = None,
) -> NDArray[np.float64]:
    """Heights (rows, cols) of the surface of triangles ``faces`` (T, 3) over vertices ``xy``
    (V, 2) with heights ``z`` (V,), at the posts of ``grid``; NaN where no triangle covers a post.

    ``max_edge``: a triangle with an edge longer than this (in ``xy``'s units) covers no post
    (a gap in the data, not a surface); None: every triangle covers its posts."""
    out = np.full((grid.rows, grid.cols), np.nan)
    faces = np.asarray(faces, np.intp)
    # grid coordinates: posts at whole numbers, v growing southward
    u = (np.asarray(xy[:, 0], float) - grid.x0) / grid.cell
    v = (grid.y0 - np.asarray(xy[:, 1], float)) / grid.cell
    height = np.asarray(z, float)
    longest = np.inf if max_edge is None else (max_edge / grid.cell) ** 2
    for s in range(0, len(faces), FACES):
        _triangles(faces[s : s + FACES], u, v, height, grid, out, longest)
    return out


def _triangles(
    faces: NDArray[np.intp],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    z: NDArray[np.float64],
    grid: PostGrid,
    out: NDArray[np.float64],
    longest: float,
) -> None:
    """Write the heights of one batch of triangles into ``out``, in batches of runs of about
    :data:`CHUNK` posts; a triangle with an edge's square (in posts) over ``longest`` writes none."""
    # corners (3, T), one row per corner, so that each corner's values lie together in memory
    corners = np.ascontiguousarray(faces.T)
    tu, tv, tz = u[corners], v[corners], z[corners]
    plane, ok = _planes(tu, tv, tz)
    if np.isfinite(longest):
        for a, b in ((0, 1), (1, 2), (2, 0)):
            ok &= (tu[b] - tu[a]) ** 2 + (tv[b] - tv[a]) ** 2 <= longest
    first = np.maximum(np.ceil(_least(tv) - EDGE), 0).astype(np.int64)
    last = np.minimum(np.floor(_most(tv) + EDGE), grid.rows - 1).astype(np.int64)
    nrows = np.where(ok, np.maximum(last - first + 1, 0), 0)
    # the posts a triangle's rows can hold, to cut the triangles into batches of similar work
    width = np.ceil(_most(tu) - _least(tu)) + 1
    work = np.cumsum(nrows * width)
    cuts = np.searchsorted(work, np.arange(CHUNK, work[-1], CHUNK)) + 1
    edges = np.unique(np.r_[0, np.minimum(cuts, len(faces)), len(faces)])
    for a, b in itertools.pairwise(edges.tolist()):
        _scan(tu[:, a:b], tv[:, a:b], plane[:, a:b], first[a:b], nrows[a:b], grid, out)


def _least(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """The smallest of each triangle's three corner values ((3, T) → (T,)): elementwise, which
    numpy does far faster than a reduction over an axis of three."""
    return np.minimum(np.minimum(t[0], t[1]), t[2])


def _most(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """The largest of each triangle's three corner values ((3, T) → (T,))."""
    return np.maximum(np.maximum(t[0], t[1]), t[2])


def _planes(
    tu: NDArray[np.float64], tv: NDArray[np.float64], tz: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Each triangle's plane z = a + b·u + c·v ((3, T): a, b, c), and whether it has an area."""
    du1, dv1, dz1 = tu[1] - tu[0], tv[1] - tv[0], tz[1] - tz[0]
    du2, dv2, dz2 = tu[2] - tu[0], tv[2] - tv[0], tz[2] - tz[0]
    det = du1 * dv2 - du2 * dv1
    ok = np.abs(det) > 1e-12 * (np.abs(du1 * dv2) + np.abs(du2 * dv1) + 1e-300)
    safe = np.where(ok, det, 1.0)
    plane = np.empty((3, len(det)))
    plane[1] = (dz1 * dv2 - dz2 * dv1) / safe
    plane[2] = (du1 * dz2 - du2 * dz1) / safe
    plane[0] = tz[0] - plane[1] * tu[0] - plane[2] * tv[0]
    return plane, ok


def _scan(
    tu: NDArray[np.float64],
    tv: NDArray[np.float64],
    plane: NDArray[np.float64],
    first: NDArray[np.int64],
    nrows: NDArray[np.int64],
    grid: PostGrid,
    out: NDArray[np.float64],
) -> None:
    """Write the heights of one batch of triangles into ``out``: per (triangle, row) the run of
    columns between the edges the row crosses (an east–west edge on the row gives both its ends)."""
    tri = np.repeat(np.arange(tu.shape[1], dtype=np.int32), nrows)
    if len(tri) == 0:
        return
    row = first[tri] + np.arange(len(tri)) - np.repeat(np.cumsum(nrows) - nrows, nrows)
    r = row.astype(float)
    lo = np.full(len(tri), np.inf)
    hi = np.full(len(tri), -np.inf)
    cu, cv = [t[tri] for t in tu], [t[tri] for t in tv]
    for a, b in ((0, 1), (1, 2), (2, 0)):
        ua, va, ub, vb = cu[a], cv[a], cu[b], cv[b]
        top, bottom = np.minimum(va, vb), np.maximum(va, vb)
        crosses = (top <= r + EDGE) & (bottom >= r - EDGE)
        flat = bottom - top <= EDGE
        with np.errstate(invalid="ignore", divide="ignore"):
            at = ua + (np.clip(r, top, bottom) - va) * (ub - ua) / (vb - va)
        lo = np.where(crosses, np.minimum(lo, np.where(flat, np.minimum(ua, ub), at)), lo)
        hi = np.where(crosses, np.maximum(hi, np.where(flat, np.maximum(ua, ub), at)), hi)
    c0 = np.maximum(np.ceil(lo - EDGE), 0).astype(np.int64)
    c1 = np.minimum(np.floor(hi + EDGE), grid.cols - 1).astype(np.int64)
    ncols = np.maximum(c1 - c0 + 1, 0)
    run = np.repeat(np.arange(len(tri), dtype=np.int32), ncols)
    col = c0[run] + np.arange(len(run)) - np.repeat(np.cumsum(ncols) - ncols, ncols)
    # the plane along a run: its height at the run's row, then a step per column
    at_row = plane[0, tri] + plane[2, tri] * r
    out[row[run], col] = at_row[run] + plane[1, tri][run] * col
