"""Trees and buildings in the database: one row each, keyed by (version, x, y), outline as WKB.

The key is the B-tree index that an area read walks: rows of one version whose x falls in the
box are a range of it, and y is checked within that range. A building's key is its footprint's
centroid; an outline reaching into the box from a centroid outside it is found by widening the
box by the largest outline's reach, which is stored in no index but bounded here.
"""

from __future__ import annotations

from typing import Any

import shapely
from sqlalchemy import Connection, and_, insert, select

from tdb import schema
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
                    "x": c.x,
                    "y": c.y,
                    "height": b.height,
                    "area": b.area,
                    "footprint": shapely.to_wkb(b.footprint),
                }
            )
        conn.execute(insert(schema.buildings), _unique(rows, lambda r: (r["x"], r["y"])))


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


def _where(table: Any, vid: int, bbox: tuple[float, float, float, float] | None) -> Any:
    cond = table.c.version == vid
    if bbox is not None:
        x0, y0, x1, y1 = bbox
        cond = and_(
            cond,
            table.c.x >= x0 - REACH,
            table.c.x <= x1 + REACH,
            table.c.y >= y0 - REACH,
            table.c.y <= y1 + REACH,
        )
    return cond


def read_trees(conn: Connection, vid: int, bbox: tuple[float, float, float, float] | None) -> list[Tree]:
    """The trees of a version whose crown meets ``bbox`` (all where None), tallest first."""
    t = schema.trees
    q = select(t.c.x, t.c.y, t.c.height, t.c.crown_diameter, t.c.crown).where(_where(t, vid, bbox))
    out = [Tree(r.x, r.y, r.height, r.crown_diameter, shapely.from_wkb(r.crown)) for r in conn.execute(q)]
    if bbox is not None:
        box = shapely.box(*bbox)
        out = [tree for tree in out if tree.crown.intersects(box)]
    return sorted(out, key=lambda tree: -tree.height)


def read_buildings(conn: Connection, vid: int, bbox: tuple[float, float, float, float] | None) -> list[Building]:
    """The buildings of a version whose footprint meets ``bbox`` (all where None), largest first."""
    b = schema.buildings
    q = select(b.c.height, b.c.footprint).where(_where(b, vid, bbox))
    out = [Building(shapely.from_wkb(r.footprint), r.height) for r in conn.execute(q)]
    if bbox is not None:
        box = shapely.box(*bbox)
        out = [bd for bd in out if bd.footprint.intersects(box)]
    return sorted(out, key=lambda bd: -bd.area)
