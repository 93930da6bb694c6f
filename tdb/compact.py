"""A database rewritten compact: each table's pages in key order, no space left by deleted versions.

SQLite puts a new page wherever its file has one free. An ingest writes tiles, points, pages
and objects block by block, so the tables interleave through the file, and a deleted version
leaves its pages free inside it (the file never shrinks by itself). Where the file is larger than
the system's cache, an area read then seeks once per page it needs. Rewritten, each table and
index lies in key order, so that an area's rows come in a few runs of the file: the tables of
BLOBs (:data:`tdb.schema.BLOB_TABLES`, rowid tables whose rows lie in the order they were
written) are first copied afresh in key order, in the current layout (a database made before
they were rowid tables gets it now), and the file is then rewritten. PostgreSQL rewrites tdb's
tables in full and refreshes the planner's statistics.
"""

from __future__ import annotations

import os
import sqlite3
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

from sqlalchemy import Connection, Table
from sqlalchemy.dialects.sqlite import dialect as sqlite_dialect
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.schema import CreateTable

from tdb import schema
from tdb.atomic import atomic_path
from tdb.database import Database
from tdb.errors import DatabaseError, InputError


@dataclass(frozen=True)
class Compacted:
    """What a compaction wrote: the database (``db``'s name, or the new file) and the sizes of
    the file before and after (None for a server database)."""

    destination: str
    bytes_before: int | None
    bytes_after: int | None


def compact(db: Database, *, into: str | os.PathLike[str] | None = None) -> Compacted:
    """Rewrite ``db`` compact, in place, or into a new file ``into`` (SQLite only), leaving ``db``
    as it is.

    In place, SQLite needs free disk for two to three times the file while it works (the tables
    of BLOBs copied in key order inside it, then a copy of the whole and the journal that makes
    the rewrite all or nothing); into a new file, for one copy. An interruption leaves ``db`` as
    it was, and no part of ``into``.

    Raises
    ------
    InputError
        If ``into`` is given for a server database or a database of an older schema, or ``db``
        is open read only and no ``into`` is given.
    TdbIOError
        If ``into`` cannot be written (among others: it is a terrain database already).
    DatabaseError
        If the database refuses the rewrite (a full disk, missing rights).
    """
    file = _file(db)
    if into is not None and file is None:
        raise InputError(f"{db.name}: a server database is rewritten in place, not into a file")
    if into is not None and (found := db.schema_version()) < schema.SCHEMA_VERSION:
        # its tables are copied in the current layout, which an older schema's do not fit
        raise InputError(f"{db.name}: schema version {found}; open it writable once to upgrade it first")
    if into is None and db.readonly:
        raise InputError(f"{db.name}: opened read only; it can be rewritten into a new file only")
    before = file.stat().st_size if file is not None else None
    try:
        if into is None:
            _in_place(db)
            after = file.stat().st_size if file is not None else None
            return Compacted(db.name, before, after)
        assert file is not None
        with atomic_path(into, errors=(sqlite3.Error,)) as tmp:
            _copy_into(file, tmp)
        return Compacted(str(into), before, Path(into).stat().st_size)
    except SQLAlchemyError as exc:
        detail = str(getattr(exc, "orig", exc)).splitlines()[0]
        raise DatabaseError(f"{db.name}: not compacted ({detail})") from None


def _copy_into(file: Path, tmp: Path) -> None:
    """The tables copied into a new file ``tmp``, each in key order, through a connection that
    only reads ``file``: a database opened read only refuses writes on its own connections."""
    # URI names, so that the read-only mode of the attached file is understood however SQLite was built
    con = sqlite3.connect(Path(tmp).resolve().as_uri(), uri=True)
    try:
        con.execute("ATTACH DATABASE ? AS source", (f"{file.resolve().as_uri()}?mode=ro",))
        with con:  # one transaction
            for name, sql in con.execute(
                "SELECT name, sql FROM source.sqlite_master WHERE type = 'table' AND name NOT LIKE 'sqlite_%'"
            ).fetchall():
                table = schema.metadata.tables.get(name)
                if table is None:  # not tdb's: as it is
                    con.execute(sql)
                    quoted = '"' + str(name).replace('"', '""') + '"'
                    con.execute(f"INSERT INTO main.{quoted} SELECT * FROM source.{quoted}")
                    continue
                con.execute(_create(table, name))
                con.execute(_ordered_copy(table, into=f'main."{name}"', source=f'source."{name}"'))
            for (sql,) in con.execute(
                "SELECT sql FROM source.sqlite_master WHERE type = 'index' AND sql IS NOT NULL"
            ).fetchall():
                con.execute(sql)
        con.execute("DETACH DATABASE source")
    finally:
        con.close()


def _in_key_order(conn: Connection) -> None:
    """Each table of BLOBs copied afresh in key order and in the current layout, in place of the old."""
    present = set(conn.dialect.get_table_names(conn))
    for table in schema.BLOB_TABLES:
        if table.name not in present:
            continue
        new = f"{table.name}__compact"
        conn.exec_driver_sql(_create(table, new))
        conn.exec_driver_sql(_ordered_copy(table, into=f'"{new}"', source=f'"{table.name}"'))
        conn.exec_driver_sql(f'DROP TABLE "{table.name}"')
        conn.exec_driver_sql(f'ALTER TABLE "{new}" RENAME TO "{table.name}"')


def _create(table: Table, name: str) -> str:
    """The CREATE TABLE statement of ``table`` in tdb's current layout, named ``name``."""
    sql = str(CreateTable(table).compile(dialect=sqlite_dialect())).strip()
    head = f"CREATE TABLE {table.name} "
    assert sql.startswith(head), sql
    return f'CREATE TABLE "{name}" ' + sql[len(head) :]


def _ordered_copy(table: Table, *, into: str, source: str) -> str:
    """The INSERT that copies ``table``'s rows from ``source`` into ``into`` (both quoted names)
    in the order of its key."""
    columns = ", ".join(f'"{c.name}"' for c in table.columns)
    key = ", ".join(f'"{c.name}"' for c in table.primary_key.columns)
    return f"INSERT INTO {into} ({columns}) SELECT {columns} FROM {source} ORDER BY {key}"


def _in_place(db: Database) -> None:
    """The tables of BLOBs in key order (one transaction), then VACUUM, which needs a
    connection outside any transaction."""
    sqlite = db.engine.dialect.name == "sqlite"
    if sqlite:
        with db.transaction() as conn:
            _in_key_order(conn)
    with db.engine.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        if sqlite:
            conn.exec_driver_sql("VACUUM")
            # the rewrite went through the journal: copied into the file, its space given back
            conn.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
            return
        names = set(db.engine.dialect.get_table_names(conn))
        for table in schema.metadata.sorted_tables:
            if table.name in names:
                name = conn.dialect.identifier_preparer.quote(table.name)
                conn.exec_driver_sql(f"VACUUM (FULL, ANALYZE) {name}")


def _file(db: Database) -> Path | None:
    """The SQLite file of ``db`` (None for a server database)."""
    if db.engine.dialect.name != "sqlite" or not db.engine.url.database:
        return None
    name = db.engine.url.database
    # a file opened read only on read-only media is named by its URI (tdb.open)
    return Path(urlsplit(name).path) if name.startswith("file:") else Path(name)
