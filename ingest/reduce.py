"""Data reduction: keep the tile corners and the sub-grid nodes of each tile's feature.

At the finest level the kept set is then refined against the dense model: the
feature nodes are kept where they stand out of the surface the corners rebuild,
and, tile by tile, the node the kept ones rebuild worst is added, largest errors
first, until every node is within a tolerance or a budget of kept nodes is spent
(:func:`refine`). Kept nodes of all levels are merged into one set of points;
each carries a 4-bit mask n of the levels that keep it (bit 0: 2 m … bit 3: 16 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tdb.categories import NO_DATA, feature_nodes
from tdb.surface import line_rebuild_at
from tdb.tiles import NodeLattice, TileIndex, corner_mask

TOLERANCE = 0.05  # m: a node rebuilt this close to the dense model needs no point of its own
MAX_KEPT_SHARE = 0.098  # at most this share of the dense posts is kept at the finest level
SCHEDULE = (2.0, 1.0, 0.6, 0.4, 0.3, 0.2, 0.15, 0.1, 0.07)  # m: error bands, worst first


@dataclass(frozen=True)
class KeptNodes:
    """Kept nodes of one level, as integer node indices in units of the finest spacing."""

    kx: NDArray[np.int64]
    ky: NDArray[np.int64]


def category_nodes(codes: NDArray[np.uint8], *, n: int) -> NDArray[np.bool_]:
    """(T, n*n) the nodes of each tile's feature; none for a tile with no category."""
    out = np.zeros((len(codes), n * n), bool)
    ok = codes != NO_DATA
    out[ok] = feature_nodes(n)[codes[ok]]
    return out


def paper_keep(tiles: NDArray[np.float64], codes: NDArray[np.uint8], *, n: int) -> NDArray[np.bool_]:
    """(T, n*n) the paper's kept nodes: corners of every tile and the nodes of its category's
    feature; a tile with holes (no category) keeps its corners that have data."""
    return (corner_mask(n) | category_nodes(codes, n=n)) & ~np.isnan(tiles)


def line_error(tiles: NDArray[np.float64], keep: NDArray[np.bool_], *, n: int) -> NDArray[np.float64]:
    """|rebuilt − dense| at every node (T, n*n), the surface rebuilt from the kept nodes by
    straight lines along each tile's rows and columns (edges first, then the interior,
    :func:`tdb.surface.line_rebuild_at`); NaN where a node has no data or no line reaches it."""
    z = np.where(keep, tiles, np.nan)
    return np.abs(line_rebuild_at(z.reshape(-1, n, n)) - tiles)


