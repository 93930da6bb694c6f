"""Read-only commands never write: not the file, not its journal mode, not beside it."""

from __future__ import annotations

import os
import sqlite3

import pytest
from click.testing import CliRunner
from sqlalchemy import text

import tdb
from ingest.pipeline import ingest
from tdb.cli import main
from tdb.errors import DatabaseError


@pytest.fixture(scope="module")
def park(tmp_path_factory, small_cloud):
    path = tmp_path_factory.mktemp("ro") / "park.tdb"
    db = tdb.open(path, create=True)
    ingest(small_cloud, db, version="A")
    db.close()
    return path


def _beside(path):
    return sorted(p.name for p in path.parent.iterdir())


@pytest.mark.parametrize(
    "args",
    [
        ["info", "{db}"],
        ["info", "{db}", "--json"],
        ["query", "SELECT ditch FROM A", "--db", "{db}"],
        ["aoi", "--db", "{db}", "--bbox", "500010,5500010,500040,5500040"],
    ],
)
def test_reading_commands_leave_the_file_as_it_was(park, args, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # aoi writes its default outputs (aoi.ply …) into the working directory
    before, files = park.read_bytes(), _beside(park)
    r = CliRunner().invoke(main, [a.format(db=park) for a in args])
    assert r.exit_code == 0, r.output
    assert park.read_bytes() == before
    assert _beside(park) == files  # no -wal or -shm left beside it


def test_a_read_only_database_refuses_writes_and_reads_as_immutable_where_it_cannot_be_written(
    park, small_cloud, monkeypatch
):
    db = tdb.open(park, readonly=True)
    with pytest.raises(DatabaseError):
        ingest(small_cloud, db, version="B")
    db.close()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if mode == os.W_OK else real(p, mode))
    assert not tdb.database.writable(park)
    db = tdb.open(park, readonly=True)
    assert [v.name for v in db.versions()] == ["A"]
    assert len(db.evidence("A")) > 0
    db.close()


def test_info_on_a_foreign_sqlite_file_keeps_its_journal_mode(tmp_path):
    other = tmp_path / "foreign.sqlite"
    con = sqlite3.connect(other)
    con.execute("CREATE TABLE t (a)")
    con.commit()
    con.close()
    before = other.read_bytes()
    r = CliRunner().invoke(main, ["info", str(other)])
    assert r.exit_code != 0 and "not a tdb database" in r.output
    assert other.read_bytes() == before  # still a rollback journal, not switched to WAL


def test_an_older_schema_is_read_as_it_is_and_not_upgraded(park, tmp_path):
    old = tmp_path / "old.tdb"
    old.write_bytes(park.read_bytes())
    con = sqlite3.connect(old)
    con.execute("DROP TABLE evidence_blocks")
    con.execute("DROP TABLE coregistrations")
    con.execute("UPDATE meta SET value = '2' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    before = old.read_bytes()
    db = tdb.open(old, readonly=True)
    assert db.schema_version() == 2
    assert [v.name for v in db.versions()] == ["A"] and len(db.evidence("A")) == 0
    with db.engine.connect() as conn:
        assert conn.execute(text("SELECT count(*) FROM tile_blocks")).scalar() > 0
    db.close()
    assert old.read_bytes() == before
