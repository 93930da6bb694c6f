"""The terrain database schema (SQLAlchemy Core), portable to SQLite and PostgreSQL.

``versions``: one row per survey of the area. ``tdb``: the kept points (x, y, z)
with the 4-bit level mask n. ``c2`` … ``c16``: the category of every tile, keyed
by its lower-left corner in whole metres. ``categories``: what each code means.
``meta``: the schema version. ``tile_blocks`` and ``point_blocks``: the same
tiles and points cut into square blocks stored as BLOBs, for reading an area at
once (:mod:`tdb.blocks`). ``evidence_blocks``: the ground evidence of the 2 m tiles
(:mod:`tdb.evidence`) in the same blocks. ``coregistrations``: the shifts found between
two versions (JSON), kept so that later queries reuse them. ``trees`` and ``buildings``: the
objects found on the ground (seed §2.2–2.3), keyed by the tree's top or the footprint's
centroid, with the outline as WKB.
"""

from __future__ import annotations

import math
from typing import Any

from sqlalchemy import (
    Column,
    Date,
    Float,
    ForeignKey,
    Integer,
    LargeBinary,
    MetaData,
    SmallInteger,
    String,
    Table,
    Text,
    and_,
)

from tdb.tiles import LEVELS

# 2: tile_blocks, point_blocks; 3: evidence_blocks, coregistrations; 4: trees, buildings;
# 5: the objects keyed by their block first; 6: point pages of float32 x, y offsets and int32 z
# (tdb.point_pages; those written before are still read, but an older tdb would misread the new)
SCHEMA_VERSION = 6
LEVEL_TABLES = {level: f"c{level}" for level in LEVELS}

metadata = MetaData()

meta = Table("meta", metadata, Column("key", String(64), primary_key=True), Column("value", Text, nullable=False))

versions = Table(
    "versions",
    metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("name", String(200), nullable=False, unique=True),
    Column("acquired", Date, nullable=True),
    Column("source", Text, nullable=True),
    Column("crs", Text, nullable=True),
    Column("params", Text, nullable=False, default="{}"),
    Column("stats", Text, nullable=False, default="{}"),
    Column("created", String(32), nullable=False),
)

categories = Table(
    "categories",
    metadata,
    Column("code", SmallInteger, primary_key=True, autoincrement=False),
    Column("inclination", SmallInteger, nullable=False),
    Column("feature", SmallInteger, nullable=False),
    Column("orient_from", SmallInteger, nullable=True),
    Column("orient_to", SmallInteger, nullable=True),
    Column("flat_side", SmallInteger, nullable=False),
    Column("description", String(200), nullable=False),
)

