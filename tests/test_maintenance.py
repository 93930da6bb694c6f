"""Everyday operations on a database: delete or rename a version, check the file."""

from __future__ import annotations

import json
import sqlite3

import numpy as np
import pytest
from click.testing import CliRunner

import tdb
from ingest.pipeline import ingest
from tdb.cli import main


@pytest.fixture()
def park(tmp_path, small_cloud):
    path = tmp_path / "park.tdb"
    db = tdb.open(path, create=True)
    ingest(small_cloud, db, version="A")
    ingest(small_cloud, db, version="B")
    db.close()
    return path


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_rm_deletes_one_version_and_leaves_the_other(park):
    r = _run("rm", "A", "--db", park)
    assert r.exit_code == 0, r.output
    db = tdb.open(park)
    assert [v.name for v in db.versions()] == ["B"]
    assert db.count("B") > 0 and len(db.evidence("B")) > 0
    r = _run("rm", "A", "--db", park)
    assert r.exit_code != 0 and "no version 'A'" in r.output and "Traceback" not in r.output


def test_rename_keeps_the_model_and_refuses_a_taken_name(park):
    before = tdb.open(park).count("A")
    assert _run("rename", "A", "2019", "--db", park).exit_code == 0
    db = tdb.open(park)
    assert [v.name for v in db.versions()] == ["2019", "B"]
    assert db.count("2019") == before
    r = _run("rename", "2019", "B", "--db", park)
    assert r.exit_code != 0 and "exists" in r.output
    r = _run("rename", "2019", " ", "--db", park)
    assert r.exit_code != 0 and "name" in r.output


def test_check_passes_a_whole_database(park):
    r = _run("check", park, "--json")
    assert r.exit_code == 0, r.output
    doc = json.loads(r.output)
    assert doc["ok"] and doc["integrity"] == "ok" and [v["name"] for v in doc["versions"]] == ["A", "B"]


def test_check_finds_missing_rows(park):
    con = sqlite3.connect(park)
    vid = con.execute("SELECT id FROM versions WHERE name = 'B'").fetchone()[0]
    xg, yg = con.execute("SELECT xg, yg FROM c4 WHERE version = ? LIMIT 1", (vid,)).fetchone()
    con.execute("DELETE FROM c4 WHERE version = ? AND xg = ? AND yg = ?", (vid, xg, yg))
    con.commit()
    con.close()
    r = _run("check", park)
    assert r.exit_code == 1
    assert "B:" in r.output and "rows missing" in r.output


def test_check_finds_a_damaged_file(park):
    data = bytearray(park.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 4096] = bytes(range(256)) * 16
    park.write_bytes(bytes(data))
    r = _run("check", park)
    assert r.exit_code != 0 and "Traceback" not in r.output
    assert "damaged" in r.output or "malformed" in r.output


def _area(path, version):
    db = tdb.open(path, readonly=True)
    try:
        b = db.version(version).stats.bounds
        a = db.aoi((b[0], b[1], b[2], b[3]), level=2, version=version)
        return a.xg, a.yg, a.code, a.x, a.y, a.z, a.n
    finally:
        db.close()


def test_compact_gives_back_a_deleted_versions_space_and_keeps_the_rest(park):
    before = _area(park, "B")
    assert _run("rm", "A", "--db", park).exit_code == 0
    size = park.stat().st_size
    assert json.loads(_run("check", park, "--json").output)["free_share"] > 0.3
    assert "tdb compact" in _run("check", park).output
    r = _run("compact", "--db", park)
    assert r.exit_code == 0, r.output
    assert park.stat().st_size < 0.7 * size
    assert json.loads(_run("check", park, "--json").output)["free_share"] == 0.0
    after = _area(park, "B")
    for old, new in zip(before, after):
        np.testing.assert_array_equal(old, new)
    assert json.loads(_run("check", park, "--json").output)["ok"]


