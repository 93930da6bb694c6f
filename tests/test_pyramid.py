"""Tiles, categories per level, reduction and the 4-bit level masks."""

from __future__ import annotations

import numpy as np
import pytest

from ingest.pyramid import build
from tdb.categories import NO_DATA, all_categories
from tdb.raster import Raster
from tdb.tiles import LEVELS, level_bit


def _raster(f, size=64.0, cell=0.5, x0=1000.0, y0=2000.0):
    n = int(size / cell) + 1
    xs = x0 + np.arange(n) * cell
    ys = y0 + size - np.arange(n) * cell
    gx, gy = np.meshgrid(xs, ys)
    return Raster(f(gx, gy), x0 - cell / 2, y0 + size + cell / 2, cell)


def test_inclined_plane_is_one_category_and_keeps_corners_only():
    model = build(_raster(lambda x, y: 0.2 * (y - 2000)), flat_threshold=0.1)
    codes = model.levels[2].code
    assert set(codes.tolist()) == {1}  # plane rising N
    assert all_categories()[1].description == "plane rising N"
    assert model.stats.rmse_m == pytest.approx(0.0, abs=1e-9)
    corners = (np.mod(model.x[model.n & 1 > 0], 2) == 0) & (np.mod(model.y[model.n & 1 > 0], 2) == 0)
    assert corners.all()
    assert model.stats.reduction_pct > 93


def test_flat_terrain():
    model = build(_raster(lambda x, y: np.full(x.shape, 50.0)), flat_threshold=0.1)
    for level in LEVELS:
        t = model.levels[level]
        inside = (t.xg >= 1000) & (t.xg + level <= 1064) & (t.yg >= 2000) & (t.yg + level <= 2064)
        assert (t.code[inside] == 0).all()
        assert (t.code[~inside] == NO_DATA).all()  # straddling the data edge: no data, never a guess


def test_ditch_tiles_are_valleys_along_it():
    # A V ditch along x = 1031 (N-S), 3 m wide, 1 m deep.
    model = build(_raster(lambda x, y: -np.clip(1 - np.abs(x - 1031.0) / 1.5, 0, None)), flat_threshold=0.1)
    t = model.levels[2]
    on_ditch = (t.xg == 1030) & (t.yg > 2002) & (t.yg < 2060)
    valleys = [all_categories()[c].feature for c in t.code[on_ditch]]
    from tdb.categories import VALLEY

    assert np.mean([f == VALLEY for f in valleys]) > 0.9
    assert (t.code[(t.xg < 1020)] == 0).all()


def test_tile_keys_are_whole_multiples_of_the_level():
    model = build(
        _raster(lambda x, y: 0.01 * x + 0.3 * np.sin(x / 7) * np.cos(y / 5), x0=1001.5, y0=2003.0),
        flat_threshold=0.1,
    )
    for level, t in model.levels.items():
        assert (t.xg % level == 0).all() and (t.yg % level == 0).all()
        assert t.xg.dtype.kind == "i"


def test_level_masks():
    model = build(_raster(lambda x, y: 0.01 * x + 0.5 * np.sin(x / 9) * np.cos(y / 6)), flat_threshold=0.1)
    assert model.n.min() >= 1 and model.n.max() <= 15
    for level in LEVELS:
        keep = (model.n & level_bit(level)) > 0
        # Every level-L tile corner inside the data is kept with that level's bit.
        corners = (np.mod(model.x, level) == 0) & (np.mod(model.y, level) == 0)
        assert keep[corners].all()
        # Points of a level lie on its sub-grid.
        s = level / 4
        assert (np.mod(model.x[keep], s) == 0).all() and (np.mod(model.y[keep], s) == 0).all()
    # 16 m corners are corners of every level.
    c16 = (np.mod(model.x, 16) == 0) & (np.mod(model.y, 16) == 0)
    assert (model.n[c16] == 15).all()


def _tiles(f, count=6, n=5):
    """(T, n*n) sub-grids of ``count`` × ``count`` 2 m tiles of the surface f, and their indices."""
    ti, tj = np.meshgrid(np.arange(count), np.arange(count))
    ti, tj = ti.ravel(), tj.ravel()
    u = np.arange(n) * 2.0 / (n - 1)
    x = ti[:, None, None] * 2.0 + u[None, None, :]
    y = tj[:, None, None] * 2.0 + u[None, :, None]
    return f(x, y).reshape(len(ti), n * n), ti, tj


def test_refine_reaches_the_tolerance_when_the_budget_allows():
    from ingest.reduce import TOLERANCE, rebuild_error, refine

    tiles, ti, tj = _tiles(lambda x, y: 0.8 * np.sin(x / 1.3) * np.cos(y / 1.7))
    codes = np.ones(len(tiles), np.uint8)
    keep = refine(tiles, codes, ti, tj, n=5, budget=10_000, relief=0.1).keep
    assert rebuild_error(tiles, keep, n=5).max() <= TOLERANCE
    assert not keep.all()  # it stopped once within the tolerance


