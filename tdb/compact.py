"""A database rewritten compact: each table's pages in key order, no space left by deleted versions.

SQLite puts a new page wherever its file has one free. An ingest writes tiles, points, pages
and objects block by block, so the tables interleave through the file, and a deleted version
leaves its pages free inside it (the file never shrinks by itself). Where the file is larger than
the system's cache, an area read then seeks once per page it needs. Rewritten, each table and
index lies in key order, so that an area's rows come in a few runs of the file. PostgreSQL
rewrites tdb's tables in full and refreshes the planner's statistics.
"""

from __future__ import annotations

import os
import sqlite3
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import urlsplit

from sqlalchemy.exc import SQLAlchemyError

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

    In place, SQLite needs free disk for about twice the file while it works (a copy, and the
    journal that makes the rewrite all or nothing); into a new file, for one copy. An
    interruption leaves ``db`` as it was, and no part of ``into``.

    Raises
    ------
    InputError
        If ``into`` is given for a server database, or ``db`` is open read only and no ``into``
        is given.
    TdbIOError
        If ``into`` cannot be written (among others: it is a terrain database already).
    DatabaseError
        If the database refuses the rewrite (a full disk, missing rights).
    """
    file = _file(db)
    if into is not None and file is None:
        raise InputError(f"{db.name}: a server database is rewritten in place, not into a file")
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
    """VACUUM INTO through a connection of its own that only reads: a database opened read only
    refuses it on its own connections, which refuse every write."""
    con = sqlite3.connect(f"{file.resolve().as_uri()}?mode=ro", uri=True)
    try:
        con.execute("VACUUM INTO ?", (str(tmp),))
    finally:
        con.close()


def _in_place(db: Database) -> None:
    """VACUUM needs a connection outside any transaction."""
    with db.engine.connect().execution_options(isolation_level="AUTOCOMMIT") as conn:
        if db.engine.dialect.name == "sqlite":
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
