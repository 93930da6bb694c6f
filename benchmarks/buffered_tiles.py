"""A survey delivered as buffered tiles against the same survey in one file.

The file is cut into 2 × 2 tiles at its median x and y, each reaching ``--buffer`` metres into
its neighbours (as providers deliver tiles with a buffer), and written as LAZ. Both are ingested
block by block in the same way; reported: the points each version counts, the points the catalog
dropped as held twice, whether every level's tiles and the kept points are the same, the trees,
and the seconds of each.

    python -m benchmarks.buffered_tiles [--file isprs/FSite5_orig-utm.laz] [--buffer 20] [--block 512]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import laspy
import numpy as np

import tdb
from benchmarks.common import DATA, save
from ingest.blocked import Blocking, ingest_blocked
from tdb.tiles import LEVELS


def cut(src: Path, out: Path, *, buffer: float) -> int:
    """``src`` cut into four buffered tiles in ``out``; the points they hold together."""
    las = laspy.read(src)
    x, y = np.asarray(las.x), np.asarray(las.y)
    xm, ym = float(np.median(x)), float(np.median(y))
    held = 0
    for i, (xa, xb) in enumerate([(-np.inf, xm + buffer), (xm - buffer, np.inf)]):
        for j, (ya, yb) in enumerate([(-np.inf, ym + buffer), (ym - buffer, np.inf)]):
            part = (x >= xa) & (x < xb) & (y >= ya) & (y < yb)
            tile = laspy.LasData(las.header)
            tile.points = las.points[part]
            tile.write(out / f"tile{i}{j}.laz")
            held += int(part.sum())
    return held


def _same_share(db: Any, level: int) -> float:
    (xa, ya, ca), (xb, yb, cb) = (db.tiles(v, level=level) for v in ("file", "tiles"))
    a = dict(zip(zip(xa.tolist(), ya.tolist()), ca.tolist()))
    b = dict(zip(zip(xb.tolist(), yb.tolist()), cb.tolist()))
    return 100.0 * float(np.mean([a[k] == b.get(k) for k in a]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--file", default="isprs/FSite5_orig-utm.laz")
    parser.add_argument("--buffer", type=float, default=20.0)
    parser.add_argument("--block", type=float, default=512.0)
    args = parser.parse_args()
    src = DATA / args.file
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        held = cut(src, tmp, buffer=args.buffer)
        db = tdb.open(tmp / "d.tdb", create=True)
        seconds = {}
        for version, source in (("file", str(src)), ("tiles", str(tmp / "tile*.laz"))):
            t0 = time.perf_counter()
            ingest_blocked(source, db, version=version, blocking=Blocking(block=args.block))
            seconds[version] = time.perf_counter() - t0
        a, b = db.version("file"), db.version("tiles")
        pa, pb = db.points("file", level=2), db.points("tiles", level=2)
        doc = {
            "file": args.file,
            "buffer_m": args.buffer,
            "block_m": args.block,
            "points_in_tiles": held,
            "points": {"file": a.stats.points, "tiles": b.stats.points},
            "dropped": b.params.get("overlap_points_dropped", 0),
            "same_tiles_pct": {str(lv): _same_share(db, lv) for lv in LEVELS},
            "kept_points": {"file": len(pa[0]), "tiles": len(pb[0])},
            "kept_points_identical": all(np.array_equal(p, q) for p, q in zip(pa, pb)),
            "trees": {"file": len(db.trees("file")), "tiles": len(db.trees("tiles"))},
            "seconds": seconds,
        }
    print(doc)
    print(save("buffered_tiles", doc))


if __name__ == "__main__":
    main()
