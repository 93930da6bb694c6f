"""Tiles, categories per level, reduction and the 4-bit level masks."""

from __future__ import annotations

import numpy as np
import pytest

from ingest.pyramid import build
from ingest.reduce import level_bit
from ingest.tiles import LEVELS
from tdb.categories import NO_DATA, all_categories
from tdb.raster import Raster


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
    assert model.stats["rmse_m"] == pytest.approx(0.0, abs=1e-9)
    corners = (np.mod(model.x[model.n & 1 > 0], 2) == 0) & (np.mod(model.y[model.n & 1 > 0], 2) == 0)
    assert corners.all()
    assert model.stats["reduction_pct"] > 93


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
