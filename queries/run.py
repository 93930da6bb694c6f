"""Run parsed queries against a database and shape the results as GeoJSON features."""

from __future__ import annotations

import operator
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from queries.filters import Filter, Match
from queries.history import change_history
from queries.language import Query, parse
from queries.match import WIDE, broader, find, fits_lines, reads_whole_band, resolve
from queries.object_changes import object_changes
from queries.parts import line_batches
from queries.profile import BAND, Nodes, Stretch, side_of, stretches_of
from tdb.categories import all_categories
from tdb.database import Database
from tdb.errors import QueryError
from tdb.geojson import feature
from tdb.median import weighted_median
from tdb.objects import building_features, tree_features
from tdb.options import Measure
from tdb.progress import Progress, or_silent

OPS = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "=": operator.eq,
    "!=": operator.ne,
    "in": lambda value, texts: value in texts,
}


def run(
    db: Database, text: str, *, progress: Progress | None = None, workers: int | None = None
) -> list[dict[str, Any]]:
    """Run a query; return GeoJSON Feature dicts in the database's CRS. ``progress``
    (:mod:`tdb.progress`) follows the long steps: the parts of a query over a whole survey, the
    cross-sections of a query on ``width``, and each interval's detection of changes. A query over
    a whole survey reads its parts in ``workers`` processes (default: one per core;
    :func:`queries.match.find`, :func:`queries.changes.detect`)."""
    q = parse(text)
    return _order(_near(db, q, _select(db, q, text, progress=progress, workers=workers)), q)


def _order(features: list[dict[str, Any]], q: Query) -> list[dict[str, Any]]:
    if q.order_by is not None and features:
        key = q.order_by
        missing = [f for f in features if f["properties"].get(key) is None]
        if missing:
            have = ", ".join(sorted(missing[0]["properties"]))
            raise QueryError(f"{q.what} results have no attribute {key!r} to order by (they have: {have})")
        features = sorted(features, key=lambda f: f["properties"][key], reverse=q.descending)
    return features if q.limit is None else features[: q.limit]


def _select(
    db: Database, q: Query, text: str, *, progress: Progress | None, workers: int | None
) -> list[dict[str, Any]]:
    db.version(q.version)  # a clear error for an unknown version before any work
    if q.what == "tiles":
        return _tiles(db, q)
    if q.what == "changes":
        return _changes(db, q, text, progress=progress, workers=workers)
    if q.what == "object_changes":
        return _object_changes(db, q, text)
    if q.to_version is not None:
        raise QueryError(
            "TO <version> belongs to SELECT changes", text=text, position=text.lower().find(" to ") + 1
        )
    if q.categories is not None:
        raise QueryError(
            "category IN (...) belongs to SELECT tiles", text=text, position=text.lower().find("category")
        )
    if q.what in OBJECTS:
        return _objects(db, q)
    matches = find(db, q.version, q.what, level=q.level, bbox=q.bbox, progress=progress, workers=workers)
    if "width" in {c.attribute for c in q.conditions} | {q.order_by}:
        return _by_stretch(db, q, matches, progress=progress)
    return [f for f in map(_feature_of, matches) if _keep(f["properties"], q)]


OBJECTS = ("trees", "buildings")  # what stands on the ground, stored per version
FIT_BATCH = 500  # matches whose cross-sections are fitted together: the fits cost less in batches