# Each table's B-tree index is its primary key. On SQLite the small rows of the row tables live
# in that B-tree itself (WITHOUT ROWID), which halves the work of every insert. Tables of BLOBs
# (pages, objects' outlines) are rowid tables with their key a separate index: a row larger than
# a fraction of a page overflows, and SQLite reads a WITHOUT ROWID row's whole payload at each
# comparison while it seeks, which made an area read fetch its point pages about three times over.
points = Table(
    "tdb",
    metadata,
    Column("version", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
    Column("x", Float(53), primary_key=True),
    Column("y", Float(53), primary_key=True),
    Column("z", Float(53), nullable=False),
    Column("n", SmallInteger, nullable=False),
    sqlite_with_rowid=False,
)


def _level_table(name: str) -> Table:
    table = Table(
        name,
        metadata,
        Column("version", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
        Column("xg", Integer, primary_key=True, autoincrement=False),
        Column("yg", Integer, primary_key=True, autoincrement=False),
        Column("c", SmallInteger, nullable=False),
        sqlite_with_rowid=False,
    )
    return table


level_tables = {level: _level_table(name) for level, name in LEVEL_TABLES.items()}

tile_blocks = Table(
    "tile_blocks",
    metadata,
    Column("version", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
    Column("level", SmallInteger, primary_key=True, autoincrement=False),
    Column("bx", Integer, primary_key=True, autoincrement=False),
    Column("by", Integer, primary_key=True, autoincrement=False),
    Column("codes", LargeBinary, nullable=False),
)


def _block_table(name: str) -> Table:
    """A version's BLOBs, one per square block (bx, by) of the area."""
    return Table(
        name,
        metadata,
        Column("version", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
        Column("bx", Integer, primary_key=True, autoincrement=False),
        Column("by", Integer, primary_key=True, autoincrement=False),
        Column("data", LargeBinary, nullable=False),
    )


point_blocks = _block_table("point_blocks")
evidence_blocks = _block_table("evidence_blocks")

coregistrations = Table(
    "coregistrations",
    metadata,
    Column("before", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
    Column("after", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
    Column("setting", String(200), primary_key=True),
    Column("shift", Text, nullable=False),
)


OBJECT_BLOCK = 256.0  # m: the side of the square blocks (bx, by) that lead an object's key


def _object_table(name: str, *columns: Column) -> Table:
    """One row per object of a version, keyed by its block and its position (bx, by, x, y): the
    B-tree an area read walks, one seek per column of blocks the box meets."""
    return Table(
        name,
        metadata,
        Column("version", Integer, ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True),
        Column("bx", Integer, primary_key=True, autoincrement=False),
        Column("by", Integer, primary_key=True, autoincrement=False),
        Column("x", Float(53), primary_key=True),
        Column("y", Float(53), primary_key=True),
        *columns,
    )


trees = _object_table(
    "trees",
    Column("height", Float, nullable=False),
    Column("crown_diameter", Float, nullable=False),
    Column("crown", LargeBinary, nullable=False),
)
buildings = _object_table(
    "buildings",
    Column("height", Float, nullable=False),
    Column("area", Float, nullable=False),
    Column("footprint", LargeBinary, nullable=False),
)


# The rowid tables: their rows lie in the order they were written, so compaction rewrites them in
# key order (tdb.compact).
BLOB_TABLES = (tile_blocks, point_blocks, evidence_blocks, trees, buildings)


def blob_compression() -> list[str]:
    """PostgreSQL statements that compress the BLOB columns with LZ4 (PostgreSQL 14 on).

    A server compresses a BLOB larger than about 2 kB on its own; its default method (pglz)
    decompresses a point page several times slower than LZ4, which shrinks them as much, so an
    area read waited on the server's decompression. SQLite stores BLOBs as they are."""
    return [
        f'ALTER TABLE "{table.name}" ALTER COLUMN "{column.name}" SET COMPRESSION lz4'
        for table in BLOB_TABLES
        for column in table.columns
        if isinstance(column.type, LargeBinary)
    ]


def ddl(dialect_name: str = "sqlite") -> str:
    """CREATE statements for every table and index, for ``schemas/``."""
    from sqlalchemy.dialects import postgresql, sqlite
    from sqlalchemy.schema import CreateIndex, CreateTable

    dialect = {"sqlite": sqlite.dialect(), "postgresql": postgresql.dialect()}[dialect_name]
    parts = [f"-- tdb schema version {SCHEMA_VERSION} ({dialect_name}); generated from tdb/schema.py"]
    for table in metadata.sorted_tables:
        parts.append(str(CreateTable(table).compile(dialect=dialect)).strip() + ";")
        for index in sorted(table.indexes, key=lambda i: str(i.name)):
            parts.append(str(CreateIndex(index).compile(dialect=dialect)).strip() + ";")
    if dialect_name == "postgresql":
        statements = ";\n".join(blob_compression())
        parts.append(f"-- PostgreSQL 14 on; an older server keeps its default\n{statements};")
    return "\n\n".join(parts) + "\n"


MAX_SEEKS = 256  # block columns sought one by one; a wider box reads the columns' range


def in_blocks(table: Table, bbox: tuple[float, float, float, float], side: float) -> Any:
    """The condition that a row of ``table`` (keyed by ``bx``, ``by``) lies in a block of
    ``side`` m that meets ``bbox``."""
    bx0, bx1 = math.floor(bbox[0] / side), math.floor(bbox[2] / side)
    by0, by1 = math.floor(bbox[1] / side), math.floor(bbox[3] / side)
    # One seek per column of blocks: with a range on bx the B-tree would be walked through
    # every block of those columns, however far north or south of the box they lie.
    columns = table.c.bx.in_(range(bx0, bx1 + 1)) if bx1 - bx0 < MAX_SEEKS else table.c.bx.between(bx0, bx1)
    return and_(columns, table.c.by.between(by0, by1))
