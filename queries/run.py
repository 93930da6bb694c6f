"""Run parsed queries against a database and shape the results as GeoJSON features."""

from __future__ import annotations

import operator
from typing import Any

import numpy as np
import shapely

from queries.language import Query, parse
from queries.match import find
from tdb.categories import all_categories
from tdb.database import Database
from tdb.errors import QueryError

OPS = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "=": operator.eq,
    "!=": operator.ne,
    "in": lambda value, texts: value in texts,
}


def run(db: Database, text: str) -> list[dict[str, Any]]:
    """Run a query; return GeoJSON Feature dicts in the database's CRS."""
    q = parse(text)
    return _order(_select(db, q, text), q)


def _order(features: list[dict[str, Any]], q: Query) -> list[dict[str, Any]]:
    if q.order_by is not None and features:
        key = q.order_by
        missing = [f for f in features if f["properties"].get(key) is None]
        if missing:
            have = ", ".join(sorted(missing[0]["properties"]))
            raise QueryError(f"{q.what} results have no attribute {key!r} to order by (they have: {have})")
        features = sorted(features, key=lambda f: f["properties"][key], reverse=q.descending)
    return features if q.limit is None else features[: q.limit]


def _select(db: Database, q: Query, text: str) -> list[dict[str, Any]]:
    db.version(q.version)  # a clear error for an unknown version before any work
    if q.what == "tiles":
        return _tiles(db, q)
    if q.what == "changes":
        if q.to_version is None:
            raise QueryError("SELECT changes needs FROM <version> TO <version>", text=text, position=0)
        from queries.changes import detect

        found = detect(db, q.version, q.to_version, level=q.level or 2, bbox=q.bbox)
        return [f for f in found if _keep(f["properties"], q)]
    if q.to_version is not None:
        raise QueryError(
            "TO <version> belongs to SELECT changes", text=text, position=text.lower().find(" to ") + 1
        )
    if q.categories is not None:
        raise QueryError(
            "category IN (...) belongs to SELECT tiles", text=text, position=text.lower().find("category")
        )
    out = []
    for m in find(db, q.version, q.what, level=q.level, bbox=q.bbox):
        props = {
            "kind": m.filter,
            "level": m.level,
            "tiles": len(m.tiles),
            "length": round(m.length, 2),
            ("depth" if m.filter in ("ditch", "pit") else "height"): round(m.measure, 3),
        }
        if np.isfinite(m.shoulder):
            props["shoulder"] = round(m.shoulder, 2)
        if _keep(props, q):
            out.append({"type": "Feature", "geometry": shapely.geometry.mapping(m.geometry), "properties": props})
    return out


def _tiles(db: Database, q: Query) -> list[dict[str, Any]]:
    level = q.level or 2
    xg, yg, code = db.tiles(q.version, level=level, bbox=q.bbox, categories=q.categories)
    cats = all_categories()
    feats = []
    for x, y, c in zip(xg.tolist(), yg.tolist(), code.tolist()):
        props = {
            "xg": x,
            "yg": y,
            "level": level,
            "category": c,
            "description": cats[c].description if c < len(cats) else "no data",
        }
        feats.append(
            {
                "type": "Feature",
                "geometry": shapely.geometry.mapping(shapely.box(x, y, x + level, y + level)),
                "properties": props,
            }
        )
    return [f for f in feats if _keep(f["properties"], q)]


def _keep(props: dict[str, Any], q: Query) -> bool:
    for cond in q.conditions:
        value = props.get(cond.attribute)
        if value is None:
            raise QueryError(
                f"{q.what} results have no attribute {cond.attribute!r} (they have: {', '.join(sorted(props))})"
            )
        if not OPS[cond.op](value, cond.value):
            return False
    return True


def feature_collection(features: list[dict[str, Any]], crs: Any) -> dict[str, Any]:
    doc: dict[str, Any] = {"type": "FeatureCollection", "features": features}
    if crs is not None and crs.to_epsg():
        doc["crs"] = {"type": "name", "properties": {"name": f"urn:ogc:def:crs:EPSG::{crs.to_epsg()}"}}
    return doc
