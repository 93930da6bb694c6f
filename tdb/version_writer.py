"""One version written in parts, inside one transaction.

A survey ingested whole is one part; one ingested block by block is written block after block,
so that the writer holds one block at a time whatever the survey's size. The parts are disjoint:
every tile and every kept point belongs to one of them. A block page (:mod:`tdb.blocks`) wider
than a part (the 16 m level's pages are 2048 m wide) is merged with what earlier parts wrote of it.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Callable, Iterator
from itertools import chain
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sqlalchemy import BigInteger, Connection, Float, Integer, SmallInteger, bindparam, literal_column, select

from tdb import blocks, point_pages, schema
from tdb.errors import DatabaseError
from tdb.evidence import TileEvidence
from tdb.object_store import write_objects
from tdb.objects import Building, Tree
from tdb.progress import Progress

BATCH = 50_000
ROWS_PER_STATEMENT = 200
MAX_PARAMETERS = 999  # SQLite's limit before 3.32

Levels = dict[int, tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.uint8]]]
Points = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.uint8]]


class VersionWriter:
    """The parts of version ``vid``, written on ``conn`` (the caller's transaction).

    ``progress`` is told ``("database", rows written, rows)``; ``rows`` is what the caller
    expects (None where it does not know: the count so far is told then).
    """

    def __init__(self, conn: Connection, vid: int, *, progress: Progress, rows: int | None = None) -> None:
        self.conn, self.vid = conn, vid
        self.progress, self.rows, self.done = progress, rows, 0
        self.described = False
        progress("database", 0, rows or 0)

    def add(
        self,
        *,
        levels: Levels,
        points: Points,
        evidence: TileEvidence | None = None,
        objects: tuple[list[Tree], list[Building]] | None = None,
    ) -> None:
        """Write one part: tiles per level (xg, yg, code), kept points (x, y, z, n), the ground
        evidence of its 2 m tiles, its trees and buildings."""
        for level, (xg, yg, code) in levels.items():
            order = np.lexsort((yg, xg))  # key order: B-tree pages fill in sequence
            xg, yg, code = xg[order], yg[order], code[order]
            self._bulk(schema.level_tables[level], {"xg": xg, "yg": yg, "c": code})
            write_tile_pages(self.conn, self.vid, level, xg, yg, code)
        write_point_pages(self.conn, self.vid, *points)
        if evidence is not None and len(evidence):
            layers = [getattr(evidence, f) for f in evidence.FIELDS]
            pages = blocks.evidence_blocks(evidence.xg, evidence.yg, layers)
            fields = len(TileEvidence.FIELDS)
            _merge_pages(
                self.conn,
                schema.evidence_blocks,
                pages,
                {"version": self.vid},
                merge=lambda _, old, new: blocks.merge_evidence_pages(old, new, fields=fields),
            )
        if objects is not None:
            write_objects(self.conn, self.vid, *objects)
        x, y, z, n = points
        order = np.lexsort((y, x))
        self._bulk(schema.points, {"x": x[order], "y": y[order], "z": z[order], "n": n[order]})

    def describe(self, *, params: dict[str, Any], stats: dict[str, Any]) -> None:
        """Record the version's settings and figures, known once every part is written."""
        self.conn.execute(
            schema.versions.update()
            .where(schema.versions.c.id == self.vid)
            .values(params=json.dumps(params), stats=json.dumps(stats, default=float))
        )
        self.described = True

    def check_described(self) -> None:
        if not self.described:
            raise DatabaseError("a version was written without its figures; nothing was stored")

    def _bulk(self, table: Any, columns: dict[str, NDArray[Any]]) -> None:
        """Batch insert of one part's rows: the statement SQLAlchemy compiles for this dialect,
        with the version as a literal, run by the DB-API's executemany batch by batch (Python
        objects for 25 M rows at once would take gigabytes; one parameter fewer per row saves a
        tenth).

        With positional parameters (SQLite) each statement carries many rows: SQLite spends half
        its time per statement run rather than per row, so this doubles the rows written per second.
        PostgreSQL takes them by COPY in its binary format, built by numpy (:func:`copy_rows`)."""
        conn = self.conn
        if conn.dialect.name == "postgresql":
            self._copy(table, columns)
            return
        version: Any = literal_column(str(int(self.vid)))
        values: dict[str, Any] = {"version": version, **{k: bindparam(k) for k in columns}}
        # inline(): no RETURNING of the literal primary key column
        stmt = table.insert().inline().values(values).compile(dialect=conn.dialect)
        names = list(stmt.positiontup) if stmt.positional and stmt.positiontup else list(columns)
        total = len(next(iter(columns.values()))) if columns else 0
        cursor = conn.connection.cursor()
        try:
            for start in range(0, total, BATCH):
                cols = [columns[k][start : start + BATCH].tolist() for k in names]
                if stmt.positional:
                    _execute_rows(cursor, str(stmt), cols)
                else:
                    cursor.executemany(str(stmt), [dict(zip(names, r)) for r in zip(*cols)])
                self._advance(len(cols[0]))
        finally:
            cursor.close()

    def _advance(self, rows: int) -> None:
        self.done += rows
        self.progress("database", self.done, max(self.rows or 0, self.done))

    def _copy(self, table: Any, columns: dict[str, NDArray[Any]]) -> None:
        total = len(next(iter(columns.values()))) if columns else 0
        cursor = self.conn.connection.cursor()
        try:
            columns = {"version": np.full(total, self.vid), **columns}
            for written in copy_rows(cursor, table, columns, quote=self.conn.dialect.identifier_preparer):
                self._advance(written)
        finally:
            cursor.close()


# PostgreSQL's binary COPY: a signature, flags and an empty extension; each row its field count,
# then each field's length and value, big-endian; -1 as the last row's count
COPY_HEADER = b"PGCOPY\n\xff\r\n\x00" + struct.pack(">ii", 0, 0)
COPY_TRAILER = struct.pack(">h", -1)
_WIRE = ((SmallInteger, ">i2"), (BigInteger, ">i8"), (Integer, ">i4"), (Float, ">f8"))


def _wire_type(column: Any) -> str:
    """The big-endian numpy type PostgreSQL sends ``column``'s values in (a float is double precision)."""
    for kind, dtype in _WIRE:  # SmallInteger and BigInteger are Integers: the narrower first
        if isinstance(column.type, kind):
            return dtype
    raise TypeError(f"no binary COPY for column {column.name} of type {column.type}")


def copy_rows(cursor: Any, table: Any, columns: dict[str, NDArray[Any]], *, quote: Any) -> Iterator[int]:
    """COPY the rows given column-wise into ``table`` on a psycopg ``cursor``, in PostgreSQL's binary
    format, its names quoted by the dialect's identifier preparer ``quote``; yields the rows sent
    after each batch of :data:`BATCH`."""
    names = list(columns)
    fields = [("count", ">i2")]
    for name in names:
        fields += [(f"{name}_size", ">i4"), (name, _wire_type(table.c[name]))]
    row = np.dtype(fields)
    total = len(columns[names[0]]) if names else 0
    quoted = ", ".join(quote.quote(n) for n in names)
    with cursor.copy(f"COPY {quote.format_table(table)} ({quoted}) FROM STDIN (FORMAT BINARY)") as copy:
        copy.write(COPY_HEADER)
        for start in range(0, total, BATCH):
            end = min(start + BATCH, total)
            out = np.empty(end - start, row)
            out["count"] = len(names)
            for name in names:
                out[f"{name}_size"] = row[name].itemsize
                out[name] = columns[name][start:end]
            copy.write(out.tobytes())
            yield end - start
        copy.write(COPY_TRAILER)


def write_tile_pages(conn: Connection, vid: int, level: int, xg: Any, yg: Any, code: Any) -> None:
    """The code pages of one part's tiles of ``level``, merged into those already written."""
    _merge_pages(
        conn,
        schema.tile_blocks,
        blocks.tile_blocks(xg, yg, code, level=level),
        {"version": vid, "level": level},
        merge=lambda _, old, new: blocks.merge_tile_pages(old, new),
        blob="codes",
    )


def write_point_pages(conn: Connection, vid: int, x: Any, y: Any, z: Any, n: Any) -> None:
    """The point pages of one part's kept points, merged into those already written."""
    _merge_pages(
        conn,
        schema.point_blocks,
        point_pages.point_blocks(x, y, z, n),
        {"version": vid},
        merge=point_pages.merge_point_pages,
    )


def _merge_pages(
    conn: Connection,
    table: Any,
    pages: Iterator[tuple[int, int, bytes]],
    key: dict[str, int],
    *,
    merge: Callable[[tuple[int, int], bytes, bytes], bytes],
    blob: str = "data",
) -> None:
    """Insert block pages (bx, by, blob) with the columns ``key`` into ``table``; a page an
    earlier part wrote is read (one query for the part's range) and merged with the new one by
    ``merge(block, old, new)``."""
    new = list(pages)
    if not new:
        return
    bxs, bys = [p[0] for p in new], [p[1] for p in new]
    q = select(table.c.bx, table.c.by, table.c[blob]).where(
        *(table.c[k] == v for k, v in key.items()),
        table.c.bx.between(min(bxs), max(bxs)),
        table.c.by.between(min(bys), max(bys)),
    )
    old = {(int(r[0]), int(r[1])): bytes(r[2]) for r in conn.execute(q)}
    fresh = [{**key, "bx": bx, "by": by, blob: data} for bx, by, data in new if (bx, by) not in old]
    if fresh:
        conn.execute(table.insert(), fresh)
    cond = [table.c[k] == v for k, v in key.items()]
    for bx, by, data in new:
        if (bx, by) in old:
            conn.execute(
                table.update()
                .where(*cond, table.c.bx == bx, table.c.by == by)
                .values({blob: merge((bx, by), old[(bx, by)], data)})
            )


def _execute_rows(cursor: Any, sql: str, cols: list[list[Any]]) -> None:
    """Insert the rows given column-wise with one statement per ``ROWS_PER_STATEMENT`` rows.

    ``sql`` is a compiled single-row INSERT with positional parameters; its VALUES tuple is
    repeated, so the statement stays SQLAlchemy's (no user text reaches it)."""
    head, _, row = sql.rpartition(" VALUES ")
    width = len(cols)
    per = max(1, min(ROWS_PER_STATEMENT, MAX_PARAMETERS // max(width, 1)))
    flat = list(chain.from_iterable(zip(*cols)))
    count = len(flat) // width if width else 0
    whole = count - count % per
    if whole:
        step = per * width
        cursor.executemany(
            f"{head} VALUES {', '.join([row] * per)}", [flat[i : i + step] for i in range(0, whole * width, step)]
        )
    if count > whole:
        cursor.execute(f"{head} VALUES {', '.join([row] * (count - whole))}", flat[whole * width :])
