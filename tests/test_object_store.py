"""Trees and buildings in the database: an area read finds exactly the objects whose outline meets
the box, across block edges and on negative coordinates, and a schema 4 file (objects keyed by
x and y alone) reads the same, read only as it is and writable once upgraded."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from sqlalchemy import text

import tdb
from tdb.database import VersionInfo
from tdb.objects import Building, Tree

EMPTY = np.empty(0)


def _objects(seed: int = 0) -> tuple[list[Tree], list[Building]]:
    """Trees and buildings strewn over 1.2 km across the origin, so that boxes cut block edges."""
    rng = np.random.default_rng(seed)
    trees = []
    for x, y, r in zip(rng.uniform(-600, 600, 400), rng.uniform(-600, 600, 400), rng.uniform(1, 9, 400)):
        trees.append(Tree(float(x), float(y), float(5 + r), float(2 * r), shapely.Point(x, y).buffer(r)))
    buildings = []
    for x, y, w in zip(rng.uniform(-600, 600, 40), rng.uniform(-600, 600, 40), rng.uniform(5, 60, 40)):
        buildings.append(Building(shapely.box(x, y, x + w, y + w / 2), float(w / 5)))
    return trees, buildings


def _store(path, trees, buildings) -> tdb.Database:
    db = tdb.open(path, create=True)
    empty = {lv: (EMPTY.astype(np.int64), EMPTY.astype(np.int64), EMPTY.astype(np.uint8)) for lv in (2, 4, 8, 16)}
    with db.writing("v", info=VersionInfo()) as w:
        w.add(levels=empty, points=(EMPTY, EMPTY, EMPTY, EMPTY.astype(np.uint8)), objects=(trees, buildings))
        w.describe(params={}, stats={})
    return db


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    trees, buildings = _objects()
    return trees, buildings, _store(tmp_path_factory.mktemp("objects") / "o.tdb", trees, buildings)


def _expected(trees, buildings, box):
    b = shapely.box(*box)
    return (
        sorted((t.x, t.y) for t in trees if t.crown.intersects(b)),
        sorted(round(bd.area, 6) for bd in buildings if bd.footprint.intersects(b)),
    )


def _found(db, box):
    return (
        sorted((t.x, t.y) for t in db.trees("v", bbox=box)),
        sorted(round(bd.area, 6) for bd in db.buildings("v", bbox=box)),
    )


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-700, 650),
    y=st.floats(-700, 650),
    w=st.floats(0.5, 600),
    h=st.floats(0.5, 600),
)
def test_an_area_read_finds_exactly_the_objects_meeting_the_box(stored, x, y, w, h) -> None:
    trees, buildings, db = stored
    box = (x, y, x + w, y + h)
    assert _found(db, box) == _expected(trees, buildings, box)


def test_every_object_is_read_back_whole(stored) -> None:
    trees, buildings, db = stored
    back = {(t.x, t.y): t for t in db.trees("v")}
    assert len(back) == len(trees)
    for t in trees:
        assert back[(t.x, t.y)].crown.equals(t.crown) and back[(t.x, t.y)].height == t.height
    areas = sorted((round(b.area, 6) for b in buildings), reverse=True)
    assert [round(b.area, 6) for b in db.buildings("v")] == areas


def _as_schema_4(path) -> None:
    """The objects' tables rebuilt as schema 4 had them, keyed by (version, x, y)."""
    db = tdb.open(path)
    with db.engine.begin() as conn:
        for name, cols in (
            ("trees", "height FLOAT NOT NULL, crown_diameter FLOAT NOT NULL, crown BLOB NOT NULL"),
            ("buildings", "height FLOAT NOT NULL, area FLOAT NOT NULL, footprint BLOB NOT NULL"),
        ):
            keep = ", ".join(c.split()[0] for c in cols.split(", "))
            conn.execute(
                text(
                    f"CREATE TABLE old (version INTEGER NOT NULL, x FLOAT NOT NULL, y FLOAT NOT NULL, {cols}, "
                    "PRIMARY KEY (version, x, y)) WITHOUT ROWID"
                )
            )
            conn.execute(text(f"INSERT INTO old SELECT version, x, y, {keep} FROM {name}"))
            conn.execute(text(f"DROP TABLE {name}"))
            conn.execute(text(f"ALTER TABLE old RENAME TO {name}"))
        conn.execute(text("UPDATE meta SET value = '4' WHERE key = 'schema_version'"))
    db.close()


def test_a_schema_4_file_reads_the_same_before_and_after_its_upgrade(tmp_path) -> None:
    trees, buildings = _objects(seed=1)
    path = tmp_path / "old.tdb"
    _store(path, trees, buildings).close()
    _as_schema_4(path)
    boxes = [(-50.0, -50.0, 50.0, 50.0), (-600.0, 100.0, -255.0, 300.0), (0.0, 0.0, 1.0, 1.0)]
    with tdb.open(path, readonly=True) as db:
        assert db.schema_version() == 4
        for box in boxes:
            assert _found(db, box) == _expected(trees, buildings, box)
    with tdb.open(path) as db:
        assert db.schema_version() == tdb.schema.SCHEMA_VERSION
        with db.engine.connect() as conn:
            assert conn.execute(text("SELECT count(*) FROM trees WHERE bx IS NOT NULL")).scalar() == len(trees)
        for box in boxes:
            assert _found(db, box) == _expected(trees, buildings, box)