def test_refine_spends_no_more_than_its_budget_largest_errors_first():
    from ingest.reduce import rebuild_error, refine
    from tdb.tiles import corner_mask

    # One sharp pit in an otherwise planar area: the budget goes to it.
    def surface(x, y):
        return 0.1 * x - 2.0 * np.exp(-((x - 5.0) ** 2 + (y - 5.0) ** 2) / 0.3)

    tiles, ti, tj = _tiles(surface)
    codes = np.ones(len(tiles), np.uint8)
    corners = np.broadcast_to(corner_mask(5), tiles.shape)
    for budget in (0, 1, 3):
        keep = refine(tiles, codes, ti, tj, n=5, budget=budget, relief=0.1).keep
        assert (keep & ~corners).sum() <= 2 * budget  # an edge node is kept by both its tiles
        assert (keep & corners).sum() == corners.sum()
    pit = np.flatnonzero((ti == 2) & (tj == 2))[0]  # the tile holding (5, 5)
    before = rebuild_error(tiles, corners, n=5)[pit].max()
    after = rebuild_error(tiles, refine(tiles, codes, ti, tj, n=5, budget=1, relief=0.1).keep, n=5)[pit].max()
    assert after < before / 2


def test_a_kept_edge_node_is_kept_by_both_tiles_sharing_it():
    from ingest.reduce import refine

    # A step along x = 2 (the edge between tiles 0 and 1): only edge nodes can rebuild it.
    tiles, ti, tj = _tiles(lambda x, y: np.where(np.abs(x - 2.0) < 0.1, 1.0, 0.0) * (y > 0.1) * (y < 1.9), count=2)
    keep = refine(tiles, np.ones(len(tiles), np.uint8), ti, tj, n=5, budget=50, relief=0.1).keep.reshape(-1, 5, 5)
    west = np.flatnonzero((ti == 0) & (tj == 0))[0]
    east = np.flatnonzero((ti == 1) & (tj == 0))[0]
    assert keep[west, 1:4, 4].any()
    assert (keep[west, :, 4] == keep[east, :, 0]).all()


def test_a_budget_the_feature_nodes_would_spend_goes_to_the_worst_errors_first():
    from ingest.categorise import categorise
    from ingest.reduce import category_nodes, rebuild_error, refine
    from tdb.tiles import corner_mask

    # Shallow valleys through every tile (their nodes stand 0.3 m out of the corners' surface)
    # and one 2 m pit off the valley lines: three nodes cannot keep every valley node.
    def surface(x, y):
        return 0.3 * np.abs((x % 2.0) - 1.0) - 2.0 * np.exp(-((x - 4.5) ** 2 + (y - 5.0) ** 2) / 0.05)

    tiles, ti, tj = _tiles(surface)
    codes = categorise(tiles, flat_threshold=0.1, n=5)
    corners = np.broadcast_to(corner_mask(5), tiles.shape)
    standing_out = category_nodes(codes, n=5) & (rebuild_error(tiles, corners, n=5) > 0.1)
    assert standing_out.sum() > 3
    pit = np.flatnonzero((ti == 2) & (tj == 2))[0]
    before = rebuild_error(tiles, corners, n=5)[pit].max()
    keep = refine(tiles, codes, ti, tj, n=5, budget=3, relief=0.1).keep
    assert rebuild_error(tiles, keep, n=5)[pit].max() < before / 2