def _near(db: Database, q: Query, features: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The results within each ``within(distance, kind)`` of the FROM version's trees or buildings."""
    for near in q.near:
        if not features:
            break
        geoms = [shapely.geometry.shape(f["geometry"]) for f in features]
        x0, y0, x1, y1 = shapely.total_bounds(geoms)
        d = near.distance
        box = (x0 - d, y0 - d, x1 + d, y1 + d)
        shapes = (
            [t.crown for t in db.trees(q.version, bbox=box)]
            if near.kind == "trees"
            else [b.footprint for b in db.buildings(q.version, bbox=box)]
        )
        if not shapes:
            return []
        index = shapely.STRtree(shapes)
        hit, _ = index.query(geoms, predicate="dwithin", distance=d)
        keep = set(hit.tolist())
        features = [f for i, f in enumerate(features) if i in keep]
    return features


def _objects(db: Database, q: Query) -> list[dict[str, Any]]:
    """Trees (crowns, with their top's x and y) or buildings (footprints) meeting the box."""
    if q.what == "trees":
        found = tree_features(db.trees(q.version, bbox=q.bbox))
    else:
        found = building_features(db.buildings(q.version, bbox=q.bbox))
    return [f for f in found if _keep(f["properties"], q)]


def _object_changes(db: Database, q: Query, text: str) -> list[dict[str, Any]]:
    """Trees felled and new, buildings removed and added, FROM a TO b (:mod:`queries.object_changes`)."""
    if q.to_version is None or len(q.to_versions) != 1:
        raise QueryError("SELECT object_changes needs FROM <version> TO <version>", text=text, position=0)
    db.version(q.to_version)
    return [f for f in object_changes(db, q.version, q.to_version, bbox=q.bbox) if _keep(f["properties"], q)]


def _changes(
    db: Database, q: Query, text: str, *, progress: Progress | None, workers: int | None
) -> list[dict[str, Any]]:
    """Changes FROM a TO b [TO c …]: co-registered on stable ground, as :mod:`queries.history` says."""
    if q.to_version is None:
        raise QueryError("SELECT changes needs FROM <version> TO <version>", text=text, position=0)
    for name in q.to_versions:
        db.version(name)
    versions = [q.version, *q.to_versions]
    found = change_history(db, versions, level=q.level or 2, bbox=q.bbox, progress=progress, workers=workers)
    return [f for f in found if _keep(f["properties"], q)]


def _feature_of(m: Match) -> dict[str, Any]:
    props: dict[str, Any] = {
        "kind": m.filter,
        "level": m.level,
        "tiles": len(m.tiles),
        "length": round(m.length, 2),
        ("depth" if m.filter in ("ditch", "pit") else "height"): round(m.measure, 3),
    }
    if np.isfinite(m.shoulder):
        props["shoulder"] = round(m.shoulder, 2)
    return feature(m.geometry, props)


def _by_stretch(
    db: Database, q: Query, matches: list[Match], *, progress: Progress | None = None
) -> list[dict[str, Any]]:
    """Matches cut into stretches with their own cross-section (:mod:`queries.profile`): the
    stretches whose width and depth (height) pass the query, joined where they follow on."""
    report = or_silent(progress)
    flt = resolve(q.what)
    if not flt.linear or flt.measure is Measure.STEP:
        raise QueryError(f"{q.what} results have no width: ditch, ridge and wall lines do")
    if not matches:
        return []
    name = flt.measure.value
    pieces, broad = _stretches_by_parts(db, q.version, matches, flt, report)
    by_piece = Query(q.what, q.version, conditions=[c for c in q.conditions if c.attribute in ("width", name)])
    kept = [(m, own) for m, own, b in zip(matches, pieces, broad) if not b]
    return [f for m, own in kept for f in _passing_runs(m, own, q, by_piece, name)]


def _stretches_by_parts(
    db: Database, version: str, matches: list[Match], flt: Filter, report: Progress
) -> tuple[list[list[Stretch]], NDArray[np.bool_]]:
    """Each match's stretches (:func:`queries.profile.stretches_of`), the matches taken part by
    part (:func:`queries.parts.line_batches`), each part's with the stored points of its box; and
    per match whether it is broader than ``flt.max_width`` (:func:`queries.match.broader`, read
    where the usual stretches see no feet) for a filter whose matching does not read it
    (:func:`queries.match.fits_lines`): there every match has passed it already."""
    level = matches[0].level
    geoms = [m.geometry for m in matches]
    out: list[list[Stretch]] = [[] for _ in matches]
    broad = np.zeros(len(matches), bool)
    done = 0
    most = None if fits_lines(flt) else flt.max_width
    reach = side_of(BAND if most is None else WIDE * BAND)[1]  # the wide fits read farther off
    for idx, box in line_batches(shapely.bounds(geoms), level=level, grow=reach + level):
        nodes = Nodes.of(*db.points(version, level=level, bbox=box, ordered=False)[:3])
        for s in range(0, len(idx), FIT_BATCH):
            report("cross-sections", done, len(matches))
            batch = idx[s : s + FIT_BATCH]
            for k, own in zip(batch, stretches_of([geoms[k] for k in batch], nodes, measure=flt.measure)):
                out[k] = own
            if most is not None:
                whole = [k for k in batch if reads_whole_band(out[k])]
                wide = stretches_of([geoms[k] for k in whole], nodes, measure=flt.measure, band=WIDE * BAND)
                broad[whole] = [broader(w, most) for w in wide]
            done += len(batch)
    return out, broad


def _passing_runs(m: Match, pieces: list[Stretch], q: Query, by_piece: Query, name: str) -> list[dict[str, Any]]:
    """The runs of a match's consecutive pieces (on one part) that pass ``by_piece``, as
    features with their length-weighted depth (height) and width, where they pass ``q``."""
    runs: list[list[Stretch]] = []
    for st in pieces:
        if not (np.isfinite(st.width) and _keep({"width": st.width, name: st.measure}, by_piece)):
            runs.append([])
        elif runs and runs[-1] and runs[-1][-1].part == st.part:
            runs[-1].append(st)
        else:
            runs.append([st])
    out = []
    for run_ in filter(None, runs):
        weight = np.array([st.line.length for st in run_])
        props = {
            "kind": m.filter,
            "level": m.level,
            "tiles": len(m.tiles),
            "length": round(float(weight.sum()), 2),
            name: round(weighted_median(np.array([st.measure for st in run_]), weight), 3),
            "width": round(weighted_median(np.array([st.width for st in run_]), weight), 2),
        }
        if np.isfinite(m.shoulder):
            props["shoulder"] = round(m.shoulder, 2)
        if _keep(props, q):
            geom = shapely.line_merge(shapely.union_all([st.line for st in run_]))
            out.append(feature(geom, props))
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
        feats.append(feature(shapely.box(x, y, x + level, y + level), props))
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
