"""The same database on PostgreSQL, through the same SQLAlchemy metadata.

Runs when ``TDB_TEST_POSTGRES`` names a database URL the test may fill and empty, e.g.
``postgresql+psycopg://postgres@/tdbtest?host=/tmp&port=54329`` (needs the ``postgres`` extra).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import tdb
from ingest.pipeline import ingest
from ingest.synth import apply_changes, make_scene, sample
from queries.changes import detect

URL = os.environ.get("TDB_TEST_POSTGRES")
pytestmark = pytest.mark.skipif(not URL, reason="set TDB_TEST_POSTGRES to a PostgreSQL URL to run")


@pytest.fixture
def pg():
    pytest.importorskip("psycopg")
    db = tdb.open(URL, create=True)
    for v in db.versions():
        db.delete_version(v.name)
    yield db
    for v in db.versions():
        db.delete_version(v.name)


def test_round_trip_area_sql_filter_and_diff_on_postgresql(pg, tmp_path):
    scene = make_scene(seed=4, size=100)
    cloud = sample(scene, density=2.0, seed=4)
    v = ingest(cloud, pg, version="s")
    area = pg.aoi(scene.bounds, level=2)
    assert len(area.code) == v.stats.reduction.tiles[2]
    # the same survey in SQLite gives the same tiles and points
    lite = tdb.open(tmp_path / "s.tdb", create=True)
    ingest(cloud, lite, version="s")
    other = lite.aoi(scene.bounds, level=2)
    assert sorted(zip(area.xg.tolist(), area.yg.tolist(), area.code.tolist())) == sorted(
        zip(other.xg.tolist(), other.yg.tolist(), other.code.tolist())
    )
    np.testing.assert_allclose(np.sort(area.z), np.sort(other.z))
    # the objects too, their outlines read in the server's binary format
    assert area.trees and [(t.x, t.y, t.height, t.crown.wkb) for t in area.trees] == [
        (t.x, t.y, t.height, t.crown.wkb) for t in other.trees
    ]
    assert [b.footprint.wkb for b in area.buildings] == [b.footprint.wkb for b in other.buildings]
    with pg.engine.connect() as conn:  # pages stored LZ4-compressed where the server can (14 on)
        if conn.dialect.server_version_info >= (14,):
            methods = conn.exec_driver_sql("SELECT DISTINCT pg_column_compression(data) FROM point_blocks")
            assert set(methods.scalars()) - {None} == {"lz4"}
    _, _, flat = pg.tiles("s", level=2, categories=[0])
    assert len(flat) == int((area.code == 0).sum())
    later, _ = apply_changes(scene, seed=4)
    resurvey = sample(later, density=2.0, seed=9)
    ingest(resurvey, pg, version="t")
    ingest(resurvey, lite, version="t")
    assert [f["properties"]["kind"] for f in detect(pg, "s", "t")] == [
        f["properties"]["kind"] for f in detect(lite, "s", "t")
    ]


def test_blocked_ingest_and_its_resume_on_postgresql(pg, tmp_path, monkeypatch):
    """Blocks written one by one (pages merged across them) into PostgreSQL, as into SQLite; a
    killed run leaves no version there and resumes from its finished blocks."""
    import ingest.blocked as blocked
    from ingest.blocked import Blocking, ingest_blocked
    from ingest.synth import write_scene

    path = tmp_path / "b.laz"
    write_scene(path, make_scene(seed=6, size=100), density=2, seed=6)
    cut = Blocking(block=48.0, buffer=32.0, workers=1)
    lite = tdb.open(tmp_path / "b.tdb", create=True)
    ingest_blocked(path, lite, version="b", blocking=cut)
    real, calls = blocked._one_block, []

    def dies_at_the_third(*a, **kw):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(1)
        return real(*a, **kw)

    monkeypatch.setattr(blocked, "_one_block", dies_at_the_third)
    with pytest.raises(KeyboardInterrupt):
        ingest_blocked(path, pg, version="b", blocking=cut)
    assert pg.versions() == []
    monkeypatch.setattr(blocked, "_one_block", real)
    ingest_blocked(path, pg, version="b", blocking=cut, resume=True)
    for level in (2, 4, 8, 16):
        a, b = pg.aoi((-1e6, -1e6, 1e7, 1e7), level=level), lite.aoi((-1e6, -1e6, 1e7, 1e7), level=level)
        assert sorted(zip(a.xg.tolist(), a.yg.tolist(), a.code.tolist())) == sorted(
            zip(b.xg.tolist(), b.yg.tolist(), b.code.tolist())
        ), level
        assert sorted(zip(a.x.tolist(), a.y.tolist(), a.z.tolist())) == sorted(
            zip(b.x.tolist(), b.y.tolist(), b.z.tolist())
        ), level
    assert pg.version("b").stats == lite.version("b").stats


def test_the_command_line_takes_a_postgresql_url_and_says_what_is_wrong_in_one_line(pg, tmp_path):
    """The URL reaches the database as written (a path type would fold its //); a user without
    rights is told so at open, before any work, in one line."""
    import sqlalchemy
    from click.testing import CliRunner

    from ingest.synth import write_scene
    from tdb.cli import main

    src = tmp_path / "s.laz"
    write_scene(src, make_scene(seed=3, size=100), density=1, seed=3)
    runner = CliRunner()
    r = runner.invoke(main, ["ingest", str(src), "--db", URL, "--version", "cli"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["info", URL])
    assert r.exit_code == 0 and "cli" in r.output, r.output
    with pg.engine.begin() as conn:
        conn.exec_driver_sql("DROP ROLE IF EXISTS tdb_reader")
        conn.exec_driver_sql("CREATE ROLE tdb_reader LOGIN")
    try:
        reader = sqlalchemy.make_url(URL).set(username="tdb_reader").render_as_string(hide_password=False)
        for args in (["info", reader], ["ingest", str(src), "--db", reader, "--version", "x"]):
            r = runner.invoke(main, args)
            assert r.exit_code == 1 and "lacks the rights" in r.output, r.output
            assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output
        with pg.engine.begin() as conn:
            conn.exec_driver_sql("GRANT SELECT ON ALL TABLES IN SCHEMA public TO tdb_reader")
        assert runner.invoke(main, ["info", reader]).exit_code == 0  # reading is enough to read
        r = runner.invoke(main, ["rm", "cli", "--db", reader])
        assert r.exit_code == 1 and "lacks the rights to write" in r.output, r.output
    finally:
        with pg.engine.begin() as conn:
            conn.exec_driver_sql("DROP OWNED BY tdb_reader")
            conn.exec_driver_sql("DROP ROLE tdb_reader")


def test_compact_rewrites_a_server_database_in_place_and_refuses_a_file(pg, tmp_path):
    from tdb.compact import compact
    from tdb.errors import InputError

    scene = make_scene(seed=5, size=100)
    ingest(sample(scene, density=2.0, seed=5), pg, version="s")
    before = pg.aoi(scene.bounds, level=2)
    done = compact(pg)
    assert done.bytes_before is None and done.bytes_after is None
    after = pg.aoi(scene.bounds, level=2)
    np.testing.assert_array_equal(np.sort(before.z), np.sort(after.z))
    assert sorted(before.code.tolist()) == sorted(after.code.tolist())
    with pytest.raises(InputError, match="server database"):
        compact(pg, into=tmp_path / "copy.tdb")


def test_a_whole_survey_query_in_worker_processes_on_postgresql(pg):
    """Each worker opens the server database by its URL (with its password) and matches its batches."""
    from unittest import mock

    import queries.parts
    from queries.match import find

    ingest(sample(make_scene(seed=3, size=300), density=2.0, seed=3), pg, version="w")
    assert pg.location is not None and pg.location.startswith("postgresql")
    whole = find(pg, "w", "ditch")
    with mock.patch.multiple(queries.parts, PART=256, PART_NODES=1000):  # parts of one block
        parted = find(pg, "w", "ditch", workers=2)

    def key(matches):
        return sorted((f"{m.measure:.9f}", m.geometry.normalize().wkt) for m in matches)

    assert whole and key(parted) == key(whole)