@pytest.mark.parametrize("level", [2, 4, 8, 16])
def test_node_lattices_read_on_the_posts_are_the_bilinear_reads(level):
    """Nodes fall on the dense model's posts: read there directly (and smoothed only where read),
    they are what a bilinear read of the whole smoothed model gives."""
    from ingest.tiles import _post_index, _smoothed, node_grid
    from tdb.raster import Raster

    rng = np.random.default_rng(level)
    dtm = Raster(rng.normal(size=(203, 187)), 999.75, 2000.25, 0.5)  # posts on whole half metres, as ingest's
    dtm.data[5:9, 7:20] = np.nan
    g = node_grid(dtm, level)
    xs = (g.i0 + np.arange(g.z.shape[1])) * g.spacing
    ys = (g.j0 + np.arange(g.z.shape[0])) * g.spacing
    gx, gy = np.meshgrid(xs, ys)
    source = _smoothed(dtm, sigma=0.5 * g.spacing / dtm.cell) if g.spacing > dtm.cell * 1.01 else dtm
    ref = source.sample(gx.ravel(), gy.ravel()).reshape(gx.shape)
    assert _post_index(source, xs, ys) is not None  # the direct read, not the bilinear one
    np.testing.assert_array_equal(np.isnan(ref), np.isnan(g.z))
    np.testing.assert_allclose(g.z[~np.isnan(ref)], ref[~np.isnan(ref)], atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_reduction_error_counts_every_post_once(seed):
    """The rebuild's error is measured at every post of the dense model once, though tiles share
    their edge nodes: the same figures as a post-by-post tally, on a model with ragged edges and holes."""
    from ingest.pyramid import reduction_stats
    from ingest.tiles import node_grid
    from tdb.surface import line_rebuild_at
    from tdb.tiles import SUBGRID, node_lattice

    rng = np.random.default_rng(seed)
    rows, cols = 97, 83
    yy, xx = np.mgrid[0:rows, 0:cols] * 0.5
    data = np.sin(xx / 3.0) + 0.3 * np.cos(yy / 2.0) + rng.normal(0, 0.05, (rows, cols))
    data[rng.random((rows, cols)) < 0.02] = np.nan  # holes
    data[:, : rng.integers(1, 9)] = np.nan  # a ragged edge
    dtm = Raster(data, 999.75, 1000.25 + 0.5 * rows, 0.5)
    model = build(dtm, flat_threshold=0.1, measure=False)
    stats = reduction_stats(dtm, model)
    tiles = model.levels[2]
    keep = (model.n & level_bit(2)) > 0
    kept = node_lattice(model.x[keep], model.y[keep], model.z[keep], 2)
    rebuilt = line_rebuild_at(kept.tile_nodes(tiles.xg, tiles.yg))
    dense = node_grid(dtm, 2)
    truth = dense.tile_nodes(tiles.xg, tiles.yg).reshape(len(tiles.xg), -1)
    tally: dict[tuple[int, int], float] = {}
    for t in range(len(tiles.xg)):
        for k in range(SUBGRID * SUBGRID):
            e = rebuilt[t, k] - truth[t, k]
            if np.isfinite(e):
                tally[(int(tiles.xg[t] * 2) + k % SUBGRID, int(tiles.yg[t] * 2) + k // SUBGRID)] = e
    err = np.array(list(tally.values()))
    assert stats.rmse_m == pytest.approx(round(float(np.sqrt(np.mean(err**2))), 4), abs=1e-4)
    assert stats.max_error_m == pytest.approx(round(float(np.abs(err).max()), 4), abs=1e-4)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_refinements_own_errors_are_the_kept_lattices(seed):
    """The reduction's figures read from the errors the refinement keeps up to date are those of
    the surface rebuilt afresh from the kept points' lattice, on a model with holes, a ragged
    edge and a budget that runs out (so that shared edge nodes matter)."""
    from ingest.categorise import categorise
    from ingest.pyramid import reduction_stats
    from ingest.reduce import budget_for, refine
    from ingest.tiles import node_grid
    from tdb.surface import line_rebuild_at
    from tdb.tiles import SUBGRID, node_lattice

    rng = np.random.default_rng(seed)
    rows, cols = 121, 109
    yy, xx = np.mgrid[0:rows, 0:cols] * 0.5
    data = np.sin(xx / 2.0) + 0.8 * np.cos(yy / 1.5) + rng.normal(0, 0.08, (rows, cols))
    data[rng.random((rows, cols)) < 0.03] = np.nan
    data[:, : rng.integers(1, 9)] = np.nan
    data[40:55, 30:47] = np.nan  # a hole the lines cannot cross
    dtm = Raster(data, 999.75, 1000.25 + 0.5 * rows, 0.5)
    measured = build(dtm, flat_threshold=0.1).stats
    model = build(dtm, flat_threshold=0.1, measure=False)
    assert measured is not None and measured.rmse_m is not None
    assert measured == reduction_stats(dtm, model)
    # node by node, as build refines the finest level
    grid = node_grid(dtm, 2)
    tiles, ti, tj = grid.tiles(SUBGRID)
    some = ~np.isnan(tiles).all(axis=1)
    tiles, ti, tj = tiles[some], ti[some], tj[some]
    codes = categorise(tiles, flat_threshold=0.1, n=SUBGRID)
    own = refine(tiles, codes, ti, tj, n=SUBGRID, budget=budget_for(grid, n=SUBGRID), relief=0.1, measure=True)
    keep = (model.n & level_bit(2)) > 0
    kept = node_lattice(model.x[keep], model.y[keep], model.z[keep], 2)
    afresh = np.abs(line_rebuild_at(kept.tile_nodes(ti * 2, tj * 2)) - tiles)
    assert own.line_error is not None and np.isnan(afresh).any()
    np.testing.assert_allclose(own.line_error, afresh, rtol=0, atol=1e-12)
