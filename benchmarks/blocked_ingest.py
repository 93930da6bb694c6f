"""Ingest of a large file whole and block by block: speed, memory, and whether the two agree.

One process per run, so that each run's peak memory is its own (a blocked run's workers
counted apart); each timed run is repeated three times and the median kept, as one run's time
varies by a tenth on a shared machine. The blocked run is timed with one worker per core and
with one worker (the scaling). The blocked run is compared with the whole one tile by tile at every level,
once with the flat threshold measured its own way (from the fullest block) and once with the
whole run's, which isolates what blocking itself changes.
    python -m benchmarks.blocked_ingest [--file isprs/FSite5_orig-utm.laz] [--block 512]
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import tdb
from benchmarks.common import DATA, file_run_args, median_run, run_child, save
from tdb.memory import peak_mib, workers_peak_mib
from tdb.tiles import LEVELS


def _run(kind: str, src: str, db_path: str, block: float, threshold: float | None) -> None:
    """One ingest in this process; prints its seconds and peak memory as JSON."""
    from ingest.blocked import Blocking, ingest_blocked
    from ingest.pipeline import IngestOptions, ingest

    db = tdb.open(db_path, create=True)
    options = IngestOptions(flat_threshold=threshold)
    t0 = time.perf_counter()
    told = None
    if kind == "whole":
        ingest(src, db, version=kind, options=options)
    elif kind == "read":
        from ingest.readers import read

        read(src)
    else:
        workers = 1 if kind == "blocks_one_worker" else None  # None: one per core
        v = ingest_blocked(src, db, version=kind, options=options, blocking=Blocking(block=block, workers=workers))
        told = v.params.get("worker_peak_mib")  # the workers' own figure: they are not this process's children
    seconds = time.perf_counter() - t0
    own = peak_mib()
    worker_mib = workers_peak_mib(told)
    print(json.dumps({"seconds": seconds, "peak_rss_mib": own, "worker_peak_rss_mib": worker_mib}))


def _same(db: Any, a: str, b: str, level: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tiles of ``a`` at ``level`` (corners) and whether ``b`` gives each the same category."""
    xa, ya, ca = db.tiles(a, level=level)
    xb, yb, cb = db.tiles(b, level=level)
    kb = dict(zip(zip(xb.tolist(), yb.tolist()), cb.tolist()))
    return xa, ya, np.array([kb.get(k) == c for k, c in zip(zip(xa.tolist(), ya.tolist()), ca.tolist())])


def _agreement(db: Any, a: str, b: str) -> dict[str, float]:
    out = {}
    for level in LEVELS:
        out[f"same_{level}m_pct"] = 100 * float(np.mean(_same(db, a, b, level)[2]))
    out["kept_2m_points_ratio"] = len(db.points(b, level=2)[0]) / max(len(db.points(a, level=2)[0]), 1)
    return out


MAP = Path(__file__).resolve().parents[1] / "docs" / "images" / "blocked-vs-whole.png"


def _agreement_map(db: Any, a: str, b: str, block: float) -> None:
    """The 2 m tiles of ``b`` against ``a``, with the block edges: a seam would show along them."""
    from tdb.pictures import agreement_map

    xa, ya, same = _same(db, a, b, 2)
    edges = tuple(
        np.arange(np.ceil(lo / block) * block, hi, block)
        for lo, hi in ((xa.min(), xa.max()), (ya.min(), ya.max()))
    )
    agreement_map(
        MAP,
        xa,
        ya,
        same,
        level=2,
        edges=edges,
        crs=db.crs(a),
        title=f"Blocked ingest ({block:g} m blocks) against one piece: 2 m tiles whose category differs",
    )


def main() -> None:
    args = file_run_args(__doc__)
    if args.run:
        kind, src, db_path, block, threshold = args.run
        _run(kind, src, db_path, float(block), None if threshold == "-" else float(threshold))
        return
    src = str(DATA / args.file)

    def child(kind: str, db_path: str, threshold: float | None = None) -> dict[str, float]:
        limit = "-" if threshold is None else repr(threshold)
        return run_child("blocked_ingest", kind, src, db_path, str(args.block), limit)

    with tempfile.TemporaryDirectory() as tmp:
        db_path = str(Path(tmp) / "b.tdb")

        def timed(kind: str) -> dict[str, Any]:
            """The median of three runs; the first stores its version in the compared database."""
            return median_run(lambda i: child(kind, db_path if i == 0 else str(Path(tmp) / f"{kind}{i}.tdb")))

        runs = {"read": child("read", db_path), "whole": timed("whole")}
        db = tdb.open(db_path)
        whole = db.version("whole")
        runs["blocks"] = timed("blocks")
        runs["blocks_one_worker"] = timed("blocks_one_worker")
        runs["blocks_same_threshold"] = child("blocks_same_threshold", db_path, whole.params["flat_threshold"])
        db = tdb.open(db_path)
        b = whole.stats.bounds or (0.0, 0.0, 0.0, 0.0)
        km2 = (b[2] - b[0]) * (b[3] - b[1]) / 1e6
        points = whole.stats.points
        for r in runs.values():
            r["points_per_s"] = points / r["seconds"]
            r["s_per_km2"] = r["seconds"] / km2
        doc = {
            "file": args.file,
            "points": points,
            "km2": km2,
            "block_m": args.block,
            "blocks": db.version("blocks").params.get("blocks"),
            "speedup_all_cores": runs["blocks_one_worker"]["seconds"] / runs["blocks"]["seconds"],
            "runs": runs,
            "agreement": _agreement(db, "whole", "blocks"),
            "agreement_same_threshold": _agreement(db, "whole", "blocks_same_threshold"),
            "rmse_m": {v: db.version(v).stats.reduction.rmse_m for v in ("whole", "blocks")},
        }
        _agreement_map(db, "whole", "blocks", args.block)
    print(doc)
    print(save("blocked_ingest", doc))


if __name__ == "__main__":
    main()
