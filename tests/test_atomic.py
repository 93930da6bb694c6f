"""The atomic-write helper: outputs appear whole or not at all, and never replace a terrain database."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

import tdb
from ingest.pipeline import ingest
from tdb.atomic import is_terrain_database, write_bytes, write_text
from tdb.cli import main
from tdb.errors import TdbIOError


@pytest.fixture(scope="module")
def park(tmp_path_factory, small_cloud):
    path = tmp_path_factory.mktemp("park") / "park.tdb"
    db = tdb.open(path, create=True)
    ingest(small_cloud, db, version="A")
    db.close()  # its write-ahead log checkpointed: the file alone holds the database
    return path


def test_an_output_onto_a_terrain_database_is_refused_and_the_database_kept(park):
    before = park.read_bytes()
    assert is_terrain_database(park)
    with pytest.raises(TdbIOError, match="terrain database"):
        write_text(park, "{}")
    assert park.read_bytes() == before


@pytest.mark.parametrize(
    "args",
    [
        ["query", "SELECT ditch FROM A", "--format", "gpkg", "--out", "{db}"],
        ["query", "SELECT ditch FROM A", "--out", "{db}"],
        ["query", "SELECT ditch FROM A", "--png", "{db}"],
    ],
)
def test_the_command_line_never_writes_its_output_over_the_database(park, args):
    before = park.read_bytes()
    r = CliRunner().invoke(main, [a.format(db=park) for a in args] + ["--db", str(park)])
    assert r.exit_code != 0
    assert "Traceback" not in r.output and "terrain database" in r.output
    assert park.read_bytes() == before
    assert [v.name for v in tdb.open(park).versions()] == ["A"]


def test_other_files_are_replaced_whole(tmp_path):
    target = tmp_path / "out.geojson"
    write_text(target, json.dumps({"a": 1}))
    write_text(target, json.dumps({"a": 2}))
    assert json.loads(target.read_text()) == {"a": 2}
    # an SQLite file that is not a terrain database (a GeoPackage written before) may be replaced
    other = tmp_path / "old.gpkg"
    import sqlite3

    con = sqlite3.connect(other)
    con.execute("CREATE TABLE gpkg_contents (table_name TEXT)")
    con.commit()
    con.close()
    assert not is_terrain_database(other)
    write_bytes(other, b"new")
    assert other.read_bytes() == b"new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.gpkg", "out.geojson"]  # no partial files
