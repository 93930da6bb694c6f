"""Terrain databases: one file (or PostgreSQL database) per area, several surveys in it.

``tdb.open(path)`` returns a :class:`Database`. All writes go through
:meth:`Database.transaction`; a version is written in one transaction, so a
failure or a kill leaves the earlier versions intact and no partial version.
SQLite files use write-ahead logging, so readers keep working during an ingest.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import re
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sqlalchemy import Connection, Engine, create_engine, event, func, select
from sqlalchemy.exc import ArgumentError, IntegrityError, NoSuchModuleError, OperationalError
from sqlalchemy.exc import DatabaseError as SADatabaseError

from tdb import blocks, point_pages, schema
from tdb.bbox import Box, check_bbox, clip_bbox
from tdb.categories import all_categories
from tdb.errors import DatabaseError, InputError, Remedy, TdbIOError, VersionExistsError, VersionNotFoundError
from tdb.evidence import TileEvidence
from tdb.fetch import fetch_rows
from tdb.object_store import read_buildings, read_trees, rekey_objects
from tdb.objects import Building, Tree
from tdb.progress import Progress, or_silent
from tdb.stats import VersionStats
from tdb.threads import keep_freed_memory
from tdb.version_writer import VersionWriter, write_point_pages, write_tile_pages

SQLITE_MAGIC = b"SQLite format 3\x00"
PROBE_CHUNK = 900


@dataclass(frozen=True)
class Version:
    id: int
    name: str
    acquired: dt.date | None
    source: str | None
    crs: str | None
    params: dict[str, Any]
    stats: VersionStats
    created: str


@dataclass(frozen=True)
class VersionInfo:
    """What is recorded of a survey beside its model: when it was flown, where it came from, its
    CRS (WKT), the settings it was modelled with and what ingest measured of it."""

    acquired: dt.date | None = None
    source: str | None = None
    crs: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    stats: VersionStats | None = None


def is_database(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an SQLite file (tdb's or another)."""
    try:
        with Path(path).open("rb") as fh:
            return fh.read(16) == SQLITE_MAGIC
    except OSError:
        return False


MAX_NAME = 200  # characters of a version's name (the schema's column)


def check_version_name(name: str) -> str:
    """``name`` where it can name a version: some visible text, no control characters (a newline,
    a tab), at most :data:`MAX_NAME` characters; an :class:`InputError` otherwise."""
    if not isinstance(name, str) or not name.strip():
        raise InputError(f"a version needs a name with something in it, got {name!r}")
    if any(unicodedata.category(ch) == "Cc" for ch in name):
        raise InputError(f"a version's name holds no control characters (newlines, tabs), got {name!r}")
    if len(name) > MAX_NAME:
        raise InputError(f"a version's name has at most {MAX_NAME} characters, got {len(name):,}")
    return name


def writable(path: str | os.PathLike[str]) -> bool:
    """Whether a database at ``path`` (a file, or a URL: assumed so) can be written here."""
    text = str(path)
    if "://" in text:
        return True
    p = Path(text).resolve()
    return os.access(p, os.W_OK) and os.access(p.parent, os.W_OK)


