"""Area pages: blocks of tiles and points read back exactly as the row tables hold them."""

from __future__ import annotations

import sqlite3

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from tdb.blocks import points_from_blocks, tile_blocks, tiles_from_blocks


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), level=st.sampled_from([2, 4, 8, 16]), n=st.integers(0, 400))
def test_tile_blocks_round_trip_any_bbox(seed, level, n):
    rng = np.random.default_rng(seed)
    cells = rng.choice(400 * 400, size=n, replace=False)
    xg = (cells % 400).astype(np.int64) * level - 300 * level + 500_000
    yg = (cells // 400).astype(np.int64) * level - 200 * level
    code = rng.choice(np.r_[np.arange(115), 255], size=n).astype(np.uint8)  # no-data tiles are stored too
    x0, y0 = rng.uniform(xg.min(initial=500_000), xg.max(initial=500_100), 2) if n else (500_000.0, 0.0)
    bbox = (float(x0), float(y0 - 500), float(x0 + rng.uniform(0, 900)), float(y0 + rng.uniform(0, 900)))
    got = tiles_from_blocks(list(tile_blocks(xg, yg, code, level=level)), bbox, level=level)
    want = (xg + level > bbox[0]) & (xg < bbox[2]) & (yg + level > bbox[1]) & (yg < bbox[3])
    assert sorted(zip(*(a.tolist() for a in got))) == sorted(
        zip(xg[want].tolist(), yg[want].tolist(), code[want].tolist())
    )


@settings(max_examples=40, deadline=None)
@given(
    x0=st.integers(-700, 800),
    y0=st.integers(-300, 1000),
    w=st.integers(0, 1600),
    h=st.integers(0, 1400),
    mask=st.sampled_from([1, 4, 8, 15]),
)
def test_point_blocks_filter_by_bbox_and_level(x0, y0, w, h, mask):
    """Boxes from within one block to several, with edges on block edges and on points (half
    metres: the points lie on a 0.5 m lattice, block edges included)."""
    from tdb.blocks import point_blocks

    rng = np.random.default_rng(5)
    x = np.round(rng.uniform(-600, 900, 6000) * 2) / 2
    y = np.round(rng.uniform(-300, 1100, 6000) * 2) / 2
    z = rng.normal(size=6000)
    n = rng.integers(1, 16, 6000).astype(np.uint8)
    bbox = (x0 / 2, y0 / 2, (x0 + w) / 2, (y0 + h) / 2) if w < 400 else (x0, y0, x0 + w, y0 + h)
    got = points_from_blocks(list(point_blocks(x, y, z, n)), bbox, mask=mask)
    want = (x >= bbox[0]) & (x <= bbox[2]) & (y >= bbox[1]) & (y <= bbox[3]) & ((n & mask) > 0)
    assert sorted(zip(got[0], got[1], got[2])) == sorted(zip(x[want], y[want], z[want]))


def test_whole_blocks_inside_a_box_come_whole():
    from tdb.blocks import point_blocks

    x = np.array([0.0, 255.99, 256.0, 511.5, 512.0, -0.5])
    y = np.array([0.0, 10.0, 255.99, 256.0, 100.0, 3.0])
    n = np.full(6, 15, np.uint8)
    got = points_from_blocks(list(point_blocks(x, y, x * 0, n)), (0.0, 0.0, 512.0, 512.0), mask=1)
    assert sorted(got[0].tolist()) == [0.0, 255.99, 256.0, 511.5, 512.0]


def _write(db):
    rng = np.random.default_rng(1)
    k = np.arange(900)
    levels = {
        lv: ((k % 30) * lv + 500_000, (k // 30) * lv + 5_000_000, rng.integers(0, 115, 900).astype(np.uint8))
        for lv in (2, 4, 8, 16)
    }
    pts = ((k % 30) * 2.0 + 500_000, (k // 30) * 2.0 + 5_000_000, rng.normal(size=900), np.full(900, 15, np.uint8))
    db.write_version("v", levels=levels, points=pts)
    return levels, pts


def test_aoi_matches_row_tables(tmp_path):
    db = tdb.open(tmp_path / "a.tdb", create=True)
    _write(db)
    bbox = (500_010.0, 5_000_007.0, 500_041.0, 5_000_033.0)
    area = db.aoi(bbox, level=4)
    # a category filter reads the c4 rows, not the blocks
    xg, yg, code = db.tiles("v", level=4, bbox=bbox, categories=list(range(256)))
    assert len(code) > 0
    assert sorted(zip(area.xg.tolist(), area.yg.tolist(), area.code.tolist())) == sorted(
        zip(xg.tolist(), yg.tolist(), code.tolist())
    )
    con = sqlite3.connect(tmp_path / "a.tdb")
    rows = con.execute(
        "SELECT x, y, z FROM tdb WHERE x >= ? AND y >= ? AND x <= ? AND y <= ? AND (n & 2) > 0", bbox
    ).fetchall()
    con.close()
    assert len(rows) > 0
    assert sorted(zip(area.x.tolist(), area.y.tolist(), area.z.tolist())) == sorted(rows)
    x, y, z, _ = db.points("v", level=4, bbox=bbox)
    assert sorted(zip(x.tolist(), y.tolist(), z.tolist())) == sorted(rows)


def test_schema_1_file_is_upgraded_with_blocks(tmp_path):
    path = tmp_path / "old.tdb"
    db = tdb.open(path, create=True)
    _write(db)
    bbox = (500_000.0, 5_000_000.0, 500_030.0, 5_000_030.0)
    before = db.aoi(bbox, level=2)
    db.engine.dispose()
    con = sqlite3.connect(path)
    con.execute("DROP TABLE tile_blocks")
    con.execute("DROP TABLE point_blocks")
    con.execute("UPDATE meta SET value = '1' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    again = tdb.open(path)
    assert again.schema_version() == tdb.schema.SCHEMA_VERSION
    after = again.aoi(bbox, level=2)
    assert sorted(zip(before.xg.tolist(), before.yg.tolist(), before.code.tolist())) == sorted(
        zip(after.xg.tolist(), after.yg.tolist(), after.code.tolist())
    )
    np.testing.assert_array_equal(np.sort(before.z), np.sort(after.z))
