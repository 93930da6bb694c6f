"""Rows of a query as plain tuples, in the server's binary format where there is one.

PostgreSQL's text format sends a BLOB (a page, an outline's WKB) as hexadecimal, twice its size,
for the driver to decode again; its binary format sends the bytes as they are.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Connection


def fetch_rows(conn: Connection, q: Any) -> list[tuple[Any, ...]]:
    """The rows of the select ``q`` on ``conn``, as tuples (a Row's attributes cost more than
    the values read through them)."""
    if conn.dialect.name == "sqlite":
        # sqlite3's cursor hands back tuples of plain values; SQLAlchemy's rows around them cost more
        result = conn.execute(q)
        try:
            return list(result.cursor.fetchall())
        finally:
            result.close()
    if conn.dialect.name != "postgresql":
        return [tuple(r) for r in conn.execute(q)]
    compiled = q.compile(dialect=conn.dialect, compile_kwargs={"render_postcompile": True})
    cursor = conn.connection.cursor(binary=True)
    try:
        cursor.execute(str(compiled), compiled.params)
        return [tuple(r) for r in cursor.fetchall()]
    finally:
        cursor.close()
