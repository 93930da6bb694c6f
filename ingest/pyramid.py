"""The terrain model of one survey: categories at 2, 4, 8 and 16 m and the kept points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ingest.categorise import categorise
from ingest.reduce import KeptNodes, budget_for, kept_nodes, paper_keep, refine
from ingest.tiles import node_grid
from tdb.categories import NO_DATA
from tdb.raster import Raster
from tdb.stats import ReductionStats
from tdb.surface import line_rebuild_at
from tdb.tiles import LEVELS, SUBGRID, NodeLattice, level_bit, node_lattice


@dataclass(frozen=True)
class LevelTiles:
    """Tiles of one level: lower-left corners in whole metres and category codes."""

    level: int
    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    code: NDArray[np.uint8]


@dataclass(frozen=True)
class TerrainModel:
    """Categories per level, and the kept points (x, y, z, n) with their level masks."""

    levels: dict[int, LevelTiles]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z: NDArray[np.float64]
    n: NDArray[np.uint8]
    stats: ReductionStats | None = None


def build(
    dtm: Raster,
    *,
    flat_threshold: float,
    n: int = SUBGRID,
    levels: tuple[int, ...] = LEVELS,
    measure: bool = True,
) -> TerrainModel:
    """Categorise every tile of every level and reduce the dense model to the kept points.

    Parameters
    ----------
    dtm : the dense ground model (node-registered posts, NaN = no data).
    flat_threshold : tiles with a smaller height range (m) are flat.
    n : sub-grid size per tile side.
    measure : whether to measure the reduction (:func:`reduction_stats`); a caller that keeps
        a part of the model measures that part instead.
    """
    unit = min(levels) / (n - 1)
    out: dict[int, LevelTiles] = {}
    kept_levels: list[KeptNodes] = []
    finest_grid: NodeLattice | None = None
    finest_error: NDArray[np.float64] | None = None
    bits: list[int] = []
    for level in levels:
        grid = node_grid(dtm, level, n=n)
        tiles, ti, tj = grid.tiles(n)
        some = ~np.isnan(tiles).all(axis=1)
        tiles, ti, tj = tiles[some], ti[some], tj[some]
        codes = categorise(tiles, flat_threshold=flat_threshold, n=n)
        out[level] = LevelTiles(level, ti * level, tj * level, codes)
        if level == min(levels):
            finest_grid = grid
            refined = refine(
                tiles, codes, ti, tj, n=n, budget=budget_for(grid, n=n), relief=flat_threshold, measure=measure
            )
            keep, finest_error = refined.keep, refined.line_error
        else:
            keep = paper_keep(tiles, codes, n=n)
        kept_levels.append(kept_nodes(grid, keep, ti, tj, n=n, unit=unit))
        bits.append(level_bit(level))
    kx, ky, mask = _merged(kept_levels, bits)
    x = (kx * unit).astype(np.float64)
    y = (ky * unit).astype(np.float64)
    z = dtm.sample(x, y)
    good = ~np.isnan(z)
    model = TerrainModel(out, x[good], y[good], z[good], mask[good])
    if not measure:
        return model
    stats = reduction_stats(dtm, model, n=n, dense=finest_grid, line_error=finest_error)
    return TerrainModel(model.levels, model.x, model.y, model.z, model.n, stats)


def _merged(
    kept: list[KeptNodes], bits: list[int]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]:
    """The distinct positions of the levels' kept nodes in x-major order, each with the OR of the
    bits of the levels that keep it: marked on a raster over their extent (every level's nodes lie
    on the finest lattice) rather than sorted out, which costs a sort of every kept node."""
    kept = [k for k in kept if len(k.kx)]
    if not kept:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.uint8)
    x0, y0 = min(int(k.kx.min()) for k in kept), min(int(k.ky.min()) for k in kept)
    x1, y1 = max(int(k.kx.max()) for k in kept), max(int(k.ky.max()) for k in kept)
    raster = np.zeros((x1 - x0 + 1, y1 - y0 + 1), np.uint8)
    for k, bit in zip(kept, bits):
        raster[k.kx - x0, k.ky - y0] |= bit
    ii, jj = np.nonzero(raster)
    return ii + x0, jj + y0, raster[ii, jj]


def _owned_nodes(xg: NDArray[np.int64], yg: NDArray[np.int64], level: int, n: int) -> NDArray[np.bool_]:
    """(T, n, n): each post once. A node on a tile's east or north edge is its neighbour's there
    (a node two tiles share is rebuilt the same from either, its edge's nodes), the north-east
    corner the first of the north-east, east and north neighbours that exists."""
    ti, tj = xg // level, yg // level
    i0, j0 = int(ti.min()), int(tj.min())
    held = np.zeros((int(tj.max()) - j0 + 2, int(ti.max()) - i0 + 2), bool)
    held[tj - j0, ti - i0] = True
    east, north, north_east = (
        held[tj - j0, ti - i0 + 1],
        held[tj - j0 + 1, ti - i0],
        held[tj - j0 + 1, ti - i0 + 1],
    )
    owned = np.ones((len(xg), n, n), bool)
    owned[:, :, n - 1] = ~east[:, None]
    owned[:, n - 1, :] = ~north[:, None]
    owned[:, n - 1, n - 1] = ~(east | north | north_east)
    return owned


def reduction_stats(
    dtm: Raster,
    model: TerrainModel,
    *,
    n: int = SUBGRID,
    dense: NodeLattice | None = None,
    line_error: NDArray[np.float64] | None = None,
) -> ReductionStats:
    """Share of dense posts removed and the vertical error of the surface rebuilt from the kept 2 m
    points, at every post: the line rebuild that queries and change detection read
    (:mod:`tdb.surface`), tile by tile from the kept points' lattice, so no triangulation.
    ``dense``: the finest level's node lattice of ``dtm`` where the caller has it already;
    ``line_error``: that rebuild's error at each node of the finest level's tiles (T, n*n, as
    :func:`ingest.reduce.refine` leaves it), where the caller has it already."""
    valid = ~np.isnan(dtm.data)
    posts = int(valid.sum())
    finest = min(model.levels)
    keep = (model.n & level_bit(finest)) > 0
    rmse = max_error = None
    tiles = model.levels[finest]
    if keep.sum() >= 3 and len(tiles.xg):
        if line_error is None:
            dense = dense if dense is not None else node_grid(dtm, finest, n=n)
            kept = node_lattice(model.x[keep], model.y[keep], model.z[keep], finest)
            rebuilt = line_rebuild_at(kept.tile_nodes(tiles.xg, tiles.yg)).reshape(-1, n, n)
            line_error = rebuilt - dense.tile_nodes(tiles.xg, tiles.yg)
        err = line_error.reshape(-1, n, n)[_owned_nodes(tiles.xg, tiles.yg, finest, n)]
        err = err[np.isfinite(err)]
        if len(err):
            rmse = round(float(np.sqrt(np.mean(err**2))), 4)
            max_error = round(float(np.abs(err).max()), 4)
    return ReductionStats(
        dense_posts=posts,
        kept_points=len(model.x),
        kept_level2=int(keep.sum()),
        reduction_pct=round(100.0 * (1 - keep.sum() / max(posts, 1)), 2),
        rmse_m=rmse,
        max_error_m=max_error,
        tiles={level: len(t.code) for level, t in model.levels.items()},
        no_data={level: int((t.code == NO_DATA).sum()) for level, t in model.levels.items()},
    )