def open(path: str | os.PathLike[str], *, create: bool = False, readonly: bool = False) -> Database:
    """Open a terrain database: an SQLite file path or a SQLAlchemy URL (``postgresql://…``).

    Parameters
    ----------
    path : file path or database URL.
    create : make a new database where none exists (otherwise that is an error).
    readonly : open an SQLite file without writing to it, not even its journal mode or an
        upgrade of its schema; on a read-only filesystem (a DVD, a read-only mount) it is read
        as immutable. Writes then fail with a :class:`DatabaseError`.

    Raises
    ------
    TdbIOError
        If the file does not exist and ``create`` is false.
    DatabaseError
        If the file is not a tdb database, is damaged, or has a newer schema.
    """
    text = str(path)
    if "://" in text:
        url = text
    else:
        p = Path(text)
        if not p.exists():
            if not create:
                raise TdbIOError(f"{p}: no such database (use `tdb ingest` to create one)")
            if not p.parent.exists():
                raise TdbIOError(f"{p.parent}: no such directory")
        elif p.stat().st_size > 0 and not is_database(p):
            raise DatabaseError(f"{p}: not a tdb database (not an SQLite file)")
        url = f"sqlite:///{p}"
        if readonly and p.exists() and not writable(p):
            # no -wal or -shm can be made beside a file on read-only media: read it as it stands
            url = f"sqlite:///{p.resolve().as_uri()}?mode=ro&immutable=1&uri=true"
    try:
        engine = create_engine(url)
    except (ArgumentError, NoSuchModuleError) as exc:
        raise DatabaseError(f"{_masked(text)}: not a database URL tdb can open ({_first_line(exc)})") from None
    except ImportError as exc:  # the dialect's driver is not installed
        raise DatabaseError(f"{_masked(text)}: its driver is not installed ({_first_line(exc)})") from None
    if engine.dialect.name == "sqlite":
        # read only, the connection refuses writes and leaves the journal mode as it finds it
        event.listen(engine, "connect", _read_only_pragmas if readonly else _sqlite_pragmas)
    # a URL's password is never shown (messages name the database)
    shown = engine.url.render_as_string(hide_password=True) if "://" in text else text
    event.listen(engine, "handle_error", _damaged(shown))
    db = Database(engine, shown, readonly=readonly)
    db._prepare(create=create)
    # an area read makes and drops arrays of megabytes; without this each is mapped afresh
    keep_freed_memory()
    return db


DAMAGE = ("malformed", "not a database", "database corrupt")  # SQLite's words for a damaged file


NO_RIGHTS = "42501"  # SQLSTATE insufficient_privilege (PostgreSQL)


def _damaged(name: str) -> Any:
    """An engine hook that names a damaged file as such, and missing rights as such, whichever
    query meets them."""

    def hook(context: Any) -> None:
        original = getattr(context, "original_exception", None)
        message = _first_line(original)
        if any(word in message for word in DAMAGE):
            raise DatabaseError(f"{name}: the database file is damaged ({message})") from None
        if getattr(original, "sqlstate", None) == NO_RIGHTS:
            raise DatabaseError(f"{name}: this user lacks the rights ({message})") from None

    return hook


def _masked(url: str) -> str:
    """``url`` with its password (``scheme://user:password@host``) hidden."""
    return re.sub(r"(://[^:/@]*:)[^@]*@", r"\1***@", url)


def _first_line(exc: object) -> str:
    """A driver's message in one line (PostgreSQL's add hints on further lines)."""
    lines = str(exc or "").strip().splitlines()
    return lines[0].strip() if lines else type(exc).__name__


def _read_only_pragmas(dbapi_conn: Any, _record: Any) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA query_only=ON")
    cur.close()


def _sqlite_pragmas(dbapi_conn: Any, _record: Any) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")  # readers are not blocked by an ingest
    # Foreign keys stay unenforced: every row is written with the version id created in
    # the same transaction, and deletes remove child rows explicitly; the check costs ~15 %.
    cur.execute("PRAGMA synchronous=NORMAL")
    cur.execute("PRAGMA cache_size=-262144")  # 256 MiB of pages: index upkeep during big inserts
    cur.execute(f"PRAGMA journal_size_limit={64 * 2**20}")  # a reset WAL gives its space back
    cur.close()


