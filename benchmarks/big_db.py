"""Queries on a terrain database of more than 1,000 km²: a 1 km² area read, a ditch query and a diff.

Ingesting 1,000 km² of point clouds is not what this measures (``blocked_ingest`` measures
ingest). The database is built from one real ingest: the 1 km² synthetic pair of
``changes_synth`` (a scene and its re-survey after four rounds of changes, 4 points/m²) is
ingested once, and its two versions' tiles, kept points, ground evidence, trees and buildings
are written 32 × 32 times side by side, 1024 m apart (a multiple of every page's side but the
16 m level's, whose pages are merged across copies), through the same version writer a blocked
ingest uses, one column of copies per part. Each query is timed over 1 km² boxes placed at
random over the whole area (on the lattice of copies and off it), in a fresh process, an SQLite
file's pages first dropped from the system's cache.

    python -m benchmarks.big_db [--copies 32] [--after-copies N] [--density 4] [--dir DIR] [--url postgresql://...]

``--after-copies`` writes the re-survey over fewer copies than the first survey (a corner of it),
where the disk holds the first survey's 1,000 km² but not twice that: the area read and the
ditch query run over the whole first survey, the diff over boxes inside the corner both cover.
A version already complete in the target database is kept, so a build cut short goes on.
``--compact`` rewrites an SQLite target compact before the queries (``tdb compact``, into a new
file moved over the old: it needs free disk for one copy), as a user would once a large database
is written; its seconds are recorded.

Results go to ``big_db[_cCOPIES][_dDENSITY][_postgresql].json`` (the suffixes where not the
defaults).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

import tdb
from benchmarks.changes_synth import km2_pair
from benchmarks.common import RESULTS, peak_rss_mib, save
from queries.changes import detect
from queries.match import find
from tdb import point_pages, schema
from tdb.compact import compact
from tdb.database import Database, VersionInfo
from tdb.evidence import TileEvidence
from tdb.objects import Building, Tree

STEP = 1024  # m between copies
QUERIES = 10


@dataclasses.dataclass
class Part:
    """Everything one version holds, to be written again at an offset."""

    levels: dict[int, tuple[Any, ...]]
    points: tuple[Any, Any, Any, Any]
    evidence: TileEvidence
    trees: list[Tree]
    buildings: list[Building]


def read_part(db: Database, version: str) -> Part:
    vid = db.version(version).id
    levels = {lv: db.tiles(version, level=lv, ordered=False) for lv in schema.LEVEL_TABLES}
    with db.engine.connect() as conn:
        pages = [
            (int(r[0]), int(r[1]), bytes(r[2]))
            for r in conn.execute(
                schema.point_blocks.select()
                .with_only_columns(schema.point_blocks.c.bx, schema.point_blocks.c.by, schema.point_blocks.c.data)
                .where(schema.point_blocks.c.version == vid)
            )
        ]
    inf = float("inf")
    points = point_pages.points_from_blocks(pages, (-inf, -inf, inf, inf), mask=0xFF)
    return Part(levels, points, db.evidence(version), db.trees(version), db.buildings(version))


def shifted(part: Part, dx: int, dy: int) -> Part:
    import shapely

    offset = np.array([dx, dy], float)

    def move(g: Any) -> Any:
        return shapely.transform(g, lambda c: c + offset)

    return Part(
        {lv: (xg + dx, yg + dy, c) for lv, (xg, yg, c) in part.levels.items()},
        (part.points[0] + dx, part.points[1] + dy, part.points[2], part.points[3]),
        dataclasses.replace(part.evidence, xg=part.evidence.xg + dx, yg=part.evidence.yg + dy),
        [dataclasses.replace(t, x=t.x + dx, y=t.y + dy, crown=move(t.crown)) for t in part.trees],
        [dataclasses.replace(b, footprint=move(b.footprint)) for b in part.buildings],
    )


def column(part: Part, i: int, copies: int) -> Part:
    """The copies of column ``i``, as one part."""
    cs = [shifted(part, i * STEP, j * STEP) for j in range(copies)]
    cat = np.concatenate
    return Part(
        {lv: tuple(cat([c.levels[lv][k] for c in cs]) for k in range(3)) for lv in part.levels},
        tuple(cat([c.points[k] for c in cs]) for k in range(4)),  # type: ignore[arg-type]
        TileEvidence(*(cat([getattr(c.evidence, f) for c in cs]) for f in ("xg", "yg", *TileEvidence.FIELDS))),
        [t for c in cs for t in c.trees],
        [b for c in cs for b in c.buildings],
    )


def build(source: Database, target: Database, copies: int, after_copies: int) -> dict[str, float]:
    seconds = {}
    have = {v.name for v in target.versions()}
    for version, side in (("before", copies), ("after", after_copies)):
        if version in have:
            continue
        v = source.version(version)
        part = read_part(source, version)
        x0, y0, x1, y1 = v.stats.bounds or (0.0, 0.0, 0.0, 0.0)
        bounds = (x0, y0, x1 + (side - 1) * STEP, y1 + (side - 1) * STEP)
        stats = json.loads(json.dumps(v.stats.to_json()))
        stats["bounds"] = list(bounds)
        info = VersionInfo(acquired=v.acquired, source=f"{side}² copies of {v.source}", crs=v.crs)
        t0 = time.perf_counter()
        with target.writing(version, info=info) as w:
            for i in range(side):
                c = column(part, i, side)
                w.add(levels=c.levels, points=c.points, evidence=c.evidence, objects=(c.trees, c.buildings))
                print(f"{version}: column {i + 1}/{side}, {time.perf_counter() - t0:.0f} s", flush=True)
            w.describe(params=v.params, stats=stats)
        seconds[version] = time.perf_counter() - t0
    return seconds


def boxes(
    db: Database, n: int, seed: int = 0, *, version: str = "before"
) -> list[tuple[float, float, float, float]]:
    x0, y0, x1, y1 = db.version(version).stats.bounds or (0.0, 0.0, 0.0, 0.0)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        bx, by = rng.uniform(x0, x1 - 1000), rng.uniform(y0, y1 - 1000)
        out.append((float(bx), float(by), float(bx + 1000), float(by + 1000)))
    return out


def timed(fn: Any, box_list: list[Any]) -> list[float]:
    out = []
    for box in box_list:
        t0 = time.perf_counter()
        fn(box)
        out.append(time.perf_counter() - t0)
    return out


def queries(db: Database) -> dict[str, Any]:
    box_list = boxes(db, QUERIES)
    aoi = timed(lambda b: db.aoi(b, level=2, version="before"), box_list)
    # the same boxes again: their pages now in the system's cache, as for a user who reads an
    # area twice or a database smaller than the memory
    aoi_warm = timed(lambda b: db.aoi(b, level=2, version="before"), box_list)
    ditch = timed(lambda b: find(db, "before", "ditch", bbox=b), box_list)
    diff = timed(lambda b: detect(db, "before", "after", bbox=b), boxes(db, QUERIES, version="after"))
    area = db.aoi(box_list[0], level=2, version="before")
    return {
        "aoi_ms": [1000 * s for s in aoi],
        "ditch_s": ditch,
        "diff_s": diff,
        "aoi_ms_median": 1000 * float(np.median(aoi)),
        "aoi_warm_ms": [1000 * s for s in aoi_warm],
        "aoi_warm_ms_median": 1000 * float(np.median(aoi_warm)),
        "ditch_s_median": float(np.median(ditch)),
        "diff_s_median": float(np.median(diff)),
        "aoi_tiles": len(area.code),
        "aoi_points": len(area.x),
    }


def compacted(target: str) -> float:
    """Seconds to compact the database ``target`` (:mod:`tdb.compact`): in place for a server,
    into a new file moved over the old for SQLite."""
    t0 = time.perf_counter()
    with tdb.open(target) as db:
        if "://" in target:
            compact(db)
            return time.perf_counter() - t0
        copy = Path(target).with_name(Path(target).stem + "-compact.tdb")
        compact(db, into=copy)
    copy.replace(target)
    return time.perf_counter() - t0


def uncache(path: Path) -> None:
    """Let the system's cache drop the file's pages, so that the first reads of each box come from
    the disk whatever ran before (the build, a compaction), as in a fresh session."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
    finally:
        os.close(fd)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--copies", type=int, default=32)
    p.add_argument("--after-copies", type=int, help="copies of the re-survey (default: --copies)")
    p.add_argument("--dir", type=Path, default=Path("/tmp/tdb-big"), help="where the databases are made and kept")
    p.add_argument("--density", type=float, default=4.0, help="points per m² of the ingested pair")
    p.add_argument("--url", help="a PostgreSQL database to fill instead of an SQLite file")
    p.add_argument("--compact", action="store_true", help="compact the database before the queries")
    a = p.parse_args()
    after_copies = a.after_copies or a.copies
    tag = (
        f"_c{a.copies}" * (a.copies != 32)
        + f"_a{after_copies}" * (after_copies != a.copies)
        + f"_d{a.density:g}" * (a.density != 4.0)
    )
    work = a.dir / f"d{a.density:g}" if a.density != 4.0 else a.dir
    work.mkdir(parents=True, exist_ok=True)
    km2 = work / "km2.tdb"
    if not km2.exists():
        km2 = km2_pair(work, density=a.density)
    target_name = a.url or str(a.dir / f"big{a.copies}.tdb")
    with tdb.open(km2) as source, tdb.open(target_name, create=True) as target:
        built = build(source, target, a.copies, after_copies)
    compact_s = compacted(target_name) if a.compact else None
    if not a.url:
        uncache(Path(target_name))
    with tdb.open(target_name) as db:
        bounds = db.version("before").stats.bounds or (0.0, 0.0, 0.0, 0.0)
        after = db.version("after").stats.bounds or (0.0, 0.0, 0.0, 0.0)
        size = None if a.url else Path(target_name).stat().st_size / 2**20
        doc = {
            "backend": "postgresql" if a.url else "sqlite",
            "copies": a.copies,
            "density": a.density,
            "area_km2": (bounds[2] - bounds[0]) * (bounds[3] - bounds[1]) / 1e6,
            "after_area_km2": (after[2] - after[0]) * (after[3] - after[1]) / 1e6,
            "rows_2m": db.count("before", table="c2"),
            "points": db.count("before"),
            "build_s": built,
            "file_mib": size,
            "compacted": a.compact,
            "compact_s": compact_s,
            **queries(db),
            "peak_rss_mib": peak_rss_mib(),
        }
    print(json.dumps({k: v for k, v in doc.items() if not isinstance(v, list)}, indent=1))
    name = "big_db" + tag + "_postgresql" * bool(a.url)
    earlier = RESULTS / f"{name}.json"
    if earlier.exists():  # a version written by an earlier run keeps the seconds it took then
        doc["build_s"] = {**json.loads(earlier.read_text()).get("build_s", {}), **(built or {})}
    print(save(name, doc))


if __name__ == "__main__":
    main()