def rebuild_error(
    tiles: NDArray[np.float64],
    keep: NDArray[np.bool_],
    *,
    n: int,
    line: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """|rebuilt − dense| at every node with data (0 without).

    The surface is rebuilt from the kept nodes by straight lines (:func:`line_error`, or its
    ``line`` where the caller has it); a node no line reaches (a tile cut by a hole) takes the
    mean of the tile's kept nodes, and a tile with no kept node has error inf, so that it is
    given one first.
    """
    line = line_error(tiles, keep, n=n) if line is None else line
    z = np.where(keep, tiles, np.nan)
    known = ~np.isnan(z)
    kept = known.sum(axis=1, keepdims=True)
    mean = np.where(kept > 0, np.where(known, z, 0.0).sum(axis=1, keepdims=True) / np.maximum(kept, 1), np.nan)
    fallback = np.where(np.isnan(mean), np.inf, np.abs(mean - tiles))
    return np.where(np.isnan(tiles), 0.0, np.where(np.isnan(line), fallback, line))


@dataclass(frozen=True)
class Refined:
    """What :func:`refine` keeps (T, n*n), and, where asked, the line rebuild's error at every
    node once it is done (:func:`line_error`: NaN without data or where no line reaches)."""

    keep: NDArray[np.bool_]
    line_error: NDArray[np.float64] | None = None


def refine(  # noqa: PLR0913 (a numeric kernel: the tiles' four arrays and its budget)
    tiles: NDArray[np.float64],
    codes: NDArray[np.uint8],
    ti: NDArray[np.int64],
    tj: NDArray[np.int64],
    *,
    n: int,
    budget: int,
    relief: float,
    tolerance: float = TOLERANCE,
    measure: bool = False,
) -> Refined:
    """(T, n*n) kept nodes: corners, the feature nodes that stand out, then the worst-rebuilt node
    of each tile, band by band (:data:`SCHEDULE`), while the budget lasts.

    Parameters
    ----------
    tiles : (T, n*n) dense heights on each tile's sub-grid; NaN = no data.
    codes : (T,) category codes.
    ti, tj : tile indices (neighbouring tiles share their edge nodes).
    budget : how many nodes beyond the corners may be kept (see :func:`budget_for`).
    relief : m; a feature node is kept first where the corners miss it by more (the flat
        threshold: less is not a form).
    tolerance : m; nodes rebuilt within it are not added.
    measure : whether to return the line rebuild's error at every node as well (what the
        reduction's figures read), kept up to date as the errors that choose the nodes are.
    """
    valid = ~np.isnan(tiles)
    keep = np.broadcast_to(corner_mask(n), tiles.shape) & valid
    line: NDArray[np.float64] | None = line_error(tiles, keep, n=n)
    err = rebuild_error(tiles, keep, n=n, line=line)
    if not measure:
        line = None
    nb = _neighbours(ti, tj)
    # The category's feature nodes first, where the corners alone miss their relief (err is 0
    # without data). Where they would spend the whole budget (a patchy survey, whose tile corners
    # take most of it), they go first within each band instead, so that a node rebuilt 1.5 m
    # off is not left for a bend of 0.1 m.
    feature = category_nodes(codes, n=n) & (err > max(relief, tolerance))
    feature_err = np.where(feature, err, 0.0)
    # each tile's worst error, kept up to date for the tiles touched: a band's pass then reads
    # only the tiles above it, not every node again
    tile_worst = err.max(axis=1, initial=0.0)

    def keep_nodes(t: NDArray[np.intp], node: NDArray[np.intp], e: NDArray[np.float64]) -> None:
        nonlocal budget
        added, rows = _add(keep, t, node, e, budget, nb, n)
        budget -= added
        touched = line_error(tiles[rows], keep[rows], n=n)
        err[rows] = rebuild_error(tiles[rows], keep[rows], n=n, line=touched)
        if line is not None:
            line[rows] = touched
        tile_worst[rows] = err[rows].max(axis=1, initial=0.0)

    def keep_features(floor: float) -> None:
        t, node = np.nonzero((feature_err > floor) & ~keep)
        keep_nodes(t, node, feature_err[t, node])

    fits = np.count_nonzero(feature) <= budget
    if fits:
        keep_features(0.0)
    for band in [b for b in SCHEDULE if b > tolerance] + [tolerance]:
        if not fits:
            keep_features(band)
        while budget > 0:
            t = np.flatnonzero(tile_worst > band)
            if len(t) == 0:
                break
            worst = err[t].argmax(axis=1)
            keep_nodes(t, worst, err[t, worst])
    return Refined(keep, line)


def _neighbours(ti: NDArray[np.int64], tj: NDArray[np.int64]) -> NDArray[np.intp]:
    """(T, 4) index of each tile's east, north, west and south neighbour; −1 where none."""
    index = TileIndex(ti, tj)
    return np.column_stack([index.find(ti + di, tj + dj) for di, dj in ((1, 0), (0, 1), (-1, 0), (0, -1))])


def _add(
    keep: NDArray[np.bool_],
    t: NDArray[np.intp],
    node: NDArray[np.intp],
    err: NDArray[np.float64],
    budget: int,
    nb: NDArray[np.intp],
    n: int,
) -> tuple[int, NDArray[np.intp]]:
    """Keep nodes (t, node), the largest errors first, at most ``budget``, and the same
    nodes in the neighbour sharing them. Returns how many were kept and the tiles touched."""
    if budget <= 0 or len(t) == 0:
        return 0, np.zeros(0, np.intp)
    if len(t) > budget:
        top = np.argsort(-err, kind="stable")[:budget]
        t, node = t[top], node[top]
    keep[t, node] = True
    r, c = node // n, node % n
    touched = [t]
    for k, on_edge, partner in (
        (0, c == n - 1, r * n),  # east edge -> west edge of the east tile
        (1, r == n - 1, c),  # north edge -> south edge of the north tile
        (2, c == 0, r * n + n - 1),
        (3, r == 0, (n - 1) * n + c),
    ):
        other = nb[t, k]
        share = on_edge & (other >= 0)
        keep[other[share], partner[share]] = True
        touched.append(other[share])
    return len(t), np.unique(np.concatenate(touched))


def budget_for(grid: NodeLattice, *, n: int, max_share: float = MAX_KEPT_SHARE) -> int:
    """Nodes :func:`refine` may add: ``max_share`` of the grid's nodes with data, less its corners."""
    valid = ~np.isnan(grid.z)
    return int(max_share * valid.sum()) - int(valid[:: n - 1, :: n - 1].sum())


def kept_nodes(
    grid: NodeLattice,
    keep: NDArray[np.bool_],
    ti: NDArray[np.int64],
    tj: NDArray[np.int64],
    *,
    n: int,
    unit: float,
) -> KeptNodes:
    """Positions of the kept nodes (T, n*n) of tiles (ti, tj), in units of ``unit``, the finest
    node spacing; a node two tiles share (their edge) comes once from each tile keeping it."""
    t_idx, node = np.nonzero(keep)
    ratio = round(grid.spacing / unit)
    step = n - 1
    kx = (ti[t_idx] * step + node % n) * ratio
    ky = (tj[t_idx] * step + node // n) * ratio
    return KeptNodes(kx, ky)
