"""Trees and buildings in the database: one row each, keyed by (version, bx, by, x, y), outline
as WKB.

The key is the B-tree index that an area read walks: (bx, by) is the block of
:data:`tdb.schema.OBJECT_BLOCK` m that holds (x, y), so the rows of one column of blocks
meeting the box are one range of the index, sought column by column, and x and y are checked
within it. A building's key is its footprint's centroid; an outline reaching into the box from
a centroid outside it is found by widening the box by the largest outline's reach, which is
stored in no index but bounded here.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
from sqlalchemy import Connection, and_, insert, select

from tdb import schema
from tdb.fetch import fetch_rows
from tdb.objects import Building, Tree

REACH = 100.0  # m: no crown or footprint reaches further than this from its key


def write_objects(conn: Connection, vid: int, trees: list[Tree], buildings: list[Building]) -> None:
    """Insert one version's trees and buildings (inside the caller's transaction)."""
    if trees:
        conn.execute(
            insert(schema.trees),
            [
                {
                    "version": vid,
                    **_block(t.x, t.y),
                    "x": t.x,
                    "y": t.y,
                    "height": t.height,
                    "crown_diameter": t.crown_diameter,
                    "crown": shapely.to_wkb(t.crown),
                }
                for t in _unique(trees, lambda t: (t.x, t.y))
            ],
        )
    if buildings:
        rows = []
        for b in buildings:
            c = b.footprint.centroid
            rows.append(
                {
                    "version": vid,
                    **_block(c.x, c.y),
                    "x": c.x,
                    "y": c.y,
                    "height": b.height,
                    "area": b.area,
                    "footprint": shapely.to_wkb(b.footprint),
                }
            )
        conn.execute(insert(schema.buildings), _unique(rows, lambda r: (r["x"], r["y"])))


def rekey_objects(conn: Connection) -> None:
    """Rebuild the trees and buildings tables of a schema 4 file, keyed by (x, y) alone, with the
    block leading the key (inside the caller's transaction)."""
    for table in (schema.trees, schema.buildings):
        names = [c.name for c in table.columns if c.name not in ("bx", "by")]
        rows = [dict(zip(names, r)) for r in conn.exec_driver_sql(f"SELECT {', '.join(names)} FROM {table.name}")]
        conn.exec_driver_sql(f"DROP TABLE {table.name}")
        table.create(conn)
        if rows:
            conn.execute(insert(table), [{**r, **_block(r["x"], r["y"])} for r in rows])


def _unique(items: list[Any], key: Any) -> list[Any]:
    """The items with one per key (two objects cannot share a key in the primary index)."""
    seen: set[Any] = set()
    out = []
    for item in items:
        k = key(item)
        if k not in seen:
            seen.add(k)
            out.append(item)
    return out


def _block(x: float, y: float) -> dict[str, int]:
    return {"bx": math.floor(x / schema.OBJECT_BLOCK), "by": math.floor(y / schema.OBJECT_BLOCK)}


def _where(table: Any, vid: int, bbox: tuple[float, float, float, float] | None, *, keyed: bool) -> Any:
    """The rows of version ``vid`` whose key lies within ``REACH`` of ``bbox``; ``keyed`` where the
    table leads its key with the block (schema 5 on), else by x alone (an older file read as it is)."""
    cond = table.c.version == vid
    if bbox is None:
        return cond
    x0, y0, x1, y1 = bbox[0] - REACH, bbox[1] - REACH, bbox[2] + REACH, bbox[3] + REACH
    cond = and_(cond, table.c.x.between(x0, x1), table.c.y.between(y0, y1))
    return and_(cond, schema.in_blocks(table, (x0, y0, x1, y1), schema.OBJECT_BLOCK)) if keyed else cond


def read_trees(
    conn: Connection, vid: int, bbox: tuple[float, float, float, float] | None, *, keyed: bool = True
) -> list[Tree]:
    """The trees of a version whose crown meets ``bbox`` (all where None), tallest first."""
    t = schema.trees
    q = select(t.c.x, t.c.y, t.c.height, t.c.crown_diameter, t.c.crown).where(_where(t, vid, bbox, keyed=keyed))
    rows = fetch_rows(conn, q)
    crowns = _meeting(shapely.from_wkb([r[4] for r in rows]), bbox)
    out = [Tree(x, y, h, d, crown) for (x, y, h, d, _), crown in zip(rows, crowns) if crown is not None]
    return sorted(out, key=lambda tree: -tree.height)


def read_buildings(
    conn: Connection, vid: int, bbox: tuple[float, float, float, float] | None, *, keyed: bool = True
) -> list[Building]:
    """The buildings of a version whose footprint meets ``bbox`` (all where None), largest first."""
    b = schema.buildings
    rows = fetch_rows(conn, select(b.c.height, b.c.footprint).where(_where(b, vid, bbox, keyed=keyed)))
    shapes = _meeting(shapely.from_wkb([r[1] for r in rows]), bbox)
    out = [Building(shape, h) for (h, _), shape in zip(rows, shapes) if shape is not None]
    return sorted(out, key=lambda bd: -bd.area)


def _meeting(shapes: Any, bbox: tuple[float, float, float, float] | None) -> Any:
    """``shapes`` with None in place of those that do not meet ``bbox``."""
    if bbox is None or len(shapes) == 0:
        return shapes
    return np.where(shapely.intersects(shapes, shapely.box(*bbox)), shapes, None)
