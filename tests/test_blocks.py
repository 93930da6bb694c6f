"""Area pages: blocks of tiles and points read back exactly as the row tables hold them."""

from __future__ import annotations

import sqlite3

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import tdb
from tdb.blocks import tile_blocks, tiles_from_blocks
from tdb.point_pages import point_blocks, points_from_blocks


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
    rng = np.random.default_rng(5)
    x = np.round(rng.uniform(-600, 900, 6000) * 2) / 2
    y = np.round(rng.uniform(-300, 1100, 6000) * 2) / 2
    z = rng.normal(size=6000)
    n = rng.integers(1, 16, 6000).astype(np.uint8)
    bbox = (x0 / 2, y0 / 2, (x0 + w) / 2, (y0 + h) / 2) if w < 400 else (x0, y0, x0 + w, y0 + h)
    got = points_from_blocks(list(point_blocks(x, y, z, n)), bbox, mask=mask)
    want = (x >= bbox[0]) & (x <= bbox[2]) & (y >= bbox[1]) & (y <= bbox[3]) & ((n & mask) > 0)
    g, w = np.lexsort((got[2], got[1], got[0])), np.lexsort((z[want], y[want], x[want]))
    np.testing.assert_array_equal(got[0][g], x[want][w])  # half metres: exact as offsets
    np.testing.assert_array_equal(got[1][g], y[want][w])
    np.testing.assert_allclose(got[2][g], z[want][w], rtol=0, atol=2.0**-15)


def test_whole_blocks_inside_a_box_come_whole():
    x = np.array([0.0, 255.99, 256.0, 511.5, 512.0, -0.5])
    y = np.array([0.0, 10.0, 255.99, 256.0, 100.0, 3.0])
    n = np.full(6, 15, np.uint8)
    got = points_from_blocks(list(point_blocks(x, y, x * 0, n)), (0.0, 0.0, 512.0, 512.0), mask=1)
    np.testing.assert_allclose(np.sort(got[0]), [0.0, 255.99, 256.0, 511.5, 512.0], rtol=0, atol=2.0**-15)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    east=st.floats(-1e6, 1e7),
    north=st.floats(-1e6, 1e7),
    low=st.floats(-500, 8000),
    relief=st.floats(0, 2000),
)
@example(seed=204, east=-5.0, north=0.0, low=0.0, relief=0.0)  # two x a micrometre apart
def test_point_pages_keep_coordinates_to_their_stated_precision(seed, east, north, low, relief):
    """x, y as float32 offsets from the block's corner, z in whole 2^-14 m: within 2^-17 m
    horizontally and 2^-15 m vertically, wherever the survey lies."""
    rng = np.random.default_rng(seed)
    x = east + rng.uniform(0, 700, 500)
    y = north + rng.uniform(0, 700, 500)
    z = low + rng.uniform(0, relief, 500)
    n = rng.integers(1, 16, 500).astype(np.uint8)
    inf = float("inf")
    got = points_from_blocks(list(point_blocks(x, y, z, n)), (-inf, -inf, inf, inf), mask=15)
    # each point read back paired with the nearest written (two points a micrometre apart in x
    # may come back in either order, so sorting both would pair them wrong)
    _, w = cKDTree(np.column_stack([x, y])).query(np.column_stack([got[0], got[1]]))
    assert np.array_equal(np.sort(w), np.arange(len(x)))  # every point once
    assert np.abs(got[0] - x[w]).max() <= 2.0**-17
    assert np.abs(got[1] - y[w]).max() <= 2.0**-17
    assert np.abs(got[2] - z[w]).max() <= 2.0**-15
    np.testing.assert_array_equal(got[3], n[w])


def _old_page(x, y, z, n):
    """A page as schemas before 6 wrote it: absolute float64 columns."""
    return b"".join(a.astype("<f8").tobytes() for a in (x, y, z)) + n.astype(np.uint8).tobytes()


def test_pages_of_the_old_layout_are_read_and_merged():
    from tdb.point_pages import merge_point_pages

    x, y = np.array([300.25, 400.125, 511.0]), np.array([10.5, 20.0, 255.5])
    z, n = np.array([101.1, 99.7, 100.3]), np.array([1, 3, 15], np.uint8)
    old = _old_page(x, y, z, n)
    got = points_from_blocks([(1, 0, old)], (0.0, 0.0, 1024.0, 1024.0), mask=1)
    np.testing.assert_array_equal(got[2], z)  # read as written, to the bit
    ((_, _, new),) = point_blocks(x + 0.5, y, z + 1.0, n)
    merged = points_from_blocks([(1, 0, merge_point_pages((1, 0), old, new))], (0.0, 0.0, 1024.0, 1024.0), mask=2)
    np.testing.assert_allclose(np.sort(merged[0]), [400.125, 400.625, 511.0, 511.5], atol=2.0**-15)


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
    # the pages hold the rows' points to their precision (tdb.point_pages)
    want = np.array(sorted(rows))
    for x, y, z in ((area.x, area.y, area.z), db.points("v", level=4, bbox=bbox)[:3]):
        got = np.array(sorted(zip(x.tolist(), y.tolist(), z.tolist())))
        np.testing.assert_allclose(got, want, rtol=0, atol=2.0**-15)


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


def test_a_schema_5_file_with_float64_pages_reads_the_same_read_only_and_upgraded(tmp_path):
    from tdb.point_pages import decoded

    path = tmp_path / "old.tdb"
    db = tdb.open(path, create=True)
    _write(db)
    bbox = (500_000.0, 5_000_000.0, 500_060.0, 5_000_060.0)
    before = db.points("v", level=2, bbox=bbox)
    db.close()
    con = sqlite3.connect(path)
    for bx, by, data in con.execute("SELECT bx, by, data FROM point_blocks").fetchall():
        page = decoded(bx, by, data)
        con.execute(
            "UPDATE point_blocks SET data = ? WHERE bx = ? AND by = ?",
            (_old_page(*page.absolute(), page.n), bx, by),
        )
    con.execute("UPDATE meta SET value = '5' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    with tdb.open(path, readonly=True) as old:
        assert old.schema_version() == 5
        for got, want in zip(old.points("v", level=2, bbox=bbox), before):
            np.testing.assert_array_equal(got, want)
    with tdb.open(path) as upgraded:
        assert upgraded.schema_version() == tdb.schema.SCHEMA_VERSION
        levels = {lv: upgraded.tiles("v", level=lv, ordered=False) for lv in (2, 4, 8, 16)}
        x, y, z, n = upgraded.points("v", level=16, bbox=None)
        upgraded.write_version("w", levels=levels, points=(x + 3.0, y, z, n))
        for got, want in zip(upgraded.points("v", level=2, bbox=bbox), before):
            np.testing.assert_array_equal(got, want)
        w = upgraded.points("w", level=16)
        np.testing.assert_allclose(np.sort(w[0]), np.sort(x + 3.0), rtol=0, atol=2.0**-15)
