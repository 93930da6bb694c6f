"""Blocked ingest: the same model as a one-piece ingest of the same area, and catalogs of tiles."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tdb
from ingest.blocked import Blocking, ingest_blocked
from ingest.catalog import open_catalog
from ingest.pipeline import ingest
from ingest.readers import read, write_las
from ingest.synth import make_scene, write_scene
from tdb.errors import CRSError, FormatError, InputError, TdbIOError
from tdb.tiles import LEVELS
from tests.conftest import two_patches


def _codes(db, version, level):
    xg, yg, code = db.tiles(version, level=level)
    return dict(zip(zip(xg.tolist(), yg.tolist()), code.tolist()))


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("blocked") / "s.laz"
    write_scene(path, make_scene(seed=5, size=200), density=3, seed=5)
    return path


@pytest.mark.slow
def test_blocks_give_the_one_piece_model(scene_file, tmp_path):
    db = tdb.open(tmp_path / "b.tdb", create=True)
    whole = ingest(scene_file, db, version="whole")
    blocks = ingest_blocked(scene_file, db, version="blocks", blocking=Blocking(block=96, buffer=64, workers=2))
    # measured on the same square of the same lattice, however the survey is cut
    assert blocks.params["flat_threshold"] == whole.params["flat_threshold"]
    # the workers' own peak memory: they are the fork server's children, not this process's
    assert 50 < blocks.params["worker_peak_mib"] < 4000
    assert "worker_peak_mib" not in whole.params
    for level in LEVELS:
        a, b = _codes(db, "whole", level), _codes(db, "blocks", level)
        assert set(a) == set(b), level  # every tile, once
        same = np.mean([a[k] == b[k] for k in a])
        assert same >= 0.995, (level, same)
    pa, pb = db.points("whole", level=2), db.points("blocks", level=2)
    assert abs(len(pb[0]) - len(pa[0])) <= 0.02 * len(pa[0])
    ra, rb = db.version("whole").stats.reduction, db.version("blocks").stats.reduction
    assert rb.dense_posts == ra.dense_posts
    assert abs((rb.rmse_m or 0) - (ra.rmse_m or 0)) <= 0.005
    # the ground evidence of every tile, once, as in one piece
    ea, eb = db.evidence("whole"), db.evidence("blocks")
    assert len(ea) == len(eb) == len(_codes(db, "whole", 2))
    back = eb.at(ea.xg, ea.yg)
    assert np.mean(back.support == ea.support) >= 0.995
    assert np.mean(np.abs(back.lift - ea.lift) < 0.01) >= 0.99
    for field in ("pulses", "ground_share"):  # each pulse counted in the block that owns it
        assert np.mean(np.isclose(getattr(back, field), getattr(ea, field), equal_nan=True)) >= 0.999, field
    sa, sb = db.version("whole").stats, db.version("blocks").stats
    assert sa.covered_pct is not None and sb.covered_pct is not None
    assert abs(sa.covered_pct - sb.covered_pct) <= 0.1
    # the same trees and buildings, each once: objects belong to the block their top or centroid is in
    ta, tb = db.trees("whole"), db.trees("blocks")
    tops_b = {(round(t.x, 3), round(t.y, 3)) for t in tb}
    assert len(tb) == len({(round(t.x, 3), round(t.y, 3)) for t in tb})
    assert np.mean([(round(t.x, 3), round(t.y, 3)) in tops_b for t in ta]) >= 0.95
    assert abs(len(tb) - len(ta)) <= 0.05 * len(ta)
    assert len(db.buildings("blocks")) == len(db.buildings("whole"))


def test_a_catalog_of_tiles_is_one_survey(scene_file, tmp_path):
    cloud = read(scene_file)
    x0 = cloud.xyz[:, 0].min()
    west = cloud.xyz[:, 0] < x0 + 100
    for name, part in (("w.laz", west), ("e.laz", ~west)):
        write_las(tmp_path / name, cloud.take(np.flatnonzero(part)))
    catalog = open_catalog(tmp_path)
    assert len(catalog.files) == 2 and catalog.points == len(cloud)
    box = (x0 + 90, cloud.xyz[:, 1].min(), x0 + 110, cloud.xyz[:, 1].min() + 50)
    inside = (
        (cloud.xyz[:, 0] >= box[0])
        & (cloud.xyz[:, 0] <= box[2])
        & (cloud.xyz[:, 1] >= box[1])
        & (cloud.xyz[:, 1] <= box[3])
    )
    assert len(catalog.read(box)) == int(inside.sum())  # across the seam between the two files
    db = tdb.open(tmp_path / "c.tdb", create=True)
    v = ingest_blocked(str(tmp_path / "*.laz"), db, version="cat", blocking=Blocking(block=256, workers=1))
    assert v.stats.points == len(cloud)
    assert v.stats.reduction.tiles[2] == 100 * 100


def test_catalog_tiles_in_different_systems_are_refused(scene_file, tmp_path):
    import dataclasses

    from pyproj import CRS

    cloud = read(scene_file)
    write_las(tmp_path / "a.laz", cloud)
    write_las(tmp_path / "b.laz", dataclasses.replace(cloud, crs=CRS.from_epsg(32633)))
    with pytest.raises(CRSError, match="share one coordinate system"):
        open_catalog(tmp_path)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="no LAS/LAZ"):
        open_catalog(empty)
    with pytest.raises(TdbIOError):
        open_catalog(tmp_path / "nothing-here.laz")
    with pytest.raises(InputError, match="multiple of 16"):
        Blocking(block=100)
    # a text file is read whole: block by block says so, not that a LAS signature is bad
    text = tmp_path / "s.xyz"
    np.savetxt(text, cloud.xyz[:100], fmt="%.3f")
    with pytest.raises(FormatError, match="LAS/LAZ files only"):
        ingest_blocked(text, tdb.open(tmp_path / "t.tdb", create=True), version="v")


def test_the_command_line_ingests_a_directory_of_tiles(scene_file, tmp_path):
    from click.testing import CliRunner

    from tdb.cli import main

    cloud = read(scene_file)
    north = cloud.xyz[:, 1] >= cloud.xyz[:, 1].min() + 100
    tiles = tmp_path / "tiles"
    tiles.mkdir()
    for name, part in (("n.laz", north), ("s.laz", ~north)):
        write_las(tiles / name, cloud.take(np.flatnonzero(part)))
    db = tmp_path / "t.tdb"
    r = CliRunner().invoke(main, ["ingest", str(tiles), "--db", str(db), "--version", "v", "--workers", "1"])
    assert r.exit_code == 0, r.output
    with tdb.open(db) as d:
        assert d.version("v").stats.points == len(cloud)
        assert d.version("v").params["blocks"] >= 1
        assert "worker_peak_mib" not in d.version("v").params  # modelled in this process


def test_a_file_too_large_to_model_whole_goes_block_by_block(scene_file, tmp_path, monkeypatch):
    """Whether a file fits a whole ingest is told from its header's count and the memory; the
    command line then ingests it block by block and says so."""
    from click.testing import CliRunner

    import ingest.catalog
    from ingest.catalog import WHOLE_BYTES_PER_POINT, too_large_to_model_whole
    from tdb.cli import main

    points = open_catalog([scene_file]).points
    need = points * WHOLE_BYTES_PER_POINT
    assert too_large_to_model_whole(scene_file, memory=need)  # half of it is too little
    assert not too_large_to_model_whole(scene_file, memory=2 * need)
    text = tmp_path / "s.xyz"
    text.write_text("0 0 0\n1 0 0\n0 1 0\n")
    assert not too_large_to_model_whole(text, memory=1)  # no header to count
    # a machine of this memory takes the survey whole; one of a thousandth of it, block by block
    monkeypatch.setattr(ingest.catalog, "WHOLE_BYTES_PER_POINT", 10**9)
    db = tmp_path / "t.tdb"
    r = CliRunner().invoke(main, ["ingest", str(scene_file), "--db", str(db), "--version", "v"])
    assert r.exit_code == 0, r.output
    assert "block by block" in r.output
    with tdb.open(db) as d:
        assert d.version("v").params["blocks"] >= 1
        assert "worker_peak_mib" not in d.version("v").params  # modelled in this process
        assert d.version("v").stats.points == points


@settings(max_examples=50, deadline=None)
@given(st.floats(0.0, 200.0), st.floats(0.0, 200.0), st.sampled_from([0.0, 32.0, 64.0, 128.0]))
def test_denser_surveys_get_smaller_blocks_on_the_tile_lattice(d1, d2, buffer):
    from ingest.block_size import MAX_BLOCK, MIN_BLOCK, block_side

    lo, hi = sorted((d1, d2))
    a, b = block_side(lo, buffer=buffer), block_side(hi, buffer=buffer)
    assert MIN_BLOCK <= b <= a <= MAX_BLOCK
    assert a % max(LEVELS) == 0 and b % max(LEVELS) == 0


def test_a_dense_survey_is_cut_into_blocks_a_worker_can_hold(scene_file, tmp_path, monkeypatch):
    """Without a side given, the blocks are as large as a worker's memory allows at the survey's
    density: here, a worker of a tenth of the memory gets a 200 m survey in several blocks."""
    import ingest.block_size
    from ingest.block_size import MAX_BLOCK, block_side

    density = open_catalog([scene_file]).points / 200.0**2
    assert block_side(density, buffer=64.0) == MAX_BLOCK  # a sparse survey: the largest blocks
    monkeypatch.setattr(ingest.block_size, "WORKER_MEMORY", 0.1 * ingest.block_size.WORKER_MEMORY)
    side = block_side(density, buffer=64.0)
    assert side < 200.0
    db = tdb.open(tmp_path / "d.tdb", create=True)
    v = ingest_blocked(scene_file, db, version="v", blocking=Blocking(workers=1))
    assert v.params["blocks"] >= (200.0 // side) ** 2 > 1
    assert v.stats.points == open_catalog([scene_file]).points


def test_blocks_read_feet_in_metres(scene_file, tmp_path):
    """A survey in US survey feet (State Plane deliveries) is modelled block by block in metres,
    as a whole ingest converts it: the same tiles, kept points and CRS with metre axes. Degrees
    need a projection, not a scale: refused."""
    import dataclasses

    from pyproj import CRS

    cloud = read(scene_file)
    foot = 1200 / 3937
    feet = tmp_path / "feet.laz"
    write_las(feet, dataclasses.replace(cloud, xyz=cloud.xyz / foot, crs=CRS.from_epsg(2263)))  # NY, US feet
    db = tdb.open(tmp_path / "f.tdb", create=True)
    whole = ingest(feet, db, version="whole")
    blocks = ingest_blocked(feet, db, version="blocks", blocking=Blocking(block=96, buffer=64, workers=1))
    assert blocks.params["blocks"] >= 4
    assert blocks.stats.points == whole.stats.points == len(cloud)
    assert blocks.stats.bounds == pytest.approx(whole.stats.bounds)
    assert db.crs("blocks").equals(db.crs("whole"))
    assert "metre" in db.crs("blocks").axis_info[0].unit_name
    for level in LEVELS:
        a, b = _codes(db, "whole", level), _codes(db, "blocks", level)
        assert set(a) == set(b), level
        assert np.mean([a[k] == b[k] for k in a]) >= 0.995, level
    pa, pb = db.points("whole", level=2), db.points("blocks", level=2)
    assert abs(len(pb[0]) - len(pa[0])) <= 0.02 * len(pa[0])
    degrees = tmp_path / "degrees.laz"
    lonlat = (cloud.xyz - cloud.xyz.min(axis=0)) * np.array([1e-5, 1e-5, 1.0]) + np.array([10.0, 50.0, 0.0])
    write_las(degrees, dataclasses.replace(cloud, xyz=lonlat, crs=CRS.from_epsg(4326)))
    with pytest.raises(CRSError, match="metres"):
        ingest_blocked(degrees, tdb.open(tmp_path / "g.tdb", create=True), version="v")


def test_blocks_modelled_on_a_dask_cluster_are_those_of_the_process_pool(tmp_path):
    distributed = pytest.importorskip("distributed")
    small = tmp_path / "small.laz"
    write_scene(small, make_scene(seed=6, size=100), density=2, seed=6)
    db = tdb.open(tmp_path / "d.tdb", create=True)
    cut = {"block": 48.0, "buffer": 32.0}
    ingest_blocked(small, db, version="pool", blocking=Blocking(**cut, workers=1))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as c:
        ingest_blocked(small, db, version="dask", blocking=Blocking(**cut, scheduler=c.scheduler_address))
    assert db.version("dask").params["blocks"] >= 4
    for level in LEVELS:
        assert _codes(db, "pool", level) == _codes(db, "dask", level), level
    np.testing.assert_array_equal(db.points("pool", level=2)[2], db.points("dask", level=2)[2])


def test_a_scheduler_that_does_not_answer_is_one_clear_error(scene_file, tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    import ingest.blocked as blocked
    from tdb.errors import TdbIOError

    monkeypatch.setattr(blocked, "CONNECT_SECONDS", 1)
    db = tdb.open(tmp_path / "e.tdb", create=True)
    with pytest.raises(TdbIOError, match="no dask scheduler answers"):
        ingest_blocked(scene_file, db, version="v", blocking=Blocking(block=96, scheduler="tcp://127.0.0.1:9"))
    assert db.versions() == []


def test_blocks_size_their_outlier_test_to_the_whole_survey(scene_file, tmp_path):
    """The scatter measures the density the ground filter would measure on the whole survey."""
    from ingest.blocked import _blocks, _scatter
    from ingest.catalog import open_catalog
    from ingest.ground.outliers import point_density
    from ingest.noise import square_counts
    from ingest.readers import read
    from tdb.classes import NOISE, excluded

    catalog = open_catalog([scene_file])
    sc = _scatter(catalog, _blocks(catalog.bounds, Blocking(block=96)), tmp_path, lambda *a: None, exclude=NOISE)
    assert sum(sc.own.values()) == catalog.points  # every point in one block's own square
    cloud = read(scene_file)
    seen = ~excluded(cloud.classification, NOISE)
    assert sc.density == pytest.approx(point_density(cloud.xyz[seen, :2]), rel=1e-12)
    assert sc.squares == square_counts(cloud.x[seen], cloud.y[seen])  # counted chunk by chunk


def test_the_providers_ground_class_blocked_is_the_one_piece_ground(scene_file, tmp_path):
    from click.testing import CliRunner

    from tdb.cli import main

    db = tmp_path / "c.tdb"
    args = ["ingest", str(scene_file), "--db", str(db), "--method", "classified"]
    r = CliRunner().invoke(main, [*args, "--version", "whole"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, [*args, "--version", "blocks", "--block", "96", "--workers", "1"])
    assert r.exit_code == 0, r.output
    with tdb.open(db) as d:
        assert d.version("blocks").params["blocks"] > 1
        for level in LEVELS:
            a, b = _codes(d, "whole", level), _codes(d, "blocks", level)
            assert set(a) == set(b)
            assert np.mean([a[k] == b[k] for k in a]) >= 0.995, level
    # a survey whose provider classified no ground: one line, non-zero, the database as it was
    bare = read(scene_file)
    bare = bare.take(np.flatnonzero(bare.classification != 2))
    write_las(tmp_path / "bare.laz", bare)
    r = CliRunner().invoke(
        main,
        ["ingest", str(tmp_path / "bare.laz"), "--db", str(db), "--version", "bare", "--method", "classified"],
    )
    assert r.exit_code != 0 and "classified ground" in r.output and len(r.output.strip().splitlines()) == 1
    with tdb.open(db) as d:
        assert "bare" not in [v.name for v in d.versions()] and "blocks" in [v.name for v in d.versions()]


def test_buffered_tiles_hold_each_point_once(scene_file, tmp_path):
    # tiles delivered with a 20 m buffer: the strip between them is in both files
    cloud = read(scene_file)
    x = cloud.xyz[:, 0]
    x0 = x.min()
    west, east = x < x0 + 110, x >= x0 + 90
    for name, part in (("w.laz", west), ("e.laz", east)):
        write_las(tmp_path / name, cloud.take(np.flatnonzero(part)))
    twice = int((west & east).sum())
    catalog = open_catalog(tmp_path)
    assert twice > 1000 and catalog.points == len(cloud) + twice  # the headers count the strip twice
    box = (x0 + 80, cloud.xyz[:, 1].min(), x0 + 120, cloud.xyz[:, 1].min() + 50)
    inside = (x >= box[0]) & (x <= box[2]) & (cloud.xyz[:, 1] >= box[1]) & (cloud.xyz[:, 1] <= box[3])
    got = catalog.read(box)
    assert len(got) == int(inside.sum())
    mm = [np.unique(np.round(xyz * 1000).astype(np.int64), axis=0) for xyz in (got.xyz, cloud.xyz[inside])]
    np.testing.assert_array_equal(*mm)
    db = tdb.open(tmp_path / "c.tdb", create=True)
    v = ingest_blocked(str(tmp_path / "*.laz"), db, version="cat", blocking=Blocking(block=256, workers=1))
    assert v.stats.points == len(cloud)
    assert v.params["overlap_points_dropped"] == twice
    from click.testing import CliRunner

    from tdb.cli import main

    r = CliRunner().invoke(main, ["info", str(tmp_path / "c.tdb")])
    assert r.exit_code == 0 and f"held twice, kept once: {twice:,}" in r.output


def test_overlapping_tiles_keep_their_own_distinct_points():
    from ingest.overlaps import SharedPoints
    from ingest.readers import RECORD

    rng = np.random.default_rng(4)
    a = np.zeros(400, RECORD)
    a["x"], a["y"], a["z"], a["r"] = rng.uniform(0, 100, 400), rng.uniform(0, 100, 400), rng.normal(size=400), 1
    b = a[a["x"] > 60].copy()  # the second tile repeats the first one's east strip ...
    b["z"][::2] += 0.5  # ... but half its points are other returns at the same place
    b["r"][1::4] = 2  # and some are other returns of the same pulse
    shared = SharedPoints([(0, 0, 100, 100), (60, 0, 160, 100)])
    assert len(shared(0, a)) == len(a)
    kept = shared(1, b)
    same = (np.arange(len(b)) % 2 == 1) & (np.arange(len(b)) % 4 != 1)
    assert shared.dropped == int(same.sum()) and len(kept) == len(b) - int(same.sum())


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    tiles=st.integers(1, 4),
    buffer=st.floats(0.0, 30.0),
    chunk=st.integers(50, 2000),
)
def test_buffered_tilings_in_any_order_give_each_point_once(seed, tiles, buffer, chunk):
    from ingest.overlaps import SharedPoints
    from ingest.readers import RECORD

    rng = np.random.default_rng(seed)
    points = np.zeros(3000, RECORD)
    points["x"], points["y"] = rng.uniform(0, 300, 3000), rng.uniform(0, 300, 3000)
    points["z"], points["r"] = rng.normal(size=3000), 1
    side = 300 / tiles
    parts = []
    for i in range(tiles):
        for j in range(tiles):
            x0, y0 = i * side - buffer, j * side - buffer
            inside = (
                (points["x"] >= x0)
                & (points["x"] < x0 + side + 2 * buffer)
                & (points["y"] >= y0)
                & (points["y"] < y0 + side + 2 * buffer)
            )
            parts.append(points[inside])
    parts = [parts[k] for k in rng.permutation(len(parts))]
    shared = SharedPoints([(p["x"].min(), p["y"].min(), p["x"].max(), p["y"].max()) for p in parts])
    kept = np.concatenate(
        [shared(k, p[s : s + chunk]) for k, p in enumerate(parts) for s in range(0, len(p), chunk)]
    )
    assert len(kept) == len(points) and shared.dropped == sum(map(len, parts)) - len(points)
    np.testing.assert_array_equal(np.sort(kept["z"]), np.sort(points["z"]))


def test_points_beyond_their_header_bounds_are_refused_not_lost(scene_file, tmp_path):
    import struct

    from tdb.errors import FormatError

    path = tmp_path / "bad.las"
    write_las(path, read(scene_file))
    with open(path, "r+b") as fh:  # LAS header: max x at byte 179, min x at 187 (doubles)
        fh.seek(179)
        max_x, min_x = struct.unpack("<2d", fh.read(16))
        fh.seek(179)
        fh.write(struct.pack("<d", min_x + 0.5 * (max_x - min_x)))  # as if the header held half the file
    db = tdb.open(tmp_path / "c.tdb", create=True)
    with pytest.raises(FormatError, match="beyond the bounds its header declares"):
        ingest_blocked(path, db, version="v", blocking=Blocking(block=64, workers=1))
    assert db.versions() == []  # nothing stored


def test_a_file_spread_over_a_wide_extent_goes_block_by_block(small_cloud, tmp_path, monkeypatch):
    """Few points over a wide box (two patches 3 km apart, as a corridor survey spreads): a whole
    ingest's grids span the box, so the extent decides as much as the count. The command line
    ingests such a file block by block, where only the blocks holding points are modelled."""
    from click.testing import CliRunner

    import ingest.catalog
    from ingest.catalog import too_large_to_model_whole
    from tdb.cli import main

    wide, near = tmp_path / "wide.laz", tmp_path / "near.laz"
    write_las(wide, two_patches(small_cloud, 3_000.0))
    write_las(near, two_patches(small_cloud, 100.0))
    memory = 4 * 2**30
    assert too_large_to_model_whole(wide, memory=memory)  # about 4 GiB of grids for 9 km²
    assert not too_large_to_model_whole(near, memory=memory)
    monkeypatch.setattr(ingest.catalog, "physical_bytes", lambda: memory)
    db = tmp_path / "w.tdb"
    r = CliRunner().invoke(main, ["ingest", str(wide), "--db", str(db), "--version", "v"])
    assert r.exit_code == 0, r.output
    assert "block by block" in r.output
    assert re.search(r"points, 0\.0[0-9] km² \(in a box of 9\.[0-9]+ km²\)", r.output), r.output
    with tdb.open(db) as d:
        assert d.version("v").stats.points == 2 * len(small_cloud)
        assert d.version("v").params["blocks"] <= 4  # a block or two at each patch, none between


def test_the_extent_is_measured_in_metres(small_cloud, tmp_path):
    """A header's bounds in US survey feet cover a tenth of the square metres they would as metres."""
    import dataclasses

    from pyproj import CRS

    from ingest.catalog import extent_m2, too_large_to_model_whole

    feet = dataclasses.replace(two_patches(small_cloud, 30_000.0), crs=CRS.from_epsg(2903))
    metres = dataclasses.replace(feet, crs=CRS.from_epsg(32633))
    write_las(tmp_path / "ft.laz", feet)
    write_las(tmp_path / "m.laz", metres)
    ft, m = (extent_m2(open_catalog([tmp_path / n])) for n in ("ft.laz", "m.laz"))
    assert ft == pytest.approx(m * (1200 / 3937) ** 2, rel=1e-6)
    memory = 100 * 2**30  # 37 GB of grids over the feet's 84 km², 400 GB over the metres' 900 km²
    assert not too_large_to_model_whole(tmp_path / "ft.laz", memory=memory)
    assert too_large_to_model_whole(tmp_path / "m.laz", memory=memory)