class Database:
    """A terrain database. Use :func:`tdb.open` to get one."""

    def __init__(self, engine: Engine, name: str, *, readonly: bool = False):
        self.engine = engine
        self.name = name
        self.readonly = readonly
        self._tables = set(schema.metadata.tables)  # what this file holds (an older one, read only, less)
        self._keyed_objects = True  # trees and buildings keyed by block first (schema 5 on)

    def __repr__(self) -> str:
        return f"<tdb.Database {self.name!r}>"

    @property
    def location(self) -> str | None:
        """The URL by which another process opens this database (with its password), or None
        where none can (an SQLite database in memory)."""
        url = self.engine.url
        if url.get_backend_name() == "sqlite" and url.database in (None, "", ":memory:"):
            return None
        return url.render_as_string(hide_password=False)

    def __enter__(self) -> Database:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.engine.dispose()

    @contextmanager
    def transaction(self) -> Iterator[Connection]:
        """The one way to write: everything inside commits together or not at all."""
        try:
            with self.engine.begin() as conn:
                yield conn
        except IntegrityError as exc:
            raise DatabaseError(f"{self.name}: constraint violated ({exc.orig})") from None
        except (OperationalError, SADatabaseError) as exc:
            raise DatabaseError(f"{self.name}: {_first_line(exc.orig)}") from None
        except self.engine.dialect.dbapi.Error as exc:  # type: ignore[union-attr]  # raw executemany
            raise DatabaseError(f"{self.name}: {_first_line(exc)}") from None

    def _prepare(self, *, create: bool) -> None:
        try:
            with self.engine.connect() as conn:
                names = set(self.engine.dialect.get_table_names(conn))
        except SADatabaseError as exc:
            raise DatabaseError(f"{self.name}: not a readable database ({_first_line(exc.orig)})") from None
        if not names:
            if not create:
                raise DatabaseError(f"{self.name}: empty database, not a tdb database")
            self._create_schema()
            return
        if "meta" not in names or "versions" not in names:
            raise DatabaseError(f"{self.name}: not a tdb database (tables: {', '.join(sorted(names))})")
        found = self.schema_version()
        if found > schema.SCHEMA_VERSION:
            raise DatabaseError(
                f"{self.name}: schema version {found} is newer than this tdb ({schema.SCHEMA_VERSION})"
            )
        if found < 2 and self.readonly:
            raise DatabaseError(f"{self.name}: schema version {found}; open it once writable to upgrade it")
        if found < schema.SCHEMA_VERSION:
            if self.readonly:  # the tables it lacks read as empty, its objects by their old key
                self._tables = names
                self._keyed_objects = found >= 5
            else:
                self._upgrade(found)
        if not self.readonly:
            self._check_rights()

    def _check_rights(self) -> None:
        """On a server, that this user may write versions: said at open, not after an hour's ingest."""
        if self.engine.dialect.name != "postgresql":
            return
        with self.engine.connect() as conn:
            may = conn.exec_driver_sql("SELECT has_table_privilege('versions', 'INSERT')").scalar()
        if not may:
            raise DatabaseError(f"{self.name}: this user lacks the rights to write (no INSERT on its tables)")

    def _upgrade(self, found: int) -> None:
        """Add the tables a newer schema has: from 1, the block tables, filled from the rows of every
        version; from 2, the evidence table (versions stored before it have no evidence); from 3, the
        trees and buildings tables (empty for the versions before); from 4, the objects keyed by their
        block first."""
        with self.transaction() as conn:
            if found == 4:
                rekey_objects(conn)
            schema.metadata.create_all(conn, checkfirst=True)
            _compress_blobs(conn)
            old = conn.execute(select(schema.versions.c.id)).scalars().all() if found < 2 else []
            for vid in old:
                for level, table in schema.level_tables.items():
                    q = select(table.c.xg, table.c.yg, table.c.c).where(table.c.version == vid)
                    xg, yg, code = _columns(list(conn.execute(q)), (np.int64, np.int64, np.uint8))
                    write_tile_pages(conn, vid, level, xg, yg, code)
                t = schema.points
                q = select(t.c.x, t.c.y, t.c.z, t.c.n).where(t.c.version == vid)
                write_point_pages(conn, vid, *_columns(list(conn.execute(q)), (float, float, float, np.uint8)))
            conn.execute(
                schema.meta.update()
                .where(schema.meta.c.key == "schema_version")
                .values(value=str(schema.SCHEMA_VERSION))
            )

    def _create_schema(self) -> None:
        with self.transaction() as conn:
            schema.metadata.create_all(conn)
            _compress_blobs(conn)
            conn.execute(schema.meta.insert(), [{"key": "schema_version", "value": str(schema.SCHEMA_VERSION)}])
            conn.execute(
                schema.categories.insert(),
                [
                    {
                        "code": c.code,
                        "inclination": c.inclination,
                        "feature": c.feature,
                        "orient_from": None if c.orientation is None else c.orientation[0],
                        "orient_to": None if c.orientation is None else c.orientation[1],
                        "flat_side": c.flat_side,
                        "description": c.description,
                    }
                    for c in all_categories()
                ],
            )

    def schema_version(self) -> int:
        with self.engine.connect() as conn:
            value = conn.execute(select(schema.meta.c.value).where(schema.meta.c.key == "schema_version")).scalar()
        if value is None:
            raise DatabaseError(f"{self.name}: no schema version recorded")
        return int(value)

    # -- versions -------------------------------------------------------------------------------

    def versions(self) -> list[Version]:
        with self.engine.connect() as conn:
            rows = conn.execute(select(schema.versions).order_by(schema.versions.c.id)).mappings().all()
        return [
            Version(
                r["id"],
                r["name"],
                r["acquired"],
                r["source"],
                r["crs"],
                json.loads(r["params"]),
                VersionStats.from_json(json.loads(r["stats"])),
                r["created"],
            )
            for r in rows
        ]

    def version(self, name: str) -> Version:
        for v in self.versions():
            if v.name == name:
                return v
        known = ", ".join(v.name for v in self.versions()) or "none"
        raise VersionNotFoundError(f"{self.name}: no version {name!r} (versions: {known})")

    def write_version(  # noqa: PLR0913 (each part of a version, and how it is written)
        self,
        name: str,
        *,
        levels: dict[int, tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]],
        points: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]],
        info: VersionInfo | None = None,
        evidence: TileEvidence | None = None,
        objects: tuple[list[Tree], list[Building]] | None = None,
        replace: bool = False,
        progress: Progress | None = None,
    ) -> Version:
        """Store one survey: tiles per level (xg, yg, code) and points (x, y, z, n), in one transaction.

        ``info``: what is recorded of the survey beside its model (:class:`VersionInfo`);
        ``evidence``: the ground evidence of its 2 m tiles (:mod:`tdb.evidence`); ``objects``: its
        trees and buildings (:mod:`tdb.objects`);
        ``progress`` is told ``("database", rows written, rows)`` (:mod:`tdb.progress`).

        Raises
        ------
        VersionExistsError
            If ``name`` exists and ``replace`` is false.
        """
        meta = info or VersionInfo()
        rows = sum(len(t[0]) for t in levels.values()) + len(points[0])
        with self.writing(name, info=meta, replace=replace, progress=progress, rows=rows) as writer:
            writer.add(levels=levels, points=points, evidence=evidence, objects=objects)
            writer.describe(params=meta.params, stats=meta.stats.to_json() if meta.stats else {})
        return self.version(name)

    @contextmanager
    def writing(
        self,
        name: str,
        *,
        info: VersionInfo | None = None,
        replace: bool = False,
        progress: Progress | None = None,
        rows: int | None = None,
    ) -> Iterator[VersionWriter]:
        """A version written in parts (:class:`~tdb.version_writer.VersionWriter`), all in one
        transaction: its ``info`` first (params and stats are set by the writer's ``describe``
        once the parts are in), then each part; nothing is stored unless the block ends well.

        Raises
        ------
        VersionExistsError
            If ``name`` exists and ``replace`` is false.
        """
        check_version_name(name)
        meta = info or VersionInfo()
        with self.transaction() as conn:
            old = conn.execute(select(schema.versions.c.id).where(schema.versions.c.name == name)).scalar()
            if old is not None:
                if not replace:
                    raise VersionExistsError(f"{self.name}: version {name!r} exists", remedy=Remedy.REPLACE)
                self._delete(conn, old)
            try:
                inserted = conn.execute(
                    schema.versions.insert().values(
                        name=name,
                        acquired=meta.acquired,
                        source=meta.source,
                        crs=meta.crs,
                        params="{}",
                        stats="{}",
                        created=dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
                    )
                ).inserted_primary_key
            except IntegrityError:  # another ingest of the same name committed first
                raise VersionExistsError(f"{self.name}: version {name!r} exists", remedy=Remedy.REPLACE) from None
            assert inserted is not None
            writer = VersionWriter(conn, inserted[0], progress=or_silent(progress), rows=rows)
            yield writer
            writer.check_described()
        self._release_journal()

    def _release_journal(self) -> None:
        """Copy a big write's journal into the file and give its disk space back: SQLite's WAL
        grows to the size of the transaction (a version) and would otherwise stay that size, and
        every later read would look through it."""
        if self.engine.dialect.name == "sqlite":
            with self.engine.connect() as conn:
                conn.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")

    def rename_version(self, name: str, new: str) -> Version:
        """Give version ``name`` the name ``new``, in one transaction.

        Raises
        ------
        VersionExistsError
            If a version is named ``new`` already.
        """
        check_version_name(new)
        vid = self.version(name).id
        if any(v.name == new for v in self.versions()):
            raise VersionExistsError(f"{self.name}: version {new!r} exists")
        with self.transaction() as conn:
            conn.execute(schema.versions.update().where(schema.versions.c.id == vid).values(name=new))
        return self.version(new)

    def check(self) -> DatabaseCheck:
        """Whether the file is whole (SQLite's integrity check) and every version holds the rows
        its figures say: tiles per level, kept points. Reads only."""
        integrity = "not checked (a server database)"
        free = None
        old_layout: list[str] = []
        if self.engine.dialect.name == "sqlite":
            try:
                with self.engine.connect() as conn:
                    found = [str(r[0]) for r in conn.exec_driver_sql("PRAGMA integrity_check").fetchall()]
            except SADatabaseError as exc:
                found = [str(exc.orig)]
            integrity = "ok" if found == ["ok"] else "damaged: " + "; ".join(found[:3])
            free = self._free_share()
            old_layout = self._old_layout()
        checks = []
        try:
            for v in self.versions():
                tiles = {lv: self.count(v.name, table=t.name) for lv, t in schema.level_tables.items()}
                points = self.count(v.name)
                want = v.stats.reduction
                ok = points == want.kept_points and all(tiles[lv] == n for lv, n in want.tiles.items())
                checks.append(VersionCheck(v.name, points, tiles, ok))
        except (SADatabaseError, DatabaseError) as exc:
            integrity = f"damaged: {getattr(exc, 'orig', exc)}"
        return DatabaseCheck(integrity, self.schema_version(), checks, free, old_layout)

    def _old_layout(self) -> list[str]:
        """The tables of BLOBs of an SQLite file made before they were rowid tables
        (:data:`tdb.schema.BLOB_TABLES`), whose area reads fetch about three times the bytes."""
        names = [t.name for t in schema.BLOB_TABLES]
        try:
            with self.engine.connect() as conn:
                marks = ", ".join("?" * len(names))
                rows = conn.exec_driver_sql(
                    f"SELECT name, sql FROM sqlite_master WHERE type = 'table' AND name IN ({marks})", tuple(names)
                ).fetchall()
        except SADatabaseError:
            return []
        return sorted(str(name) for name, sql in rows if "WITHOUT ROWID" in str(sql).upper())

    def _free_share(self) -> float | None:
        """The share of an SQLite file's pages that are free (None where unreadable)."""
        try:
            with self.engine.connect() as conn:
                free = conn.exec_driver_sql("PRAGMA freelist_count").scalar() or 0
                pages = conn.exec_driver_sql("PRAGMA page_count").scalar() or 0
        except SADatabaseError:
            return None
        return float(free) / float(pages) if pages else 0.0

    def delete_version(self, name: str) -> None:
        vid = self.version(name).id
        with self.transaction() as conn:
            self._delete(conn, vid)
        self._release_journal()

    def _delete(self, conn: Connection, vid: int) -> None:
        tables = (*schema.level_tables.values(), schema.points, schema.tile_blocks, schema.point_blocks)
        for table in (*tables, schema.evidence_blocks, schema.trees, schema.buildings):
            conn.execute(table.delete().where(table.c.version == vid))
        c = schema.coregistrations.c
        conn.execute(schema.coregistrations.delete().where((c.before == vid) | (c.after == vid)))
        conn.execute(schema.versions.delete().where(schema.versions.c.id == vid))

    # -- reading ----------------------------------------------------------------------------------

    def tiles(
        self,
        version: str,
        *,
        level: int = 2,
        bbox: tuple[float, float, float, float] | None = None,
        categories: list[int] | None = None,
        ordered: bool = True,
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]:
        """(xg, yg, code) of the tiles of ``version`` at ``level`` overlapping ``bbox``, optionally only
        those whose code is in ``categories`` (bound parameters: user text never becomes SQL).
        Ordered by (xg, yg) unless ``ordered`` is false and ``categories`` is None (then block by block)."""
        vid = self.version(version).id
        if categories is None:
            # all categories: the block pages are read far faster than the rows
            xg, yg, code = self._block_tiles(vid, _level(level), bbox)
            if not ordered:
                return xg, yg, code
            order = np.lexsort((yg, xg))
            return xg[order], yg[order], code[order]
        table = schema.level_tables[_level(level)]
        q = select(table.c.xg, table.c.yg, table.c.c).where(
            table.c.version == vid, table.c.c.in_([int(c) for c in categories])
        )
        if bbox is None:
            return _columns(self._fetch(q.order_by(table.c.xg, table.c.yg)), (np.int64, np.int64, np.uint8))
        x0, y0, x1, y1 = bbox
        # Tile keys lie on a lattice: probing the (version, xg, yg) index once per column
        # of tiles reads only the area, where a range on xg alone would read a whole strip.
        xs = np.arange(np.floor(x0 / level) * level, x1, level).astype(np.int64)
        xs = xs[xs + level > x0]
        q = q.where(table.c.yg > int(np.floor(y0)) - level, table.c.yg < y1)
        return _columns(self._probe(q, table.c.xg, xs.tolist()), (np.int64, np.int64, np.uint8))

    def points(
        self,
        version: str,
        *,
        level: int = 2,
        bbox: tuple[float, float, float, float] | None = None,
        ordered: bool = True,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]:
        """(x, y, z, n) of the kept points of ``version`` belonging to ``level`` inside ``bbox``,
        ordered by (x, y) unless ``ordered`` is false (then block by block: sorting a square
        kilometre's points costs more than reading them). Read from the block pages, which hold
        the ``tdb`` rows' points to within 31 µm (:mod:`tdb.point_pages`)."""
        x, y, z, n = self._block_points(self.version(version).id, _level(level), bbox)
        if not ordered:
            return x, y, z, n
        order = np.lexsort((y, x))
        return x[order], y[order], z[order], n[order]

    def _fetch(self, q: Any) -> list[tuple[Any, ...]]:
        with self.engine.connect() as conn:
            return fetch_rows(conn, q)

    def _probe(self, q: Any, column: Any, values: list[Any]) -> list[Any]:
        """Rows of ``q`` with ``column`` IN values, in chunks that respect bound-parameter limits."""
        rows: list[Any] = []
        with self.engine.connect() as conn:
            for start in range(0, len(values), PROBE_CHUNK):
                rows.extend(conn.execute(q.where(column.in_(values[start : start + PROBE_CHUNK]))))
        return rows

    def count(self, version: str, *, table: str = "tdb") -> int:
        vid = self.version(version).id
        t = schema.metadata.tables[table]
        with self.engine.connect() as conn:
            return int(conn.execute(select(func.count()).select_from(t).where(t.c.version == vid)).scalar() or 0)

    def object_counts(self, version: str) -> tuple[int, int]:
        """How many trees and buildings ``version`` holds (none for a version stored before they were kept)."""
        return tuple(  # type: ignore[return-value]
            self.count(version, table=t.name) if t.name in self._tables else 0
            for t in (schema.trees, schema.buildings)
        )

    def aoi(self, bbox: tuple[float, float, float, float], *, level: int = 2, version: str | None = None) -> Area:
        """The tiles' categories and the points of an area of interest (the paper's AOI access).

        Read from the block pages (:mod:`tdb.blocks`); tiles and points come block by block,
        not sorted (sorting a square kilometre's 250 000 rows would take longer than reading them).
        """
        name = version or self._only_version()
        v = self.version(name)
        vid = v.id
        level = _level(level)
        # Only what the version covers: an absurd box must not become an absurd raster later.
        bbox = clip_bbox(bbox, _widened(v.stats.bounds, level), what=f"version {name!r}")
        xg, yg, code = self._block_tiles(vid, level, bbox)
        x, y, z, n = self._block_points(vid, level, bbox)
        trees, buildings = self._trees(vid, bbox), self._buildings(vid, bbox)
        return Area(name, level, bbox, xg, yg, code, x, y, z, n, trees, buildings)

    def tile_blocks(
        self, version: str, *, level: int = 2, bbox: tuple[float, float, float, float] | None = None
    ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """(bx, by) of the blocks of :data:`tdb.blocks.TILES_PER_BLOCK`² tiles of ``level`` that
        ``version`` holds tiles in, meeting ``bbox``: where it has data, read without its tiles."""
        tb = schema.tile_blocks
        vid = self.version(version).id
        q = select(tb.c.bx, tb.c.by).where(tb.c.version == vid, tb.c.level == _level(level))
        rows = self._fetch(_in_blocks(q, tb, bbox, blocks.TILES_PER_BLOCK * level))
        bx, by = _columns(rows, (np.int64, np.int64))
        return bx, by

    def _block_tiles(
        self, vid: int, level: int, bbox: tuple[float, float, float, float] | None
    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]:
        tb = schema.tile_blocks
        q = select(tb.c.bx, tb.c.by, tb.c.codes).where(tb.c.version == vid, tb.c.level == level)
        q = _in_blocks(q, tb, bbox, blocks.TILES_PER_BLOCK * level)
        rows = self._fetch(q)
        inf = float("inf")
        return blocks.tiles_from_blocks(rows, bbox or (-inf, -inf, inf, inf), level=level)

    def _block_points(
        self, vid: int, level: int, bbox: tuple[float, float, float, float] | None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]:
        pb = schema.point_blocks
        q = select(pb.c.bx, pb.c.by, pb.c.data).where(pb.c.version == vid)
        q = _in_blocks(q, pb, bbox, point_pages.POINT_BLOCK)
        inf = float("inf")
        mask = 1 << schema_levels().index(level)
        rows = self._fetch(q)
        return point_pages.points_from_blocks(rows, bbox or (-inf, -inf, inf, inf), mask=mask)

    def evidence(self, version: str, *, bbox: tuple[float, float, float, float] | None = None) -> TileEvidence:
        """The ground evidence of the 2 m tiles of ``version`` overlapping ``bbox``
        (:mod:`tdb.evidence`); empty for a version stored before evidence was kept."""
        eb = schema.evidence_blocks
        vid = self.version(version).id
        if eb.name not in self._tables:
            return TileEvidence.empty()
        q = _in_blocks(
            select(eb.c.bx, eb.c.by, eb.c.data).where(eb.c.version == vid), eb, bbox, blocks.TILES_PER_BLOCK * 2
        )
        inf = float("inf")
        rows = self._fetch(q)
        xg, yg, fields = blocks.evidence_from_blocks(
            rows, bbox or (-inf, -inf, inf, inf), fields=len(TileEvidence.FIELDS)
        )
        return TileEvidence(xg, yg, *fields)

    def trees(self, version: str, *, bbox: tuple[float, float, float, float] | None = None) -> list[Tree]:
        """The trees of ``version`` whose crown meets ``bbox`` (all where None), tallest first;
        none for a version stored before trees were kept."""
        return self._trees(self.version(version).id, bbox)

    def _trees(self, vid: int, bbox: tuple[float, float, float, float] | None) -> list[Tree]:
        if schema.trees.name not in self._tables:
            return []
        with self.engine.connect() as conn:
            return read_trees(conn, vid, bbox, keyed=self._keyed_objects)

    def buildings(self, version: str, *, bbox: tuple[float, float, float, float] | None = None) -> list[Building]:
        """The buildings of ``version`` whose footprint meets ``bbox`` (all where None), largest first."""
        return self._buildings(self.version(version).id, bbox)

    def _buildings(self, vid: int, bbox: tuple[float, float, float, float] | None) -> list[Building]:
        if schema.buildings.name not in self._tables:
            return []
        with self.engine.connect() as conn:
            return read_buildings(conn, vid, bbox, keyed=self._keyed_objects)

    def coregistration(self, before: str, after: str, setting: str) -> dict[str, Any] | None:
        """The shift stored for ``after`` against ``before`` found with ``setting`` (a text that
        names how it was found), as its JSON object; None where none is stored."""
        c = schema.coregistrations.c
        a, b = self.version(before).id, self.version(after).id
        if schema.coregistrations.name not in self._tables:
            return None
        q = select(c.shift).where(c.before == a, c.after == b, c.setting == setting)
        rows = self._fetch(q)
        return json.loads(rows[0][0]) if rows else None

    def store_coregistration(self, before: str, after: str, setting: str, shift: dict[str, Any]) -> None:
        """Keep a shift (its JSON object) for later queries, in place of one found the same way."""
        a, b = self.version(before).id, self.version(after).id
        c = schema.coregistrations.c
        with self.transaction() as conn:
            conn.execute(schema.coregistrations.delete().where(c.before == a, c.after == b, c.setting == setting))
            conn.execute(
                schema.coregistrations.insert().values(before=a, after=b, setting=setting, shift=json.dumps(shift))
            )

    def crs(self, version: str) -> Any:
        """The :class:`pyproj.CRS` a version was stored in (None where unknown)."""
        wkt = self.version(version).crs
        if not wkt:
            return None
        import pyproj

        return pyproj.CRS.from_wkt(wkt)

    def _only_version(self) -> str:
        vs = self.versions()
        if len(vs) != 1:
            raise DatabaseError(f"{self.name}: {len(vs)} versions; name one ({', '.join(v.name for v in vs)})")
        return vs[0].name


@dataclass(frozen=True)
class VersionCheck:
    """One version's rows as counted, and whether they are those its figures record."""

    name: str
    points: int
    tiles: dict[int, int]
    ok: bool


@dataclass(frozen=True)
class DatabaseCheck:
    """What :meth:`Database.check` found."""

    integrity: str
    schema_version: int
    versions: list[VersionCheck]
    free_share: float | None = None  # of an SQLite file's pages, those free (a deleted version's)
    old_layout: list[str] = field(default_factory=list)  # tables of BLOBs laid out as before (tdb.compact)

    @property
    def ok(self) -> bool:
        return self.integrity in ("ok", "not checked (a server database)") and all(v.ok for v in self.versions)


@dataclass(frozen=True)
class Area:
    """What :meth:`Database.aoi` returns: tiles (xg, yg, code), points (x, y, z, n), and the
    trees and buildings that reach into the area."""

    version: str
    level: int
    bbox: tuple[float, float, float, float]
    xg: NDArray[np.int64]
    yg: NDArray[np.int64]
    code: NDArray[np.uint8]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    z: NDArray[np.float64]
    n: NDArray[np.uint8]
    trees: list[Tree] = field(default_factory=list)
    buildings: list[Building] = field(default_factory=list)


def _widened(bounds: Box | None, by: float) -> Box | None:
    """A version's bounds out to the tiles that hold its edge points."""
    if bounds is None:
        return None
    return (bounds[0] - by, bounds[1] - by, bounds[2] + by, bounds[3] + by)


def _in_blocks(q: Any, table: Any, bbox: tuple[float, float, float, float] | None, side: float) -> Any:
    """``q`` restricted to the rows of ``table`` whose block (of ``side`` m) meets ``bbox``."""
    if bbox is None:
        return q
    return q.where(schema.in_blocks(table, check_bbox(bbox), side))


def _compress_blobs(conn: Connection) -> None:
    """On PostgreSQL, the BLOB columns compressed with LZ4 (:func:`tdb.schema.blob_compression`)
    where the server can; a server before 14, or built without LZ4, keeps its default."""
    if conn.dialect.name != "postgresql":
        return
    try:
        with conn.begin_nested():
            for statement in schema.blob_compression():
                conn.exec_driver_sql(statement)
    except (SADatabaseError, DatabaseError):  # no LZ4, or not the tables' owner (the hook's error)
        pass  # only slower reads: the values are the same


def _columns(rows: list[Any], dtypes: tuple[Any, ...]) -> Any:
    if not rows:
        return tuple(np.empty(0, d) for d in dtypes)
    cols = list(zip(*rows))
    return tuple(np.asarray(c, dtype=d) for c, d in zip(cols, dtypes))


def schema_levels() -> list[int]:
    return list(schema.LEVEL_TABLES)


def _level(level: int) -> int:
    if level not in schema.LEVEL_TABLES:
        raise DatabaseError(f"level must be one of {', '.join(map(str, schema.LEVEL_TABLES))} m, got {level}")
    return level