def test_compact_into_a_new_file_leaves_the_database_as_it_is(park, tmp_path):
    original = park.read_bytes()
    copy = tmp_path / "archive" / "park-compact.tdb"
    copy.parent.mkdir()
    r = _run("compact", "--db", park, "--into", copy)
    assert r.exit_code == 0, r.output
    assert park.read_bytes() == original
    assert [v.name for v in tdb.open(copy, readonly=True).versions()] == ["A", "B"]
    for old, new in zip(_area(park, "A"), _area(copy, "A")):
        np.testing.assert_array_equal(old, new)
    # a terrain database is never written over, and nothing is left beside it
    r = _run("compact", "--db", park, "--into", copy)
    assert r.exit_code != 0 and "terrain database" in r.output and "Traceback" not in r.output
    assert sorted(p.name for p in copy.parent.iterdir()) == ["park-compact.tdb"]


BLOB_TABLES = ("tile_blocks", "point_blocks", "evidence_blocks", "trees", "buildings")


def _layout(path):
    """Whether each table of BLOBs is a rowid table, and whether its rows lie in key order."""
    con = sqlite3.connect(path)
    try:
        out = {}
        for name in BLOB_TABLES:
            sql = con.execute("SELECT sql FROM sqlite_master WHERE name = ?", (name,)).fetchone()[0]
            keys = "version, level, bx, by" if name == "tile_blocks" else "version, bx, by"
            if name in ("trees", "buildings"):
                keys += ", x, y"
            rowid = "WITHOUT ROWID" not in sql
            by_rowid = con.execute(f"SELECT {keys} FROM {name} ORDER BY rowid").fetchall() if rowid else []
            out[name] = (rowid, by_rowid == sorted(by_rowid))
        return out
    finally:
        con.close()


def _old_layout(path):
    """The tables of BLOBs rebuilt as they were made before they were rowid tables."""
    con = sqlite3.connect(path)
    with con:
        for name in BLOB_TABLES:
            sql = con.execute("SELECT sql FROM sqlite_master WHERE name = ?", (name,)).fetchone()[0]
            con.execute(sql.replace(f"CREATE TABLE {name}", f"CREATE TABLE {name}_old", 1) + " WITHOUT ROWID")
            con.execute(f"INSERT INTO {name}_old SELECT * FROM {name} ORDER BY random()")
            con.execute(f"DROP TABLE {name}")
            con.execute(f"ALTER TABLE {name}_old RENAME TO {name}")
    con.close()


def test_compact_lays_the_tables_of_blobs_out_as_rowid_tables_in_key_order(park, tmp_path):
    # a new database has the layout; its rows lie as they were written
    assert all(rowid for rowid, _ in _layout(park).values())
    before = {v: _area(park, v) for v in ("A", "B")}
    trees = [(t.x, t.y, t.height) for t in tdb.open(park, readonly=True).trees("A")]
    assert trees
    assert json.loads(_run("check", park, "--json").output)["old_layout"] == []
    _old_layout(park)
    assert not any(rowid for rowid, _ in _layout(park).values())
    report = _run("check", park)
    assert report.exit_code == 0 and "older layout" in report.output and "tdb compact" in report.output
    assert json.loads(_run("check", park, "--json").output)["old_layout"] == sorted(BLOB_TABLES)
    copy = tmp_path / "copy.tdb"
    assert _run("compact", "--db", park, "--into", copy).exit_code == 0
    assert _run("compact", "--db", park).exit_code == 0
    for path in (park, copy):
        assert _layout(path) == dict.fromkeys(BLOB_TABLES, (True, True)), path
        for v in ("A", "B"):
            for old, new in zip(before[v], _area(path, v)):
                np.testing.assert_array_equal(old, new)
        with tdb.open(path, readonly=True) as db:
            assert sorted((t.x, t.y, t.height) for t in db.trees("A")) == sorted(trees)
        checked = json.loads(_run("check", path, "--json").output)
        assert checked["ok"] and checked["old_layout"] == []


def test_a_database_of_an_older_schema_is_upgraded_before_it_is_copied_compact(park, tmp_path):
    con = sqlite3.connect(park)
    with con:
        con.execute("UPDATE meta SET value = '5' WHERE key = 'schema_version'")
    con.close()
    r = _run("compact", "--db", park, "--into", tmp_path / "copy.tdb")
    assert r.exit_code != 0 and "upgrade" in r.output and "Traceback" not in r.output
    assert not (tmp_path / "copy.tdb").exists()
