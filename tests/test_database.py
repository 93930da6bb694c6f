"""The terrain database: round trip, versions, bad files, schema DDL, kill -9 during ingest."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import tdb
from ingest.pipeline import ingest
from ingest.synth import make_scene, sample
from tdb.database import VersionInfo
from tdb.errors import DatabaseError, TdbIOError, VersionExistsError, VersionNotFoundError
from tdb.schema import ddl

SCHEMAS = Path(__file__).resolve().parents[1] / "schemas"


def _levels(seed=0, n=500):
    rng = np.random.default_rng(seed)
    out = {}
    for level in (2, 4, 8, 16):
        k = np.arange(n)
        out[level] = (
            (k % 25) * level + 500000,
            (k // 25) * level + 5000000,
            rng.integers(0, 115, n).astype(np.uint8),
        )
    return out


def _points(seed=0, n=1000):
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    return (
        (k % 40) * 0.5 + 500000,
        (k // 40) * 0.5 + 5000000,
        rng.normal(100, 1, n),
        rng.integers(1, 16, n).astype(np.uint8),
    )


def test_a_written_or_removed_version_leaves_no_journal_the_size_of_it(tmp_path):
    path = tmp_path / "j.tdb"
    db = tdb.open(path, create=True)
    wal = Path(f"{path}-wal")
    db.write_version("a", levels=_levels(n=20_000), points=_points(n=50_000))
    written = path.stat().st_size
    assert written > 2**20 and (not wal.exists() or wal.stat().st_size < written / 10)
    db.delete_version("a")
    assert not wal.exists() or wal.stat().st_size < written / 10
    db.close()


def test_round_trip(tmp_path):
    db = tdb.open(tmp_path / "a.tdb", create=True)
    levels, points = _levels(), _points()
    db.write_version("2020", levels=levels, points=points, info=VersionInfo(crs="EPSG:25832"))
    for level, (xg, yg, code) in levels.items():
        rx, ry, rc = db.tiles("2020", level=level)
        order = np.lexsort((yg, xg))
        np.testing.assert_array_equal(rx, xg[order])
        np.testing.assert_array_equal(ry, yg[order])
        np.testing.assert_array_equal(rc, code[order])
    x, y, z, _ = db.points("2020", level=2)
    keep = (points[3] & 1) > 0
    assert len(x) == keep.sum()
    got = sorted(zip(x, y, z))
    want = sorted(zip(points[0][keep], points[1][keep], points[2][keep]))
    np.testing.assert_allclose(np.array(got), np.array(want), rtol=0, atol=2.0**-15)  # the pages' precision


@pytest.mark.parametrize("n", [1, 199, 200, 201, 50_001])
def test_rows_written_whole_whatever_the_count(tmp_path, n):
    # rows go in many per statement; the last statement carries the remainder
    db = tdb.open(tmp_path / "a.tdb", create=True)
    levels, points = _levels(n=n), _points(n=n)
    db.write_version("v", levels=levels, points=points)
    db.close()
    con = sqlite3.connect(tmp_path / "a.tdb")
    for level, (xg, yg, code) in levels.items():
        got = np.array(con.execute(f"SELECT xg, yg, c FROM c{level} ORDER BY xg, yg").fetchall())
        order = np.lexsort((yg, xg))
        np.testing.assert_array_equal(got, np.column_stack([xg[order], yg[order], code[order]]))
    got = np.array(con.execute("SELECT x, y, z, n FROM tdb ORDER BY x, y").fetchall())
    order = np.lexsort((points[1], points[0]))
    np.testing.assert_array_equal(got, np.column_stack([p[order] for p in points]))
    assert {type(r[0]) for r in con.execute("SELECT n FROM tdb")} == {int}
    con.close()


def test_bbox_access(tmp_path):
    db = tdb.open(tmp_path / "a.tdb", create=True)
    db.write_version("v", levels=_levels(), points=_points())
    area = db.aoi((500004.0, 5000004.0, 500010.0, 5000008.0), level=2)
    # Tiles overlapping the box (a shared edge is no overlap): 500004, 500006, 500008.
    assert set(area.xg.tolist()) == {500004, 500006, 500008}
    assert ((area.x >= 500004) & (area.x <= 500010)).all()


def test_versions_replace_and_errors(tmp_path):
    path = tmp_path / "a.tdb"
    db = tdb.open(path, create=True)
    db.write_version("a", levels=_levels(1), points=_points(1))
    with pytest.raises(VersionExistsError):
        db.write_version("a", levels=_levels(2), points=_points(2))
    db.write_version("a", levels=_levels(2), points=_points(2), replace=True)
    db.write_version("b", levels=_levels(3), points=_points(3))
    assert [v.name for v in db.versions()] == ["a", "b"]
    assert db.count("a", table="c2") == 500
    with pytest.raises(VersionNotFoundError, match="versions: a, b"):
        db.tiles("zzz")
    db.delete_version("a")
    assert [v.name for v in db.versions()] == ["b"]


def test_missing_foreign_and_damaged_files(tmp_path):
    with pytest.raises(TdbIOError):
        tdb.open(tmp_path / "none.tdb")
    (tmp_path / "text.tdb").write_text("hello")
    with pytest.raises(DatabaseError, match="not an SQLite"):
        tdb.open(tmp_path / "text.tdb")
    other = sqlite3.connect(tmp_path / "other.db")
    other.execute("create table t (a int)")
    other.commit()
    other.close()
    with pytest.raises(DatabaseError, match="not a tdb database"):
        tdb.open(tmp_path / "other.db")
    good = tmp_path / "good.tdb"
    tdb.open(good, create=True).write_version("v", levels=_levels(), points=_points())
    data = bytearray(good.read_bytes())
    data[100:4000] = b"\x00" * 3900  # wipe the schema page
    broken = tmp_path / "broken.tdb"
    broken.write_bytes(bytes(data))
    with pytest.raises(DatabaseError):
        tdb.open(broken).versions()


def test_schema_files_match_metadata():
    assert (SCHEMAS / "tdb.sql").read_text() == ddl("sqlite"), "run: python -c 'from tdb.schema import ddl…'"
    assert (SCHEMAS / "tdb.postgresql.sql").read_text() == ddl("postgresql")


def test_ingest_synthetic_scene(tmp_path):
    scene = make_scene(seed=4, size=100)
    cloud = sample(scene, density=2.0, seed=4)
    db = tdb.open(tmp_path / "s.tdb", create=True)
    v = ingest(cloud, db, version="s")
    assert (
        v.stats.reduction.tiles[2] > 2300 and 85 < v.stats.reduction.reduction_pct < 99
    )  # 100 m square: 2500 at most
    assert v.stats.reduction.rmse_m < 0.1
    area = db.aoi(scene.bounds, level=2)
    assert len(area.code) == v.stats.reduction.tiles[2]
    with pytest.raises(VersionExistsError):
        ingest(cloud, db, version="s")


KILLER = textwrap.dedent(
    """
    import sys, numpy as np, tdb
    db = tdb.open(sys.argv[1])
    n = 3_000_000
    k = np.arange(n)
    levels = {2: ((k % 2000) * 2, (k // 2000) * 2, np.ones(n, np.uint8))}
    points = ((k % 2000) * 0.5, (k // 2000) * 0.5, np.zeros(n), np.ones(n, np.uint8))
    print("writing", flush=True)
    db.write_version("big", levels=levels, points=points)
    print("done", flush=True)
    """
)


@pytest.mark.slow
def test_kill_during_write_leaves_database_as_it_was(tmp_path):
    path = tmp_path / "k.tdb"
    db = tdb.open(path, create=True)
    db.write_version("kept", levels=_levels(), points=_points())
    db.close()
    proc = subprocess.Popen([sys.executable, "-c", KILLER, str(path)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "writing"
    time.sleep(1.5)  # well into the inserts
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    db = tdb.open(path)
    assert [v.name for v in db.versions()] == ["kept"]
    assert db.count("kept", table="c2") == 500 and db.count("kept") == 1000
    con = sqlite3.connect(path)
    assert con.execute("pragma integrity_check").fetchone()[0] == "ok"
    assert con.execute("select count(*) from c2 where version != 1").fetchone()[0] == 0
    con.close()


@pytest.mark.parametrize(
    ("url", "says"),
    [
        ("postgresql+psycopg://someone:secret@127.0.0.1:1/terrain", "Connection refused"),
        ("postgresql+nosuchdriver://someone:secret@host/terrain", "not a database URL tdb can open"),
        ("postgres://", "not a database URL tdb can open"),
    ],
)
def test_a_database_url_that_cannot_be_opened_is_one_line_without_its_password(url, says):
    from click.testing import CliRunner

    from tdb.cli import main

    if "psycopg" in url:
        pytest.importorskip("psycopg")
    with pytest.raises(DatabaseError, match=says) as caught:
        tdb.open(url)
    assert "secret" not in str(caught.value) and "\n" not in str(caught.value)
    r = CliRunner().invoke(main, ["info", url])
    assert r.exit_code == 1 and len(r.output.strip().splitlines()) == 1 and "secret" not in r.output, r.output
